//! `plan path` (paper 001's whole plan: perimeters with tool axes, rasters, the
//! offset-angle check; the per-point path, a JSON report, an SVG preview) and `plan demo`
//! (the twisted plate).

use lampost_plan::{Approach, Plan, PlanOptions, RasterOptions};

use crate::json::{self, obj, Obj};
use crate::mesh_cmds::{plan_error, sliced, write_out, SliceArgs};
use crate::report::CliError;

/// The perimeters' approach (`--approach`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ApproachArg {
    /// Paper 001's rule: tangent to the surface, across the traversal.
    Tangent,
    /// Along the build direction (a three-axis build).
    Build,
}

/// `plan path`: the options of `plan slice`, and how the perimeters and rasters are laid.
#[derive(Debug, clap::Args)]
pub struct PathArgs {
    #[command(flatten)]
    pub slice: SliceArgs,
    /// Longest chord between two perimeter points (mm).
    #[arg(long, default_value_t = 1.0)]
    pub spacing: f64,
    /// Largest turn of the tool axis between two points (degrees).
    #[arg(long, default_value_t = 2.0)]
    pub max_turn: f64,
    /// Feed written on every point (mm/min).
    #[arg(long, default_value_t = 600.0)]
    pub feed: f64,
    /// Bead width (mm): rasters stay half of it inside the loops.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub bead: f64,
    /// Distance between raster lines (mm; default: the bead width).
    #[arg(long, allow_negative_numbers = true)]
    pub hatch: Option<f64>,
    /// Raster angle of the first layer (degrees, in the layer's plane).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub raster_angle: f64,
    /// Raster angle added per layer (degrees).
    #[arg(long, default_value_t = 90.0, allow_negative_numbers = true)]
    pub raster_turn: f64,
    /// A hollow part: perimeters only, no raster.
    #[arg(long)]
    pub hollow: bool,
    /// The perimeters' approach.
    #[arg(long, value_enum, default_value = "tangent")]
    pub approach: ApproachArg,
    /// Largest offset angle (degrees): how far a bead may overhang the one below.
    #[arg(long, default_value_t = 45.0, allow_negative_numbers = true)]
    pub max_offset_angle: f64,
    /// Largest tilt of the tool axis from the build direction when tilting a point to
    /// bring it under the offset angle (degrees).
    #[arg(long, default_value_t = 90.0, allow_negative_numbers = true)]
    pub max_tilt: f64,
    /// Check the offset angle and report; write no path (exit 1 if points stay over it).
    #[arg(long)]
    pub check_only: bool,
    /// Draw the plan as SVG to this file.
    #[arg(long)]
    pub preview: Option<String>,
    /// Check the machine's reach: every point solved by its inverse kinematics as `lampost
    /// post` places the path (built-in name or machine file); unreachable: exit 1, nothing
    /// written.
    #[arg(long)]
    pub machine: Option<String>,
    /// Override a machine parameter: NAME=x,y,z or NAME=value (repeatable; with --machine).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Head (with --machine; default: the post's for deposition).
    #[arg(long)]
    pub head: Option<String>,
    /// Program origin in the part frame, x,y,z mm (with --machine; as `lampost post --origin`).
    #[arg(long, allow_hyphen_values = true)]
    pub origin: Option<String>,
    /// Rotary position the first point is solved nearest, e.g. A=0,B=0 (with --machine).
    #[arg(long, allow_hyphen_values = true)]
    pub near: Option<String>,
}

/// The machine and placement of `--machine` (none without it).
fn machine_reach(
    a: &PathArgs,
    pts: &[lampost_plan::PathPoint],
) -> Result<Option<lampost_plan::Reach>, CliError> {
    let Some(spec) = a.machine.as_deref() else {
        if a.head.is_some() || a.origin.is_some() || a.near.is_some() || !a.set.is_empty() {
            return Err(CliError::usage(
                "error: --head, --origin, --near and --set place the path on a machine: give --machine too
".to_string(),
            ));
        }
        return Ok(None);
    };
    let m = crate::kin_cmds::load_machine(spec, &a.set)?;
    let head = match a.head.as_deref() {
        Some(h) => m.head(h).map_err(crate::kin_cmds::kin_error)?,
        None => lampost_post::default_head(&m, true),
    };
    let origin = a
        .origin
        .as_deref()
        .map(|o| crate::kin_cmds::position("--origin", o))
        .transpose()?
        .unwrap_or_else(lampost_kinematics::Vector3::zeros);
    let near = crate::kin_cmds::near_rotary(&m, a.near.as_deref())?;
    Ok(Some(lampost_plan::reach(
        &m,
        pts,
        &lampost_plan::ReachOptions { head, origin, near },
    )))
}

/// The reach as JSON.
fn reach_json(r: &lampost_plan::Reach) -> Obj {
    let axes: Vec<Obj> = r
        .axes
        .iter()
        .map(|x| {
            obj! {
                "axis": x.name.as_str(),
                "used": x.used.map(|(lo, hi)| [lo, hi]),
                "limits": x.limits.map(|(lo, hi)| [lo, hi]),
            }
        })
        .collect();
    let first = r.first.as_ref().map(|u| {
        obj! {
            "point": u.index, "line": u.index + PATH_HEADER_LINES + 1, "layer": u.layer,
            "at": [u.p.x, u.p.y, u.p.z], "axis": [u.axis.x, u.axis.y, u.axis.z],
            "why": u.why.as_str(),
        }
    });
    obj! {
        "machine": r.machine.as_str(), "reachable": r.reachable(), "points": r.points,
        "unreachable": r.unreachable,
        "unreachable_layers": r.unreachable_layers.iter().take(MAX_LISTED).copied().collect::<Vec<usize>>(),
        "first_unreachable": first, "branch_flips": r.branch_flips, "axes": axes,
    }
}

/// Lines before the first point of a path file: the comment and the header.
const PATH_HEADER_LINES: usize = 2;

/// Violations listed one by one in the JSON and on stderr before they are only counted.
const MAX_LISTED: usize = 1000;

/// `plan path`.
pub fn path(a: &PathArgs) -> Result<(), CliError> {
    if !(a.feed.is_finite() && a.feed > 0.0) {
        return Err(CliError::usage(format!(
            "error: --feed {}: give a positive feed\n",
            a.feed
        )));
    }
    let to_stdout = a.slice.output.as_deref().is_none_or(|o| o == "-");
    if a.slice.json && to_stdout && !a.check_only {
        return Err(CliError::usage(
            "error: --json writes the report to standard output, where the path would go\n  = help: give -o PATH.csv for the path, or --check-only\n",
        ));
    }
    if a.check_only && a.slice.output.is_some() {
        return Err(CliError::usage(
            "error: --check-only writes no path: leave out -o\n",
        ));
    }
    let hatch = a.hatch.unwrap_or(a.bead);
    for (flag, v) in [("--bead", a.bead), ("--hatch", hatch)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(CliError::usage(format!(
                "error: {flag} {v}: give a positive width (mm)\n  = help: e.g. {flag} 1\n"
            )));
        }
    }
    let (mesh, s, manifold, open) = sliced(&a.slice)?;
    if open > 0 {
        return Err(crate::mesh_cmds::open_chains(
            &a.slice.file,
            open,
            &manifold,
            true,
        ));
    }
    let opts = PlanOptions {
        perimeter: lampost_plan::PerimeterOptions {
            spacing: a.spacing,
            max_turn_deg: a.max_turn,
        },
        raster: (!a.hollow).then_some(RasterOptions {
            hatch,
            inset: a.bead / 2.0,
            angle_deg: a.raster_angle,
            turn_deg: a.raster_turn,
        }),
        approach: match a.approach {
            ApproachArg::Tangent => Approach::Tangent,
            ApproachArg::Build => Approach::Build,
        },
        max_offset_deg: a.max_offset_angle,
        max_tilt_deg: a.max_tilt,
        threads: a
            .slice
            .threads
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
    };
    let plan = lampost_plan::plan(&mesh, &s, &opts).map_err(|e| plan_error(&a.slice.file, &e))?;
    let pts = plan.points();
    if pts.is_empty() {
        return Err(CliError::failed(format!(
            "error: {}: the slices hold no loop; nothing written\n",
            a.slice.file
        )));
    }
    // Never a non-finite number in a path: refused whole rather than written.
    if let Some((i, q)) = pts
        .iter()
        .enumerate()
        .find(|(_, q)| !(q.p.iter().chain(q.axis.iter()).all(|c| c.is_finite())))
    {
        return Err(CliError::failed(format!(
            "error: {}: path point {i} (layer {}) is not finite; nothing written
  = help: check the mesh near layer {} (`lampost mesh info`)
",
            a.slice.file, q.layer, q.layer
        )));
    }
    for v in plan.violations.iter().take(MAX_LISTED) {
        eprintln!(
            "warning: layer {} loop {} point {}: offset angle {:.2}° over {}° at ({:.4} {:.4} {:.4})",
            v.layer, v.loop_index, v.point, v.angle_deg, a.max_offset_angle, v.p.x, v.p.y, v.p.z
        );
    }
    if plan.violations.len() > MAX_LISTED {
        eprintln!(
            "warning: {} more points over the offset angle",
            plan.violations.len() - MAX_LISTED
        );
    }
    let reach = machine_reach(a, &pts)?;
    if let Some(r) = reach.as_ref().filter(|r| !r.reachable()) {
        if a.slice.json {
            let text = json::to_string(&report(a, &plan, &s, &pts, reach.as_ref()))?;
            write_out(None, format!("{text}\n").as_bytes())?;
        }
        let u = r.first.as_ref();
        return Err(CliError::failed(format!(
            "error: {}: {} of {} path points are beyond the reach of {} (first: layer {}, point {} at ({:.4} {:.4} {:.4}), path line {}: {}); nothing written\n  = help: move the part with --origin, or change the build direction or --max-tilt; the JSON report (--json) gives each axis's extent against its travel\n",
            a.slice.file,
            r.unreachable,
            r.points,
            r.machine,
            u.map_or(0, |u| u.layer),
            u.map_or(0, |u| u.index),
            u.map_or(0.0, |u| u.p.x),
            u.map_or(0.0, |u| u.p.y),
            u.map_or(0.0, |u| u.p.z),
            u.map_or(0, |u| u.index + PATH_HEADER_LINES + 1),
            u.map_or("", |u| u.why.as_str()),
        )));
    }
    // The preview, the path, then the report: nothing is written when an earlier one fails.
    if let Some(svg) = &a.preview {
        write_out(
            Some(svg),
            lampost_plan::preview::svg(&plan, 2.0 * a.bead.max(a.spacing), 5).as_bytes(),
        )?;
    }
    let layers_over = {
        let mut l: Vec<usize> = plan.violations.iter().map(|v| v.layer).collect();
        l.dedup();
        l.len()
    };
    if !a.check_only {
        let text = lampost_plan::perimeter::to_text(
            &pts,
            a.feed,
            &format!(
                "lampost plan path {}: {} layers, {} points; perimeters then rasters per layer; tool axis tip to head (perimeters: {}; rasters: the build direction), mm",
                a.slice.file,
                s.slices.len(),
                pts.len(),
                match a.approach {
                    ApproachArg::Tangent => "surface normal x traversal",
                    ApproachArg::Build => "the build direction",
                }
            ),
        );
        write_out(a.slice.output.as_deref(), text.as_bytes())?;
    }
    if a.slice.json {
        let text = json::to_string(&report(a, &plan, &s, &pts, reach.as_ref()))?;
        write_out(None, format!("{text}\n").as_bytes())?;
    } else if a.check_only {
        let mut t = format!(
            "layers {}\nworst offset angle {:.3}°\ntilted points {}\npoints over {}°: {} on {layers_over} layers\n",
            plan.layers.len(),
            plan.worst_offset_deg(),
            plan.tilted,
            a.max_offset_angle,
            plan.violations.len()
        );
        for l in &plan.layers {
            if plan.violations.iter().any(|v| v.layer == l.index) {
                t.push_str(&format!(
                    "layer {}: worst offset angle {:.3}°\n",
                    l.index,
                    l.worst_offset_deg()
                ));
            }
        }
        if let Some(r) = &reach {
            t.push_str(&format!(
                "reach on {}: every point ({}); {} branch flips\n",
                r.machine, r.points, r.branch_flips
            ));
            for x in &r.axes {
                if let (Some((lo, hi)), lim) = (x.used, x.limits) {
                    t.push_str(&format!(
                        "  {} {lo:.4} .. {hi:.4} of {}\n",
                        x.name,
                        lim.map_or("unlimited".to_string(), |(a, b)| format!("{a} .. {b}"))
                    ));
                }
            }
        }
        write_out(None, t.as_bytes())?;
    }
    eprintln!(
        "planned {} points on {} layers of {}; worst offset angle {:.2}°, {} points tilted, {} over {}°",
        pts.len(),
        s.slices.len(),
        a.slice.file,
        plan.worst_offset_deg(),
        plan.tilted,
        plan.violations.len(),
        a.max_offset_angle
    );
    if a.check_only && !plan.violations.is_empty() {
        return Err(CliError::failed(format!(
            "error: {}: {} points on {layers_over} layers over the offset angle of {}°\n  = help: use --approach tangent, allow more --max-tilt, or change the build direction\n",
            a.slice.file,
            plan.violations.len(),
            a.max_offset_angle
        )));
    }
    Ok(())
}

/// The JSON report of a plan.
fn report(
    a: &PathArgs,
    plan: &Plan,
    s: &lampost_plan::Slicing,
    pts: &[lampost_plan::PathPoint],
    reach: Option<&lampost_plan::Reach>,
) -> Obj {
    let (mut on, mut off) = (0.0, 0.0);
    for w in pts.windows(2) {
        let d = (w[1].p - w[0].p).norm();
        if w[1].laser {
            on += d;
        } else {
            off += d;
        }
    }
    let layers: Vec<Obj> = plan
        .layers
        .iter()
        .zip(&s.slices)
        .map(|(l, sl)| {
            obj! {
                "index": l.index, "height": sl.height, "loops": l.loops.len(),
                "perimeter_length": l.perimeter_length(), "runs": l.runs.len(),
                "raster_length": l.raster_length(), "raster_angle": l.raster_angle_deg,
                "worst_offset_angle": l.worst_offset_deg(),
            }
        })
        .collect();
    let violations: Vec<Obj> = plan
        .violations
        .iter()
        .take(MAX_LISTED)
        .map(|v| obj! {"layer": v.layer, "loop": v.loop_index, "point": v.point, "angle": v.angle_deg, "at": [v.p.x, v.p.y, v.p.z]})
        .collect();
    obj! {
        "file": a.slice.file.as_str(), "units": "mm", "layers": plan.layers.len(),
        "loops": plan.layers.iter().map(|l| l.loops.len()).sum::<usize>(),
        "points": pts.len(),
        "perimeter_length": plan.layers.iter().map(|l| l.perimeter_length()).sum::<f64>(),
        "raster_length": plan.layers.iter().map(|l| l.raster_length()).sum::<f64>(),
        "travel_length": off,
        "feed": a.feed,
        "time_s": (on + off) / a.feed * 60.0,
        "laser_on_s": on / a.feed * 60.0,
        "approach": match a.approach { ApproachArg::Tangent => "tangent", ApproachArg::Build => "build" },
        "max_offset_angle": a.max_offset_angle,
        "worst_offset_angle": plan.worst_offset_deg(),
        "tilted": plan.tilted,
        "violation_count": plan.violations.len(),
        "violations": violations,
        "hollow": a.hollow,
        "reach": reach.map(reach_json),
        "slices": layers,
    }
}

/// `plan demo` arguments.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Scale of paper 001's 600 × 200 mm plate (0.25: 150 × 50 mm).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub scale: f64,
    /// Wall thickness across the face (mm, not scaled).
    #[arg(long, default_value_t = 3.0, allow_negative_numbers = true)]
    pub thickness: f64,
    /// Quads along the twisting edge.
    #[arg(long, default_value_t = 120)]
    pub along: usize,
    /// Quads across the plate.
    #[arg(long, default_value_t = 20)]
    pub across: usize,
    /// Units the STL is written in (the plate's sizes are in mm either way).
    #[arg(long, value_enum, default_value = "mm")]
    pub units: crate::mesh_cmds::MeshUnits,
    /// The STL file (ASCII; atomic).
    #[arg(short, long)]
    pub output: String,
}

/// `plan demo`: paper 001's twisted plate as a closed STL.
pub fn demo(a: &DemoArgs) -> Result<(), CliError> {
    let mesh = lampost_plan::demo::twisted_plate(a.scale, a.thickness, a.along, a.across)
        .ok_or_else(|| {
            CliError::usage(format!(
                "error: plan demo: --scale {} --thickness {} --along {} --across {}: give positive sizes, 1 to 100000 quads each way and at most {} in all\n  = help: e.g. --scale 0.25 --thickness 3\n",
                a.scale, a.thickness, a.along, a.across, lampost_plan::demo::MAX_QUADS
            ))
        })?;
    let (lo, hi) = lampost_mesh::props::bounds(&mesh).unwrap_or_default();
    if !(lo
        .iter()
        .chain(hi.iter())
        .all(|c| c.is_finite() && c.abs() < 1e9))
    {
        return Err(CliError::usage(format!(
            "error: plan demo: --scale {}: the plate would not be finite\n",
            a.scale
        )));
    }
    let (mesh, unit) = match a.units {
        crate::mesh_cmds::MeshUnits::Mm => (mesh, "mm"),
        crate::mesh_cmds::MeshUnits::In => (mesh.scaled(1.0 / 25.4), "in"),
        crate::mesh_cmds::MeshUnits::M => (mesh.scaled(1.0 / 1000.0), "m"),
    };
    let (lo, hi) = lampost_mesh::props::bounds(&mesh).unwrap_or_default();
    write_out(
        Some(&a.output),
        lampost_mesh::write_ascii_stl(&mesh, "twisted-plate").as_bytes(),
    )?;
    eprintln!(
        "wrote {}: paper 001's plate at scale {}, {} triangles, from ({:.4} {:.4} {:.4}) to ({:.4} {:.4} {:.4}) {unit}; build direction +z",
        a.output,
        a.scale,
        mesh.triangles.len(),
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    Ok(())
}
