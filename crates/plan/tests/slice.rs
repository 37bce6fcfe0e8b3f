//! Slicing analytic solids made here: spheres, tori, cubes with faces in the planes,
//! open and inside-out meshes, fans, volume by slice areas.

use std::f64::consts::PI;

use lampost_mesh::{box_mesh, props::volume, torus, uv_sphere, Mesh, P3};
use lampost_plan::{slice, PlanError, Planes, SliceOptions, Slicing};

fn parallel(mesh: &Mesh, dir: P3, layer: f64, threads: usize) -> Result<Slicing, PlanError> {
    slice(
        mesh,
        &SliceOptions {
            planes: Planes::Parallel {
                dir,
                layer,
                first: None,
            },
            stitch: None,
            threads,
        },
    )
}

fn z() -> P3 {
    P3::new(0.0, 0.0, 1.0)
}

#[test]
fn sphere_slices_are_circles_within_the_chordal_error() {
    let (r, c) = (20.0, P3::new(3.0, -4.0, 5.0));
    let (rings, segs) = (90, 180);
    let m = uv_sphere(c, r, rings, segs);
    let s = parallel(&m, z(), 0.5, 2).expect("slices");
    assert_eq!(s.slices.len(), 80);
    // First plane half a layer above the bottom.
    assert!((s.slices[0].height - (c.z - r + 0.25)).abs() < 1e-12);
    // Chordal error: a point on a facet is within r(1 − cos(π/rings)·cos(π/segs)) of the sphere.
    let chord = r * (1.0 - (PI / f64::from(rings)).cos() * (PI / f64::from(segs)).cos());
    for sl in &s.slices {
        assert_eq!(sl.loops.len(), 1, "layer {}", sl.index);
        assert!(sl.open.is_empty() && sl.gaps.is_empty());
        let l = &sl.loops[0];
        let zz = sl.height - c.z;
        let rc = (r * r - zz * zz).sqrt();
        for p in &l.points {
            assert!((p.z - sl.height).abs() < 1e-9);
            let d = ((p - c).xy()).norm();
            assert!(
                d <= rc + 1e-9 && d >= rc - chord * 3.0,
                "layer {}: {d} vs {rc}",
                sl.index
            );
        }
        assert!(l.area > 0.0, "outer loop counter-clockwise");
        assert!(l.area <= PI * rc * rc + 1e-9);
        assert_eq!(l.faces.len(), l.points.len());
    }
}

#[test]
fn each_loop_point_keeps_the_face_holding_its_segment() {
    let m = uv_sphere(P3::zeros(), 5.0, 20, 40);
    let s = parallel(&m, P3::new(1.0, 2.0, 3.0), 0.3, 1).expect("slices");
    for sl in &s.slices {
        for l in &sl.loops {
            for i in 0..l.points.len() {
                let (p, q) = (l.points[i], l.points[(i + 1) % l.points.len()]);
                let t = m.triangles[l.faces[i] as usize].map(|k| m.vertices[k as usize]);
                let n = (t[1] - t[0]).cross(&(t[2] - t[0])).normalize();
                // Both ends in the face's plane, and the segment runs along d × n.
                assert!((p - t[0]).dot(&n).abs() < 1e-9 && (q - t[0]).dot(&n).abs() < 1e-9);
                assert!((q - p).dot(&sl.normal.cross(&n)) >= -1e-12);
            }
        }
    }
}

#[test]
fn torus_middle_slices_have_an_outer_loop_and_a_hole() {
    let m = torus(P3::zeros(), 20.0, 5.0, 120, 60);
    let s = parallel(&m, z(), 1.0, 2).expect("slices");
    assert_eq!(s.slices.len(), 10);
    for sl in &s.slices {
        assert_eq!(sl.loops.len(), 2, "layer {}", sl.index);
        let mut a: Vec<f64> = sl.loops.iter().map(|l| l.area).collect();
        a.sort_by(f64::total_cmp);
        assert!(a[0] < 0.0 && a[1] > 0.0, "{a:?}");
        // Annulus between 20 ± sqrt(25 − z²).
        let h = (25.0 - sl.height * sl.height).sqrt();
        let want = PI * ((20.0 + h).powi(2) - (20.0 - h).powi(2));
        assert!(
            ((a[0] + a[1]) - want).abs() / want < 2e-2,
            "{} vs {want}",
            a[0] + a[1]
        );
    }
}

#[test]
fn cube_faces_lying_in_slicing_planes_follow_the_rule() {
    // Layers of 1 starting at 0 (first = 0): planes at z = 0, 1, 2, 3 (not 4, the top).
    let m = box_mesh(P3::zeros(), P3::new(2.0, 3.0, 4.0));
    let s = slice(
        &m,
        &SliceOptions {
            planes: Planes::Parallel {
                dir: z(),
                layer: 1.0,
                first: Some(0.0),
            },
            stitch: None,
            threads: 1,
        },
    )
    .expect("slices");
    assert_eq!(s.slices.len(), 4);
    // z = 0: the bottom face's vertices count as above, nothing is below: no loop.
    assert!(s.slices[0].loops.is_empty() && s.slices[0].open.is_empty());
    for sl in &s.slices[1..] {
        assert_eq!(sl.loops.len(), 1);
        let l = &sl.loops[0];
        // Four corners and the four crossings of the side faces' diagonals.
        assert_eq!(l.points.len(), 8);
        for p in &l.points {
            let on_side = p.x == 0.0 || p.x == 2.0 || p.y == 0.0 || p.y == 3.0;
            assert!(on_side && (p.z - sl.height).abs() < 1e-15, "{p}");
        }
        assert!((l.area - 6.0).abs() < 1e-12 && (l.length - 10.0).abs() < 1e-12);
    }
    // A plane through the middle of a face-aligned cube at half layers: the same squares.
    let s = parallel(&m, z(), 1.0, 1).expect("slices");
    assert_eq!(s.slices.len(), 4);
    assert!(s
        .slices
        .iter()
        .all(|sl| sl.loops.len() == 1 && (sl.loops[0].area - 6.0).abs() < 1e-12));
}

#[test]
fn planes_through_vertices_of_a_tilted_cube_give_clean_loops() {
    // Build direction along the cube's diagonal: planes pass exactly through corners.
    let m = box_mesh(P3::zeros(), P3::new(1.0, 1.0, 1.0));
    let d = P3::new(1.0, 1.0, 1.0);
    let h = 3f64.sqrt() / 3.0; // corner heights 0, h, 2h, 3h along d/|d|
    let s = slice(
        &m,
        &SliceOptions {
            planes: Planes::Parallel {
                dir: d,
                layer: h,
                first: Some(0.0),
            },
            stitch: None,
            threads: 1,
        },
    )
    .expect("slices");
    for sl in &s.slices {
        assert!(sl.open.is_empty());
        assert!(sl.loops.len() <= 1);
        for l in &sl.loops {
            assert!(l.area > 0.0);
        }
    }
    // The plane through (1,0,0), (0,1,0), (0,0,1) is a triangle of area √3/2.
    let l = &s.slices[1].loops[0];
    assert_eq!(l.points.len(), 3);
    assert!((l.area - 3f64.sqrt() / 2.0).abs() < 1e-12, "{}", l.area);
}

#[test]
fn sum_of_slice_areas_times_layer_matches_the_volume() {
    for (m, layer) in [
        (uv_sphere(P3::new(1.0, 2.0, 3.0), 10.0, 100, 200), 0.05),
        (torus(P3::zeros(), 20.0, 5.0, 200, 100), 0.05),
    ] {
        let v = volume(&m);
        let s = parallel(&m, P3::new(0.3, -0.2, 1.0), layer, 2).expect("slices");
        let sum: f64 = s
            .slices
            .iter()
            .flat_map(|sl| sl.loops.iter().map(|l| l.area))
            .sum::<f64>()
            * layer;
        // Midpoint rule on a smooth profile: error O(layer²) of the volume.
        assert!((sum - v).abs() / v < 1e-3, "{sum} vs {v}");
    }
}

#[test]
fn threads_do_not_change_the_result() {
    let m = torus(P3::new(1.0, 1.0, 1.0), 20.0, 5.0, 100, 50);
    let a = parallel(&m, P3::new(1.0, 0.5, 0.2), 0.3, 1).expect("1");
    let b = parallel(&m, P3::new(1.0, 0.5, 0.2), 0.3, 3).expect("3");
    assert_eq!(a, b);
}

#[test]
fn inside_out_mesh_is_sliced_right_side_out() {
    let mut m = uv_sphere(P3::zeros(), 5.0, 20, 40);
    for t in &mut m.triangles {
        t.swap(1, 2);
    }
    let s = parallel(&m, z(), 1.0, 1).expect("slices");
    assert!(s.flipped);
    assert!(s
        .slices
        .iter()
        .all(|sl| sl.loops.iter().all(|l| l.area > 0.0)));
}

#[test]
fn open_mesh_reports_open_chains_with_their_layer_and_ends() {
    let mut m = uv_sphere(P3::zeros(), 5.0, 20, 40);
    // Remove one equatorial quad (two triangles): a hole cut by the layers at its height.
    let hole = 2 * 40 + 2 * 40 * 9; // first triangle of ring band 10
    m.triangles.drain(hole..hole + 2);
    let s = parallel(&m, z(), 0.1, 1).expect("slices");
    assert!(!s.flipped);
    let open: Vec<_> = s.slices.iter().filter(|sl| !sl.open.is_empty()).collect();
    assert!(!open.is_empty());
    for sl in &open {
        assert!(
            sl.loops.is_empty(),
            "layer {}: an open loop is never a loop",
            sl.index
        );
        let c = &sl.open[0];
        assert!((c.start() - c.end()).norm() > 0.1);
        assert_eq!(c.faces.len(), c.points.len() - 1);
    }
    // With a tolerance wider than the hole, the gap is stitched and reported.
    let s = slice(
        &m,
        &SliceOptions {
            planes: Planes::Parallel {
                dir: z(),
                layer: 0.1,
                first: None,
            },
            stitch: Some(1.0),
            threads: 1,
        },
    )
    .expect("slices");
    for sl in s.slices.iter().filter(|sl| !sl.gaps.is_empty()) {
        assert!(sl.open.is_empty());
        assert_eq!(sl.loops.len(), 1);
        assert_eq!(sl.loops[0].stitched, 1);
        assert!(sl.gaps[0].length > 0.1 && sl.gaps[0].length < 1.0);
    }
    assert!(s.slices.iter().any(|sl| !sl.gaps.is_empty()));
}

#[test]
fn fan_of_planes_about_an_axis_cuts_a_box_beside_it() {
    // Axis: the y axis pointing to −y; build direction z; w = z × (−y) = +x.
    let m = box_mesh(P3::new(1.0, 0.0, -1.0), P3::new(3.0, 1.0, 1.0));
    let s = slice(
        &m,
        &SliceOptions {
            planes: Planes::Fan {
                point: P3::zeros(),
                axis: P3::new(0.0, -1.0, 0.0),
                dir: z(),
                step_deg: 10.0,
            },
            stitch: None,
            threads: 2,
        },
    )
    .expect("fan");
    assert_eq!(s.slices.len(), 9);
    for sl in &s.slices {
        let phi = sl.height.to_radians();
        assert!((sl.height - (-40.0 + 10.0 * sl.index as f64)).abs() < 1e-9);
        let r0 = 1.0 / phi.cos();
        let r1 = (3.0 / phi.cos()).min(1.0 / phi.sin().abs());
        assert_eq!(sl.loops.len(), 1);
        let l = &sl.loops[0];
        assert!(
            (l.area - (r1 - r0)).abs() < 1e-9,
            "{}: {} vs {}",
            sl.height,
            l.area,
            r1 - r0
        );
        for p in &l.points {
            assert!(sl.normal.dot(p).abs() < 1e-12);
        }
    }
    // A part behind the axis is refused.
    let behind = box_mesh(P3::new(-3.0, 0.0, -1.0), P3::new(3.0, 1.0, 1.0));
    let e = slice(
        &behind,
        &SliceOptions {
            planes: Planes::Fan {
                point: P3::zeros(),
                axis: P3::new(0.0, -1.0, 0.0),
                dir: z(),
                step_deg: 10.0,
            },
            stitch: None,
            threads: 1,
        },
    )
    .expect_err("behind");
    assert!(matches!(e, PlanError::Fan(_)), "{e}");
}

#[test]
fn bad_directions_and_layers_are_refused() {
    let m = box_mesh(P3::zeros(), P3::new(2.0, 3.0, 4.0));
    assert!(matches!(
        parallel(&m, P3::zeros(), 1.0, 1),
        Err(PlanError::Direction { .. })
    ));
    assert!(matches!(
        parallel(&m, P3::new(f64::NAN, 0.0, 1.0), 1.0, 1),
        Err(PlanError::Direction { .. })
    ));
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(parallel(&m, z(), bad, 1), Err(PlanError::Layer { .. })),
            "{bad}"
        );
    }
    assert!(matches!(
        parallel(&m, z(), 4.5, 1),
        Err(PlanError::LayerTooLarge { .. })
    ));
    assert!(matches!(
        parallel(&m, z(), 1e-9, 1),
        Err(PlanError::Layer { .. })
    ));
    let mut huge = m.clone();
    huge.vertices[2].x = 1e200;
    assert!(matches!(
        parallel(&huge, z(), 1.0, 1),
        Err(PlanError::Mesh(_))
    ));
    let mut nan = m.clone();
    nan.vertices[3].y = f64::NAN;
    assert!(matches!(
        parallel(&nan, z(), 1.0, 1),
        Err(PlanError::Mesh(_))
    ));
    assert!(matches!(
        parallel(&Mesh::default(), z(), 1.0, 1),
        Err(PlanError::Empty)
    ));
}
