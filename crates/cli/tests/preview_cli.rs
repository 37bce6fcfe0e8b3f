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

const PATCH: &str = "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG1 X1.\nG1 Y0.5\nG2 X0.5 Y1. I-0.5 J0\nG1 X0\nG1 Y0\nG0 Z0.2\nM30\n";
const PLACE: [&str; 6] = [
    "--machine",
    "fadal-lamp",
    "--index",
    "A=0,B=-20",
    "--origin",
    "0,0,1",
];

fn posted_patch(dir: &std::path::Path) -> (String, String) {
    let input = dir.join("patch.nc");
    std::fs::write(&input, PATCH).expect("input");
    let out = dir.join("patch.out.nc");
    let mut args = vec!["post"];
    args.extend_from_slice(&PLACE);
    let (i, o) = (
        input.to_str().expect("utf8").to_string(),
        out.to_str().expect("utf8").to_string(),
    );
    args.extend_from_slice(&[&i, "-o", &o]);
    let r = lampost(&args);
    assert!(r.status.success(), "{}", stderr(&r));
    (i, o)
}

/// The deviation lines of a `verify --preview` picture: (posted line, error).
fn deviations(svg: &str) -> Vec<(u32, Option<f64>, String)> {
    let doc = roxmltree::Document::parse(svg).expect("well-formed SVG");
    doc.descendants()
        .filter(|n| {
            n.has_tag_name("line")
                && n.attribute("class")
                    .is_some_and(|c| c.split(' ').any(|w| w == "deviation"))
        })
        .map(|n| {
            (
                n.attribute("data-line").expect("line").parse().expect("n"),
                n.attribute("data-error").expect("error").parse().ok(),
                n.attribute("stroke").expect("stroke").to_string(),
            )
        })
        .collect()
}

#[test]
fn verify_preview_colours_the_path_by_its_deviation() {
    let dir = tempdir("verify-preview");
    let (input, out) = posted_patch(&dir);
    let svg = dir.join("dev.svg");
    let mut args = vec!["verify"];
    args.extend_from_slice(&PLACE);
    let s = svg.to_str().expect("utf8").to_string();
    args.extend_from_slice(&[&input, &out, "--preview", &s]);
    let r = lampost(&args);
    assert!(r.status.success(), "{}", stderr(&r));
    let text = std::fs::read_to_string(&svg).expect("svg");
    let devs = deviations(&text);
    assert!(devs.len() > 30, "{}", devs.len());
    // Every compared point is within the tolerance (0.001 in), and its colour is on the
    // ramp: red channel 26 at 0 to 254 at half the tolerance, then 254 down to 215 at it.
    for (line, e, stroke) in &devs {
        if let Some(e) = e {
            assert!(*e <= 0.001, "line {line}: {e}");
            let red = f64::from(u8::from_str_radix(&stroke[1..3], 16).expect("hex"));
            let t = e / 0.001;
            let want = if t < 0.5 {
                26.0 + 228.0 * 2.0 * t
            } else {
                254.0 - 39.0 * (2.0 * t - 1.0)
            };
            assert!((red - want).abs() <= 1.0, "{line}: {stroke} for {e}");
        }
    }
    assert!(text.contains("deviation-legend"));

    // One coordinate of a feed moved by 0.01 in: verify fails at that line, and the
    // picture still written shows it red.
    let posted = std::fs::read_to_string(&out).expect("posted");
    let lines: Vec<&str> = posted.lines().collect();
    // The tenth block after the powder goes on (M73): a deposition feed with an X word.
    let on = lines.iter().position(|l| *l == "M73").expect("M73");
    let k = on + 10;
    assert!(lines[k].starts_with('X'), "{}", lines[k]);
    let bad_line = lines[k]
        .split_whitespace()
        .map(|w| {
            w.strip_prefix('X')
                .and_then(|v| v.parse::<f64>().ok())
                .map_or(w.to_string(), |v| format!("X{:.4}", v + 0.01))
        })
        .collect::<Vec<_>>()
        .join(" ");
    let mut tampered: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    tampered[k] = bad_line;
    let bad = dir.join("bad.nc");
    std::fs::write(&bad, tampered.join("\n") + "\n").expect("bad");
    let svg2 = dir.join("bad.svg");
    let b = bad.to_str().expect("utf8").to_string();
    let s2 = svg2.to_str().expect("utf8").to_string();
    let mut args = vec!["verify"];
    args.extend_from_slice(&PLACE);
    args.extend_from_slice(&[&input, &b, "--preview", &s2]);
    let r = lampost(&args);
    assert_eq!(r.status.code(), Some(1), "{}", stderr(&r));
    let text = std::fs::read_to_string(&svg2).expect("the picture of a failed check");
    let worst = deviations(&text)
        .into_iter()
        .filter_map(|(l, e, s)| e.map(|e| (l, e, s)))
        .fold(
            (0, 0.0, String::new()),
            |a, b| if b.1 > a.1 { b } else { a },
        );
    assert_eq!(worst.0 as usize, k + 1, "the moved line is the worst");
    assert!(worst.1 > 0.001, "{worst:?}");
    assert_eq!(worst.2, "#d73027", "beyond the tolerance: red");
}

#[test]
fn feeds_with_the_laser_off_are_not_drawn_as_deposition() {
    let dir = tempdir("preview-laser");
    let (_, out) = posted_patch(&dir);
    let svg = dir.join("p.svg");
    let r = lampost(&[
        "preview",
        &out,
        "--machine",
        "fadal-lamp",
        "-o",
        svg.to_str().expect("utf8"),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let text = std::fs::read_to_string(&svg).expect("svg");
    let doc = roxmltree::Document::parse(&text).expect("well-formed SVG");
    let class_of = |c: &str| {
        doc.descendants()
            .filter(|n| n.has_tag_name("polyline") && n.attribute("class") == Some(c))
            .count()
    };
    // The plunge onto the start (G1 Z0 before the laser is on) is a feed with the laser
    // off; the patch's perimeter is one run of deposition.
    assert_eq!(class_of("feed-off"), 1, "{text}");
    assert_eq!(class_of("deposit"), 1, "{text}");
    // Which posted lines switch the laser: the deposition run starts after the first
    // laser-on line and ends at or before the laser-off.
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert!(posted.lines().any(|l| l.contains("M71")), "{posted}");
}
