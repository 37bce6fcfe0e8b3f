//! `post --preview` and `lampost preview`: the SVG is parsed as XML and its contents
//! checked against the part's geometry (the bearing seat: two rings at A = B = 0 seen from
//! the top are circles of radius 0.5 in; the side boss at B = 90° is seen edge-on).

mod common;

use common::*;

fn seat(dir: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let job = root().join("fixtures/post/bearing-seat/job.toml");
    let out = dir.join("seat.nc");
    let mut args = vec![
        "post",
        "--machine",
        "fadal-lamp",
        "--job",
        job.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ];
    args.extend_from_slice(extra);
    lampost(&args)
}

fn points(p: &roxmltree::Node) -> Vec<(f64, f64)> {
    p.attribute("points")
        .expect("points")
        .split_whitespace()
        .map(|xy| {
            let (x, y) = xy.split_once(',').expect("x,y");
            (x.parse().expect("x"), y.parse().expect("y"))
        })
        .collect()
}

#[test]
fn the_preview_draws_the_seat() {
    let dir = tempdir("preview");
    let svg = dir.join("seat.svg");
    let o = seat(&dir, &["--preview", svg.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).expect("svg written");
    let doc = roxmltree::Document::parse(&text).expect("well-formed SVG");
    let root_el = doc.root_element();
    assert_eq!(root_el.tag_name().name(), "svg");
    let lines: Vec<_> = doc
        .descendants()
        .filter(|n| n.has_tag_name("polyline"))
        .collect();
    let of = |class: &str, pos: &str| -> Vec<(f64, f64)> {
        lines
            .iter()
            .filter(|n| {
                n.attribute("class") == Some(class) && n.attribute("data-position") == Some(pos)
            })
            .flat_map(points)
            .collect()
    };
    // Two table positions, labelled and in the legend.
    let labels: Vec<&str> = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("index-label"))
        .filter_map(|n| n.text())
        .collect();
    assert_eq!(labels, ["A0.000 B0.000", "A0.000 B90.000"], "{text}");
    assert_eq!(
        doc.descendants()
            .filter(|n| n.attribute("class") == Some("legend"))
            .count(),
        2
    );
    // The rings: every deposition point at A = B = 0 on one circle.
    let ring = of("deposit", "0");
    assert!(ring.len() > 100, "{}", ring.len());
    let bx = ring
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let by = ring
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let c = (0.5 * (bx.0 + bx.1), 0.5 * (by.0 + by.1));
    let r: Vec<f64> = ring.iter().map(|p| (p.0 - c.0).hypot(p.1 - c.1)).collect();
    let (rmin, rmax) = r
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), x| (a.min(*x), b.max(*x)));
    assert!(rmax - rmin < 0.02 * rmax, "not a circle: {rmin}..{rmax}");
    // The boss on the side face, seen edge-on from the top: one vertical line, and its
    // approach feed along the face's normal (+X) beside it.
    let boss = of("deposit", "1");
    assert!(!boss.is_empty());
    let face_x = boss.iter().map(|p| p.0).fold(f64::MAX, f64::min);
    let on_face: Vec<&(f64, f64)> = boss.iter().filter(|p| p.0 - face_x < 0.5).collect();
    assert!(on_face.len() >= 5, "{boss:?}");
    assert!(
        boss.iter()
            .all(|p| p.0 - face_x < 0.5 || (p.1 - on_face[0].1).abs() < 0.5),
        "off the face only along its normal: {boss:?}"
    );
    // …to the right of the ring (part +X), 0.4 in long against the ring's 1 in.
    let ys: Vec<f64> = on_face.iter().map(|p| p.1).collect();
    let len =
        ys.iter().fold(f64::MIN, |a, y| a.max(*y)) - ys.iter().fold(f64::MAX, |a, y| a.min(*y));
    assert!(
        face_x > c.0 + rmax && (len / (2.0 * rmax) - 0.4).abs() < 0.02,
        "{len} vs {rmax}"
    );
    // Rapids dashed; the travel envelope drawn for both positions.
    assert!(lines
        .iter()
        .filter(|n| n.attribute("class") == Some("rapid"))
        .all(|n| n.attribute("stroke-dasharray").is_some()));
    for pos in ["0", "1"] {
        assert_eq!(
            doc.descendants()
                .filter(|n| n.has_tag_name("line")
                    && n.attribute("data-position") == Some(pos)
                    && n.parent().and_then(|p| p.attribute("class")) == Some("envelope"))
                .count(),
            12
        );
    }
    // `lampost preview` of the written program draws the same path.
    let again = dir.join("again.svg");
    let o = lampost(&[
        "preview",
        dir.join("seat.nc").to_str().expect("utf8"),
        "--machine",
        "fadal-lamp",
        "-o",
        again.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&again).expect("again"), text);
}

#[test]
fn a_preview_that_cannot_be_written_leaves_the_program() {
    let dir = tempdir("preview-bad");
    let o = seat(&dir, &["--preview", "/nonexistent-dir/seat.svg"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("only the preview failed"), "{e}");
    assert!(dir.join("seat.nc").exists(), "the program is written");
    // Without -o there is nothing to draw from.
    let job = root().join("fixtures/post/bearing-seat/job.toml");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--job",
        job.to_str().expect("utf8"),
        "--preview",
        "x.svg",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--preview needs -o"));
    let o = seat(&dir, &["--preview", "y.svg", "--view", "side"]);
    assert_eq!(o.status.code(), Some(2));
}
