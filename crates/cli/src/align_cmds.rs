//! `lampost fit` and `lampost align`.

use lampost_align::{AlignError, P3};

use crate::io::{display_name, open_input, Output};
use crate::json::{self, obj, Obj};
use crate::points::{parse_points, Point};
use crate::report::CliError;

/// Render an align error for people, naming the file.
pub fn align_error(file: &str, e: AlignError) -> CliError {
    let at = match &e {
        AlignError::DuplicatePoints { .. } | AlignError::NotFinite(_) => format!(" ({file})"),
        _ => format!(" ({file})"),
    };
    CliError::failed(format!("error: {e}{at}\n  = help: {}\n", e.hint()))
}

/// Read a point file (or stdin).
pub fn read_points(file: &str) -> Result<(String, Vec<Point>), CliError> {
    let name = display_name(file);
    let mut text = String::new();
    crate::io::read_to_string_checked(&mut open_input(file)?, &mut text).map_err(|e| {
        CliError::usage(format!(
            "error: cannot read {name}: {e}\n  = help: point files are text: x y z per line\n"
        ))
    })?;
    let pts = parse_points(&text, &name)?;
    if pts.is_empty() {
        return Err(CliError::failed(format!(
            "error: {name} holds no points\n  = help: write one point per line: x y z\n"
        )));
    }
    Ok((name, pts))
}

fn p3(pts: &[Point]) -> Vec<P3> {
    pts.iter().map(|p| P3::from(p.p)).collect()
}

/// With duplicates, name the lines rather than the indices.
fn with_lines(name: &str, pts: &[Point], e: AlignError) -> CliError {
    match e {
        AlignError::DuplicatePoints { first, second } => CliError::failed(format!(
            "error: {name}:{} and {name}:{} are the same point\n  = help: {}\n",
            pts[first - 1].line,
            pts[second - 1].line,
            e.hint()
        )),
        AlignError::NotFinite(i) => CliError::failed(format!(
            "error: {name}:{}: the point is not finite\n  = help: {}\n",
            pts[i - 1].line,
            e.hint()
        )),
        AlignError::TooLarge { index, value } => CliError::failed(format!(
            "error: {name}:{}: the coordinate {value:e} is beyond ±1e9 of the unit\n  = help: {}\n",
            pts[index - 1].line,
            e.hint()
        )),
        e => align_error(name, e),
    }
}

fn write_json(v: Obj) -> Result<(), CliError> {
    let text = json::to_string(&v)?;
    let mut out = Output::create(None)?;
    out.writer()
        .write_all(format!("{text}\n").as_bytes())
        .map_err(|e| CliError::write(&e))?;
    out.commit()
}

fn write_text(s: String) -> Result<(), CliError> {
    let mut out = Output::create(None)?;
    out.writer()
        .write_all(s.as_bytes())
        .map_err(|e| CliError::write(&e))?;
    out.commit()
}

fn g(v: f64) -> String {
    format!("{v:.6}")
}

fn opt3(u: Option<[f64; 3]>) -> String {
    u.map_or("n/a".into(), |u| {
        format!("{:.2e} {:.2e} {:.2e}", u[0], u[1], u[2])
    })
}

/// Which fit.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum FitKind {
    /// Geometric least-squares sphere (N ≥ 4; with --radius, centre only).
    Sphere,
    /// Sphere through exactly 4 points (paper 000's determinant method).
    Sphere4,
    /// Total-least-squares plane.
    Plane,
    /// Circle in 3D (plane, then a 2D geometric circle).
    Circle,
}

pub fn fit(
    kind: FitKind,
    file: &str,
    radius: Option<f64>,
    ball_radius: Option<f64>,
    noise: Option<f64>,
    json: bool,
) -> Result<(), CliError> {
    let bar = crate::progress::Progress::working("reading the points", false);
    let (name, pts) = read_points(file)?;
    drop(bar);
    let v = p3(&pts);
    for (flag, val) in [
        ("--radius", radius),
        ("--ball-radius", ball_radius),
        ("--noise", noise),
    ] {
        if let Some(r) = val {
            if !(r.is_finite() && r > 0.0) {
                return Err(CliError::usage(format!("error: {flag} {r}: must be a positive number\n  = help: give the radius in the points' units\n")));
            }
        }
    }
    match kind {
        FitKind::Sphere | FitKind::Sphere4 => {
            let f = match kind {
                FitKind::Sphere4 => lampost_align::sphere4(&v),
                _ => lampost_align::sphere(&v, radius),
            }
            .map_err(|e| with_lines(&name, &pts, e))?;
            let probe = ball_radius.map(|b| f.radius - b);
            let warnings = fit_warnings("sphere", f.rms, &v, noise);
            if json {
                let mut j = obj! {
                    "center": f.center, "radius": f.radius, "rms": f.rms, "max_abs_residual": f.max_abs_residual, "n": f.n,
                    "u_center": f.u_center, "u_radius": f.u_radius, "radius_fixed": radius.is_some(),
                };
                if let Some(p) = probe {
                    j.set("probe_radius", &p);
                }
                j.set("warnings", &warnings);
                write_json(j)
            } else {
                let mut s = format!(
                    "center {} {} {}\nradius {}{}\nrms {:.3e}\nmax_abs_residual {:.3e}\nn {}\nu_center {}\nu_radius {}\n",
                    g(f.center[0]), g(f.center[1]), g(f.center[2]), g(f.radius), if radius.is_some() { " (fixed)" } else { "" },
                    f.rms, f.max_abs_residual, f.n, opt3(f.u_center), f.u_radius.map_or("n/a".into(), |u| format!("{u:.2e}"))
                );
                if let Some(p) = probe {
                    s.push_str(&format!("probe_radius {}\n", g(p)));
                }
                write_text(s)
            }
        }
        FitKind::Plane => {
            let f = lampost_align::plane(&v).map_err(|e| with_lines(&name, &pts, e))?;
            let warnings = fit_warnings("plane", f.rms, &v, noise);
            if json {
                write_json(obj! {
                    "point": f.point, "normal": f.normal, "rms": f.rms, "flatness": f.flatness,
                    "max_abs_residual": f.max_abs_residual, "n": f.n, "u_offset": f.u_offset, "u_tilt_rad": f.u_tilt,
                    "warnings": warnings,
                })
            } else {
                write_text(format!(
                    "point {} {} {}\nnormal {} {} {}\nrms {:.3e}\nflatness {:.3e}\nmax_abs_residual {:.3e}\nn {}\nu_offset {}\nu_tilt_rad {}\n",
                    g(f.point[0]), g(f.point[1]), g(f.point[2]), g(f.normal[0]), g(f.normal[1]), g(f.normal[2]),
                    f.rms, f.flatness, f.max_abs_residual, f.n,
                    f.u_offset.map_or("n/a".into(), |u| format!("{u:.2e}")),
                    f.u_tilt.map_or("n/a".into(), |u| format!("{:.2e} {:.2e}", u[0], u[1]))
                ))
            }
        }
        FitKind::Circle => {
            let f = lampost_align::circle3d(&v).map_err(|e| with_lines(&name, &pts, e))?;
            // Off the circle within its plane, or off the plane.
            let mut warnings = fit_warnings("circle", f.rms, &v, noise);
            if warnings.is_empty() {
                warnings = fit_warnings("circle's plane", f.rms_out_of_plane, &v, noise);
            }
            if json {
                write_json(obj! {
                    "center": f.center, "normal": f.normal, "radius": f.radius, "rms": f.rms,
                    "max_abs_residual": f.max_abs_residual, "rms_out_of_plane": f.rms_out_of_plane, "n": f.n,
                    "u_center": f.u_center, "u_radius": f.u_radius, "warnings": warnings,
                })
            } else {
                write_text(format!(
                    "center {} {} {}\nnormal {} {} {}\nradius {}\nrms {:.3e}\nrms_out_of_plane {:.3e}\nn {}\nu_center {}\nu_radius {}\n",
                    g(f.center[0]), g(f.center[1]), g(f.center[2]), g(f.normal[0]), g(f.normal[1]), g(f.normal[2]), g(f.radius),
                    f.rms, f.rms_out_of_plane, f.n, opt3(f.u_center), f.u_radius.map_or("n/a".into(), |u| format!("{u:.2e}"))
                ))
            }
        }
    }
}

/// A fit's warning (see [`lampost_align::residual_warning`]), also written to stderr.
fn fit_warnings(shape: &str, rms: f64, pts: &[P3], noise: Option<f64>) -> Vec<String> {
    let w: Vec<String> = lampost_align::residual_warning(shape, rms, pts, noise)
        .into_iter()
        .collect();
    for m in &w {
        eprintln!("warning: {m}");
    }
    w
}

fn outward(n: P3, hint: Option<&str>) -> Result<P3, CliError> {
    match hint {
        None => Ok(n),
        Some(t) => {
            // Refuses 0,0,0 (no side), and takes 1e300,… as a direction.
            let h = crate::kin_cmds::direction("--outward", t)?;
            Ok(if n.dot(&h) < 0.0 { -n } else { n })
        }
    }
}

pub fn level(
    file: &str,
    machine: &str,
    sets: &[String],
    near: Option<&str>,
    outward_hint: Option<&str>,
    json: bool,
) -> Result<(), CliError> {
    let m = crate::kin_cmds::load_machine(machine, sets)?;
    let (name, pts) = read_points(file)?;
    let pl = lampost_align::plane(&p3(&pts)).map_err(|e| with_lines(&name, &pts, e))?;
    let n = outward(P3::from(pl.normal), outward_hint)?;
    let near = crate::kin_cmds::near_rotary(&m, near)?;
    let sols = lampost_align::level(&m, &n, &near).map_err(crate::kin_cmds::kin_error)?;
    if !sols.iter().any(|s| s.within_limits) {
        let detail: Vec<String> = sols
            .iter()
            .map(|s| {
                format!(
                    "{} = {:.3}°, {} = {:.3}°",
                    m.rotary[0].name, s.rotary[0], m.rotary[1].name, s.rotary[1]
                )
            })
            .collect();
        return Err(CliError::failed(format!(
            "error: no levelling solution within the rotary limits ({}); candidates: {}\n  = help: re-fixture the part, or check the surface's outward direction (--outward)\n",
            m.rotary.iter().filter_map(|r| r.limits.map(|(lo, hi)| format!("{} [{lo}, {hi}]", r.name))).collect::<Vec<_>>().join(", "),
            detail.join("; ")
        )));
    }
    let names = m.axis_names();
    if json {
        let list: Vec<Obj> = sols
            .iter()
            .map(|s| {
                let j = Obj::new()
                    .field(names[3], &s.rotary[0])
                    .field(names[4], &s.rotary[1]);
                obj!{"joints": j, "within_limits": s.within_limits, "branch": s.branch, "singular": s.singular, "residual_tilt_deg": s.residual_tilt_deg}
            })
            .collect();
        write_json(
            obj! {"normal": [n.x, n.y, n.z], "point": pl.point, "flatness": pl.flatness, "rms": pl.rms, "solutions": list},
        )
    } else {
        let mut s = format!(
            "normal {} {} {}\nflatness {:.3e}\n",
            g(n.x),
            g(n.y),
            g(n.z),
            pl.flatness
        );
        for l in &sols {
            s.push_str(&format!(
                "{}={} {}={}  {}  residual tilt after rounding {:.2e}°\n",
                names[3],
                g(l.rotary[0]),
                names[4],
                g(l.rotary[1]),
                if l.within_limits {
                    "within limits"
                } else {
                    "OUTSIDE LIMITS"
                },
                l.residual_tilt_deg
            ));
        }
        write_text(s)
    }
}

pub fn angle(
    file: &str,
    to_normal: Option<&str>,
    to_plane: Option<&str>,
    origin: Option<&str>,
    write_setup: Option<&str>,
    json: bool,
) -> Result<(), CliError> {
    let (name, pts) = read_points(file)?;
    let pl = lampost_align::plane(&p3(&pts)).map_err(|e| with_lines(&name, &pts, e))?;
    let cad = match (to_normal, to_plane) {
        (Some(t), None) => {
            // A unit normal, its length taken without overflow; zero length refused.
            crate::kin_cmds::direction("--to-normal", t)?
        }
        (None, Some(f)) => {
            let (n2, p2) = read_points(f)?;
            P3::from(lampost_align::plane(&p3(&p2)).map_err(|e| with_lines(&n2, &p2, e))?.normal)
        }
        _ => return Err(CliError::usage("error: give exactly one of --to-normal i,j,k or --to-plane FILE\n  = help: the CAD plane's normal, or probed points on the plane to compare with\n".to_string())),
    };
    let r = lampost_align::plane_angle(&P3::from(pl.normal), &cad);
    let origin = match origin {
        Some(o) => crate::kin_cmds::position("--origin", o)?,
        None => P3::from(pl.point),
    };
    // The program frame turned by the rotation that takes the CAD plane's normal onto the
    // probed one: with the CAD face as the program's XY plane (--to-normal 0,0,1), the
    // setup's Z is the probed normal, so the post tilts the path with the part.
    let setup = lampost_align::Setup::from_rotation(
        origin,
        r.rotation_axis,
        r.rotation_deg,
        &format!(
            "lampost align angle {name}: program frame turned by {:.6} deg about ({:.6}, {:.6}, {:.6}), the CAD plane's normal onto the probed plane's",
            r.rotation_deg, r.rotation_axis[0], r.rotation_axis[1], r.rotation_axis[2]
        ),
    );
    if let Some(path) = write_setup {
        let mut out = Output::create(Some(path))?;
        out.writer()
            .write_all(setup.to_toml().as_bytes())
            .map_err(|e| CliError::write(&e))?;
        out.commit()?;
    }
    if json {
        write_json(obj! {
            "angle_deg": r.angle_deg, "rotation_axis": r.rotation_axis, "rotation_deg": r.rotation_deg,
            "rotation_about_z_deg": r.rotation_about_z_deg, "probed_normal": pl.normal, "setup": setup,
        })
    } else {
        write_text(format!(
            "angle_deg {}\nrotation axis {} {} {} by {} deg\nrotation_about_z_deg {}\n",
            g(r.angle_deg),
            g(r.rotation_axis[0]),
            g(r.rotation_axis[1]),
            g(r.rotation_axis[2]),
            g(r.rotation_deg),
            r.rotation_about_z_deg
                .map_or("n/a (a normal is along Z)".into(), g)
        ))
    }
}

/// The most touches one probing program holds (sphere points, plane grid m·n).
pub const MAX_TOUCHES: usize = 10_000;

fn pos(flag: &str, v: f64) -> Result<f64, CliError> {
    if v.is_finite() && v > 0.0 && v <= lampost_align::MAX_COORD {
        Ok(v)
    } else {
        Err(CliError::usage(format!("error: {flag} {v}: must be a positive number, at most 1e9\n  = help: give a length in the program's units\n")))
    }
}

/// A position for a probing program: each coordinate within ±1e9 of the unit.
fn place(flag: &str, text: &str) -> Result<P3, CliError> {
    let v = crate::kin_cmds::vector(flag, text)?;
    if v.amax() > lampost_align::MAX_COORD {
        return Err(CliError::usage(format!("error: {flag} {text}: a coordinate is beyond ±1e9 of the unit\n  = help: give the position in the program's units\n")));
    }
    Ok(v)
}

fn probe_opts(units: crate::UnitsArg, number: u32) -> lampost_align::probe::ProbeOptions {
    let u = match units {
        crate::UnitsArg::Inch => lampost_gcode::Units::Inch,
        crate::UnitsArg::Mm => lampost_gcode::Units::Mm,
    };
    let mut o = lampost_align::probe::ProbeOptions::defaults(u);
    o.program_number = number;
    o
}

fn write_program(text: &str, output: Option<&str>) -> Result<(), CliError> {
    // Check our own output with our own reader before anyone runs it.
    let diags = lampost_gcode::check(text.as_bytes(), lampost_gcode::Options::default());
    if let Some(d) = diags.iter().find(|d| d.is_error()) {
        return Err(CliError::failed(format!(
            "error: internal: the generated program does not check: {d}\n"
        )));
    }
    let mut out = Output::create(output)?;
    out.writer()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::write(&e))?;
    out.commit()
}

#[allow(clippy::too_many_arguments)]
pub fn probe_sphere(
    center: &str,
    radius: f64,
    stylus: f64,
    points: usize,
    cap_deg: f64,
    units: crate::UnitsArg,
    number: u32,
    output: Option<&str>,
) -> Result<(), CliError> {
    let c = place("--center", center)?;
    let radius = pos("--radius", radius)?;
    let stylus = pos("--stylus-radius", stylus)?;
    if points < 4 {
        return Err(CliError::usage(format!("error: --points {points}: a sphere fit needs at least 4 touches\n  = help: 30 spread over the cap is a good default\n")));
    }
    if points > MAX_TOUCHES {
        return Err(CliError::usage(format!("error: --points {points}: at most {MAX_TOUCHES} touches in one program\n  = help: 30 spread over the cap is a good default\n")));
    }
    if !(cap_deg > 0.0 && cap_deg <= 120.0) {
        return Err(CliError::usage(format!("error: --cap-deg {cap_deg}: must be in (0, 120]\n  = help: the polar angle from +Z the touches may reach; keep clear of the stem\n")));
    }
    let o = probe_opts(units, number);
    let t = lampost_align::probe::sphere_touches(c, radius, stylus, points, cap_deg, &o);
    let safe = c.z + radius + stylus + 3.0 * o.clearance;
    let text = lampost_align::probe::program(
        &t,
        safe,
        &format!("LAMPOST SPHERE PROBE {points} TOUCHES"),
        &o,
    )
    .map_err(|e| CliError::write(&e))?;
    write_program(&text, output)
}

/// The rectangle and grid of `probe plane`, as given.
#[derive(Debug, Clone, Copy)]
pub struct PlaneGrid<'a> {
    /// `x,y,z` of one corner.
    pub corner: &'a str,
    /// `u,v`.
    pub size: &'a str,
    /// `m,n`.
    pub grid: &'a str,
    /// The stylus ball's radius (the grid's inset from the edges).
    pub stylus_radius: Option<f64>,
}

pub fn probe_plane(
    plane: &PlaneGrid<'_>,
    safe_z: Option<f64>,
    units: crate::UnitsArg,
    number: u32,
    output: Option<&str>,
) -> Result<(), CliError> {
    let PlaneGrid {
        corner,
        size,
        grid,
        stylus_radius,
    } = *plane;
    let c = place("--corner", corner)?;
    let bad_pair = |flag: &str, t: &str| {
        CliError::usage(format!(
            "error: {flag} {t}: expected two values a,b\n  = help: e.g. --size 2,1 --grid 3,3\n"
        ))
    };
    let (su, sv) = size
        .split_once(',')
        .ok_or_else(|| bad_pair("--size", size))?;
    let (u, v) = (
        pos(
            "--size",
            su.trim().parse().map_err(|_| bad_pair("--size", size))?,
        )?,
        pos(
            "--size",
            sv.trim().parse().map_err(|_| bad_pair("--size", size))?,
        )?,
    );
    let (gm, gn) = grid
        .split_once(',')
        .ok_or_else(|| bad_pair("--grid", grid))?;
    let m: usize = gm.trim().parse().map_err(|_| bad_pair("--grid", grid))?;
    let n: usize = gn.trim().parse().map_err(|_| bad_pair("--grid", grid))?;
    // Saturating: 9223372036854775813 × 2 must not wrap to something small.
    let touches = m.saturating_mul(n);
    if m == 0 || n == 0 || !(3..=MAX_TOUCHES).contains(&touches) {
        return Err(CliError::usage(format!("error: --grid {grid}: needs at least 3 touches (and at most 10000)\n  = help: e.g. --grid 3,3\n")));
    }
    let o = probe_opts(units, number);
    let inset = match stylus_radius {
        Some(r) if r.is_finite() && r >= 0.0 => r,
        Some(r) => {
            return Err(CliError::usage(format!(
                "error: --stylus-radius {r}: must be a finite radius, zero or more\n  = help: the stylus ball's radius, in the program's units\n"
            )))
        }
        None => match o.units {
            lampost_gcode::Units::Inch => 0.0625,
            lampost_gcode::Units::Mm => 1.5,
        },
    };
    let t = lampost_align::probe::plane_touches(c, (u, v), (m, n), inset, &o).ok_or_else(|| {
        CliError::usage(format!(
            "error: --size {size}: the grid must stay a stylus radius ({inset}) inside the edges, so each side with more than one touch must be longer than {}\n  = help: probe a larger rectangle, or give the stylus's real radius with --stylus-radius\n",
            2.0 * inset
        ))
    })?;
    let safe = safe_z.unwrap_or(c.z + 10.0 * o.clearance);
    if safe <= c.z + o.clearance {
        return Err(CliError::usage(format!(
            "error: --safe-z {safe}: must be above the face plus the clearance ({})\n",
            c.z + o.clearance
        )));
    }
    let text = lampost_align::probe::program(&t, safe, &format!("LAMPOST PLANE PROBE {m}X{n}"), &o)
        .map_err(|e| CliError::write(&e))?;
    write_program(&text, output)
}

pub fn probe_read(log: &str, output: Option<&str>, json: bool) -> Result<(), CliError> {
    let name = display_name(log);
    let mut text = String::new();
    crate::io::read_to_string_checked(&mut open_input(log)?, &mut text)
        .map_err(|e| CliError::usage(format!("error: cannot read {name}: {e}\n")))?;
    let log_error = |e| {
        match e {
        lampost_align::probe::LogError::Malformed { line, text: t, why } => CliError::failed(format!(
            "error: {name}:{line}: `{t}` {why}\n  = help: fix or delete the line; touch lines read X… Y… Z…, pose records POSE k A… B…\n"
        )),
        lampost_align::probe::LogError::NoTouches => CliError::failed(format!(
            "error: {name} has no touch lines (X… Y… Z…)\n  = help: check that the log was captured from the RS-232 port while the probing program ran\n"
        )),
    }
    };
    // A `probe poses` log keeps its POSE records: each pose's touches under a comment
    // naming it (a point file still, for `fit`), and by pose in JSON.
    let poses = lampost_align::probe::read_pose_log(&text).map_err(log_error)?;
    let pts = match &poses {
        Some(p) => p.iter().flat_map(|q| q.touches.iter().copied()).collect(),
        None => lampost_align::probe::read_log(&text).map_err(log_error)?,
    };
    let label = |q: &lampost_align::probe::LoggedPose| {
        q.rotary
            .iter()
            .map(|(l, v)| format!("{}{v}", char::from(*l)))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let s = if json {
        let list: Vec<Obj> = pts
            .iter()
            .map(|(l, p)| obj! {"line": l, "point": p})
            .collect();
        let mut o = obj! { "points": list };
        if let Some(p) = &poses {
            let by_pose: Vec<Obj> = p
                .iter()
                .map(|q| {
                    let mut r = obj! {"pose": q.number, "line": q.line};
                    for (l, v) in &q.rotary {
                        r.set(&char::from(*l).to_string(), v);
                    }
                    let t: Vec<Obj> = q
                        .touches
                        .iter()
                        .map(|(l, p)| obj! {"line": l, "point": p})
                        .collect();
                    r.field("points", &t)
                })
                .collect();
            o.set("poses", &by_pose);
        }
        format!("{}\n", json::to_string(&o)?)
    } else {
        let mut s = format!("# touch points from {name}\nx y z\n");
        match &poses {
            Some(p) => {
                for q in p {
                    s.push_str(&format!(
                        "# pose {} {} (line {})\n",
                        q.number,
                        label(q),
                        q.line
                    ));
                    for (_, p) in &q.touches {
                        s.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
                    }
                }
            }
            None => {
                for (_, p) in &pts {
                    s.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
                }
            }
        }
        s
    };
    let mut out = Output::create(output)?;
    out.writer()
        .write_all(s.as_bytes())
        .map_err(|e| CliError::write(&e))?;
    out.commit()
}

pub fn register(
    file: &str,
    mesh_path: &str,
    lock: Option<&str>,
    write_setup: Option<&str>,
    json: bool,
) -> Result<(), CliError> {
    let (name, pts) = read_points(file)?;
    let mesh = read_mesh(mesh_path)?;
    let report = lampost_mesh::manifold_report(&mesh);
    let mut warnings = Vec::new();
    if !report.closed() {
        let w = format!(
            "{mesh_path} is not a closed manifold ({} boundary edges, {} edges shared by more than two triangles, {} degenerate triangles); registering against its faces anyway",
            report.boundary_edges, report.non_manifold_edges, report.degenerate_triangles
        );
        eprintln!("warning: {w}");
        warnings.push(w);
    }
    let locks = match lock {
        Some(l) => lampost_align::register::Locks::parse(l).map_err(|e| {
            CliError::usage(format!(
                "error: --lock {l}: {e}\n  = help: e.g. --lock z,tilt\n"
            ))
        })?,
        None => lampost_align::register::Locks::default(),
    };
    let bar = crate::progress::Progress::working("registering", false);
    let reg = lampost_align::register::register(&mesh, &p3(&pts), locks);
    drop(bar);
    let reg = reg.map_err(|e| with_lines(&name, &pts, e))?;
    if let Some(path) = write_setup {
        let setup = lampost_align::Setup::from_transform(
            reg.rotation,
            reg.translation,
            &format!(
                "lampost align register {name} --mesh {mesh_path}: CAD frame placed on the part"
            ),
        );
        let mut out = Output::create(Some(path))?;
        out.writer()
            .write_all(setup.to_toml().as_bytes())
            .map_err(|e| CliError::write(&e))?;
        out.commit()?;
    }
    if json {
        let per_point: Vec<Obj> = pts
            .iter()
            .zip(&reg.residuals)
            .map(|(p, r)| obj! {"line": p.line, "residual": r})
            .collect();
        write_json(obj! {
            "rotation": reg.rotation, "translation": reg.translation, "axis": reg.axis, "angle_deg": reg.angle_deg,
            "rms": reg.rms, "max_abs_residual": reg.max_abs_residual, "iterations": reg.iterations,
            "u_rotation_deg": reg.u_rotation_deg, "u_translation": reg.u_translation,
            "residuals": per_point, "warnings": warnings,
        })
    } else {
        let mut s = format!(
            "translation {} {} {}\nrotation axis {} {} {} by {} deg\nrms {:.3e}\nmax_abs_residual {:.3e}\n",
            g(reg.translation[0]), g(reg.translation[1]), g(reg.translation[2]),
            g(reg.axis[0]), g(reg.axis[1]), g(reg.axis[2]), g(reg.angle_deg), reg.rms, reg.max_abs_residual
        );
        if let (Some(ur), Some(ut)) = (reg.u_rotation_deg, reg.u_translation) {
            s.push_str(&format!(
                "u_rotation_deg {:.3e} {:.3e} {:.3e} (about x, y, z through the points' centroid)\nu_translation {:.3e} {:.3e} {:.3e}\n",
                ur[0], ur[1], ur[2], ut[0], ut[1], ut[2]
            ));
        }
        for (p, r) in pts.iter().zip(&reg.residuals) {
            s.push_str(&format!("line {} residual {:+.3e}\n", p.line, r));
        }
        write_text(s)
    }
}

/// A mesh file (STL, OBJ or OFF) as a mesh, with located errors.
pub fn read_mesh(path: &str) -> Result<lampost_mesh::Mesh, CliError> {
    crate::mesh_cmds::read_mesh_file(path)
}
