//! `mesh info` and `plan slice`: reading meshes (STL, OBJ, OFF) with located errors,
//! their measures and manifold report, and their slices.

use lampost_mesh::{Format, Mesh, MeshError, Pos, Units};
use lampost_plan::{PlanError, Planes, SliceOptions, Slicing};

use crate::io::Output;
use crate::json::{self, obj, Obj};
use crate::report::CliError;

/// Mesh file units (`--units`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MeshUnits {
    /// Millimetres.
    Mm,
    /// Inches.
    In,
    /// Metres (Blender's, a robot's CAD).
    M,
}

impl MeshUnits {
    fn units(self) -> Units {
        match self {
            MeshUnits::Mm => Units::Mm,
            MeshUnits::In => Units::In,
            MeshUnits::M => Units::M,
        }
    }
}

/// Bad edges listed in full before the rest are only counted.
const MAX_EDGES_LISTED: usize = 100;

/// A mesh error as a located diagnostic: `file:line:col`, the line with a caret, or the
/// byte offset of a binary file; the hint.
fn located(path: &str, bytes: &[u8], e: &MeshError) -> CliError {
    let hint = e.hint();
    match e.at() {
        Some(Pos::Line { line, col }) => {
            let text = bytes
                .split(|&b| b == b'\n')
                .nth(line - 1)
                .map(|l| String::from_utf8_lossy(l).trim_end().to_string())
                .unwrap_or_default();
            let text: String = text.chars().take(200).collect();
            let num = line.to_string();
            let pad = " ".repeat(num.len());
            CliError::failed(format!(
                "error: {e}\n{pad}--> {path}:{line}:{col}\n{pad} |\n{num} | {text}\n{pad} | {}^\n  = help: {hint}\n",
                " ".repeat(col.saturating_sub(1))
            ))
        }
        Some(Pos::Byte(b)) => CliError::failed(format!(
            "error: {e}\n --> {path}: byte {b}{}\n  = help: {hint}\n",
            e.text().map(|t| format!(" ({t})")).unwrap_or_default()
        )),
        // A 3MF's model part says its place in the message (part, line, column).
        None => CliError::failed(format!(
            "error: {path}: {e}{}\n  = help: {hint}\n",
            e.text()
                .filter(|t| !t.is_empty())
                .map(|t| format!("\n  = text: {t}"))
                .unwrap_or_default()
        )),
    }
}

/// Read a mesh file (`-`: standard input; format from the extension, else from the
/// content), welded exactly.
pub fn read_mesh_file(path: &str) -> Result<Mesh, CliError> {
    read_mesh_format(path).map(|(m, _)| m)
}

/// [`read_mesh_file`] and the format read (a 3MF is read in millimetres: it says its
/// units).
fn read_mesh_format(path: &str) -> Result<(Mesh, Format), CliError> {
    let bytes = if path == "-" {
        let mut b = Vec::new();
        crate::io::read_to_end_checked(&mut std::io::stdin(), &mut b).map(|_| b)
    } else {
        crate::io::read_file(path)
    }
    .map_err(|e| {
        CliError::usage(format!(
            "error: cannot read {path}: {e}\n  = help: give a mesh file (STL, OBJ, OFF or 3MF)\n"
        ))
    })?;
    let format = Format::from_path(path).unwrap_or_else(|| Format::sniff(&bytes));
    lampost_mesh::read(&bytes, format)
        .map(|m| (m, format))
        .map_err(|e| located(path, &bytes, &e))
}

/// A mesh file in `want` units: a 3MF in the units it says (its model's `unit`; a
/// units option with it is refused), any other in `given` (default: `want`). The one
/// reading of a mesh's units for every command that takes a mesh (`mesh`, `plan`,
/// `inspect`, `post --part`). Also the units the file was read in.
pub fn read_mesh_in(
    path: &str,
    given: Option<MeshUnits>,
    want: Units,
) -> Result<(Mesh, Units), CliError> {
    let (mesh, format) = read_mesh_format(path)?;
    let from = if format == Format::ThreeMf {
        // Read in millimetres, from the file's own unit.
        if given.is_some() {
            return Err(CliError::usage(format!(
                "error: {path}: a 3MF file says its units (its model's `unit`): leave out the units option\n"
            )));
        }
        Units::Mm
    } else {
        given.map_or(want, MeshUnits::units)
    };
    let mesh = if from == want {
        mesh
    } else {
        mesh.scaled(from.to_mm() / want.to_mm())
    };
    Ok((mesh, from))
}

/// The mesh units of a machine's units.
pub fn machine_units(u: lampost_kinematics::Units) -> Units {
    match u {
        lampost_kinematics::Units::Mm => Units::Mm,
        lampost_kinematics::Units::Inch => Units::In,
    }
}

/// Read a mesh in millimetres: `--units` names the file's units (default mm).
fn read_mm(path: &str, units: Option<MeshUnits>) -> Result<(Mesh, Units), CliError> {
    let (mesh, u) = read_mesh_in(path, units, Units::Mm)?;
    Ok((mesh, u))
}

pub(crate) fn write_out(output: Option<&str>, s: &[u8]) -> Result<(), CliError> {
    let mut out = Output::create(output)?;
    out.writer().write_all(s).map_err(|e| CliError::write(&e))?;
    out.commit()
}

fn write_json(output: Option<&str>, v: Obj) -> Result<(), CliError> {
    let text = json::to_string(&v)?;
    write_out(output, format!("{text}\n").as_bytes())
}

fn p(v: &lampost_mesh::P3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// `lampost mesh info`.
pub fn info(path: &str, units: Option<MeshUnits>, json_out: bool) -> Result<(), CliError> {
    let (mesh, u) = read_mm(path, units)?;
    let report = lampost_mesh::manifold_report(&mesh);
    let (lo, hi) = lampost_mesh::props::bounds(&mesh).unwrap_or_default();
    let area = lampost_mesh::props::area(&mesh);
    let volume = report.closed().then(|| lampost_mesh::props::volume(&mesh));
    if !area.is_finite() || volume.is_some_and(|v| !v.is_finite()) {
        return Err(CliError::failed(format!(
            "error: {path}: the area or volume overflows (coordinates up to {:e})\n  = help: check the file's units and scale\n",
            lo.abs().max().max(hi.abs().max())
        )));
    }
    // A part under 1 mm across, read in mm: likely a file in metres.
    if u == Units::Mm && (hi - lo).max() < 1.0 {
        eprintln!(
            "note: {path}: the part is {:.6} mm across at most: a file in metres (Blender's, a robot's CAD) is read with --units m",
            (hi - lo).max()
        );
    }
    let listed: Vec<_> = report.bad_edges.iter().take(MAX_EDGES_LISTED).collect();
    if json_out {
        let edges: Vec<Obj> = listed
            .iter()
            .map(|e| {
                obj! {
                    "problem": e.problem.name(), "a": e.a, "b": e.b, "faces": e.faces, "face": e.face,
                    "from": p(&mesh.vertices[e.a as usize]), "to": p(&mesh.vertices[e.b as usize]),
                }
            })
            .collect();
        return write_json(
            None,
            obj! {
                "file": path, "file_units": u.name(), "units": "mm",
                "triangles": mesh.triangles.len(), "vertices": mesh.vertices.len(),
                "bounds": obj!{"min": p(&lo), "max": p(&hi)},
                "area": area, "volume": volume,
                "closed": report.closed(), "oriented": report.closed_oriented(),
                "boundary_edges": report.boundary_edges, "non_manifold_edges": report.non_manifold_edges,
                "inconsistent_edges": report.inconsistent_edges, "degenerate_triangles": report.degenerate_triangles,
                "twin_faces": report.twin_faces,
                "bad_edges": edges, "bad_edges_not_listed": report.bad_edges.len() - listed.len(),
            },
        );
    }
    let mut s = format!(
        "file {path} ({} in the file, shown in mm)\ntriangles {}\nvertices {} (welded)\nbounds {:.6} {:.6} {:.6} .. {:.6} {:.6} {:.6}\narea {:.6}\n",
        u.name(),
        mesh.triangles.len(),
        mesh.vertices.len(),
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z,
        area
    );
    match volume {
        Some(v) => s.push_str(&format!("volume {v:.6}\n")),
        None => s.push_str("volume n/a (the mesh is not closed)\n"),
    }
    s.push_str(&format!(
        "manifold {}: {} boundary edges, {} non-manifold edges, {} inconsistent edges, {} degenerate triangles\n",
        if report.closed_oriented() { "closed and oriented" } else if report.closed() { "closed, orientation inconsistent" } else { "open" },
        report.boundary_edges, report.non_manifold_edges, report.inconsistent_edges, report.degenerate_triangles
    ));
    if report.twin_faces > 0 {
        s.push_str(&format!(
            "twin faces {} (each the reverse of another: a double-sided export, whose sides cancel in every slice)\n",
            report.twin_faces
        ));
    }
    for e in &listed {
        let (a, b) = (mesh.vertices[e.a as usize], mesh.vertices[e.b as usize]);
        s.push_str(&format!(
            "edge {} {}-{} ({:.6} {:.6} {:.6} .. {:.6} {:.6} {:.6}) in {} faces (face {})\n",
            e.problem.name(),
            e.a,
            e.b,
            a.x,
            a.y,
            a.z,
            b.x,
            b.y,
            b.z,
            e.faces,
            e.face
        ));
    }
    if report.bad_edges.len() > listed.len() {
        s.push_str(&format!(
            "... and {} more bad edges (--json lists the first {MAX_EDGES_LISTED})\n",
            report.bad_edges.len() - listed.len()
        ));
    }
    write_out(None, s.as_bytes())
}

/// Parse `x,y,z`.
fn vec3(flag: &str, s: &str) -> Result<lampost_mesh::P3, CliError> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            CliError::usage(format!(
                "error: {flag} {s}: not three numbers\n  = help: e.g. {flag} 0,0,1\n"
            ))
        })?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(lampost_mesh::P3::new(*x, *y, *z)),
        _ => Err(CliError::usage(format!(
            "error: {flag} {s}: three finite numbers wanted\n  = help: e.g. {flag} 0,0,1\n"
        ))),
    }
}

/// `plan slice` arguments.
#[derive(Debug, clap::Args)]
pub struct SliceArgs {
    /// The mesh (STL, OBJ or OFF).
    pub file: String,
    /// Layer height (mm) for parallel planes.
    #[arg(long, allow_negative_numbers = true)]
    pub layer: Option<f64>,
    /// Build direction x,y,z (parallel planes; the fan's direction at angle 0).
    #[arg(long, default_value = "0,0,1", allow_hyphen_values = true)]
    pub build_dir: String,
    /// Height of the first plane above the part's lowest point (default: half a layer).
    #[arg(long, allow_negative_numbers = true)]
    pub first: Option<f64>,
    /// Fan of planes about an axis: px,py,pz,ax,ay,az (a point and the axis direction).
    #[arg(long, allow_hyphen_values = true, requires = "fan_step")]
    pub fan_axis: Option<String>,
    /// Fan: degrees between layers.
    #[arg(long, requires = "fan_axis", allow_negative_numbers = true)]
    pub fan_step: Option<f64>,
    /// Largest gap stitched between open chains (mm; default 1e-6 of the part's diagonal).
    #[arg(long, allow_negative_numbers = true)]
    pub stitch: Option<f64>,
    /// The mesh file's units (default mm); the slices are in mm.
    #[arg(long, value_enum)]
    pub units: Option<MeshUnits>,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write JSON (`plan slice`: layers, loops with signed area and length, gaps, open
    /// chains, instead of the CSV; `plan path`: the plan's report on standard output).
    #[arg(long)]
    pub json: bool,
    /// Write the loops' points as CSV (layer,loop,point,x,y,z,face) to this file.
    #[arg(short, long)]
    pub output: Option<String>,
}

pub(crate) fn plan_error(path: &str, e: &PlanError) -> CliError {
    let hint = match e {
        PlanError::Direction { .. } => "give a non-zero direction, e.g. --build-dir 0,0,1",
        PlanError::Layer { what, .. } if *what == "layer height" => "give a positive layer height (mm), e.g. --layer 0.5",
        PlanError::Layer { .. } => "give a positive number (see `lampost plan path --help`)",
        PlanError::LayerTooLarge { extent, .. } if *extent < 1.0 => "the layer must be smaller than the part's height along the build direction; a part under 1 mm may be in metres (Blender's, a robot's CAD): read it with --units m",
        PlanError::LayerTooLarge { .. } => "the layer must be smaller than the part's height along the build direction",
        PlanError::Fan(_) => "put the fan's axis along an edge of the part, with the part on the side build-dir × axis",
        _ => "repair the mesh",
    };
    let code_usage = matches!(e, PlanError::Direction { .. } | PlanError::Layer { .. });
    let msg = format!("error: {path}: {e}\n  = help: {hint}\n");
    if code_usage {
        CliError::usage(msg)
    } else {
        CliError::failed(msg)
    }
}

/// `lampost plan slice`.
/// Stage 1 of `plan slice` and `plan path`: the mesh read and sliced, the warnings said.
pub(crate) fn sliced(
    a: &SliceArgs,
) -> Result<(Mesh, Slicing, lampost_mesh::ManifoldReport, usize), CliError> {
    let dir = vec3("--build-dir", &a.build_dir)?;
    let planes = match (&a.fan_axis, a.fan_step, a.layer) {
        (Some(axis), Some(step), None) => {
            let v: Vec<f64> = axis
                .split(',')
                .map(|t| t.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .unwrap_or_default();
            if v.len() != 6 || !v.iter().all(|c| c.is_finite()) {
                return Err(CliError::usage(format!(
                    "error: --fan-axis {axis}: six finite numbers wanted (a point, then the axis direction)\n  = help: e.g. --fan-axis 0,0,0,0,-1,0\n"
                )));
            }
            Planes::Fan {
                point: lampost_mesh::P3::new(v[0], v[1], v[2]),
                axis: lampost_mesh::P3::new(v[3], v[4], v[5]),
                dir,
                step_deg: step,
            }
        }
        (None, None, Some(layer)) => Planes::Parallel {
            dir,
            layer,
            first: a.first,
        },
        _ => {
            return Err(CliError::usage(
                "error: give --layer H (parallel planes) or --fan-axis and --fan-step (a fan), not both\n  = help: e.g. --layer 0.5\n",
            ))
        }
    };
    let (mesh, _) = read_mm(&a.file, a.units)?;
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let report = lampost_mesh::manifold_report(&mesh);
    let s = lampost_plan::slice(
        &mesh,
        &SliceOptions {
            planes,
            stitch: a.stitch,
            threads,
        },
    )
    .map_err(|e| plan_error(&a.file, &e))?;
    let open: usize = s.slices.iter().map(|sl| sl.open.len()).sum();
    // Warnings on stderr: the mesh's bad edges, stitched gaps, open chains.
    if !report.closed_oriented() {
        eprintln!(
            "warning: {} is not a closed oriented manifold ({} boundary, {} non-manifold, {} inconsistent edges; `lampost mesh info` lists them): slicing what closes",
            a.file, report.boundary_edges, report.non_manifold_edges, report.inconsistent_edges
        );
    }
    for sl in &s.slices {
        for g in &sl.gaps {
            eprintln!(
                "warning: layer {}: stitched a gap of {:.3e} mm from ({:.6} {:.6} {:.6}) to ({:.6} {:.6} {:.6})",
                sl.index, g.length, g.from.x, g.from.y, g.from.z, g.to.x, g.to.y, g.to.z
            );
        }
        for c in &sl.open {
            let (b, e) = (c.start(), c.end());
            eprintln!(
                "warning: layer {}: an open chain of {} points could not be closed: from ({:.6} {:.6} {:.6}) to ({:.6} {:.6} {:.6})",
                sl.index,
                c.points.len(),
                b.x, b.y, b.z, e.x, e.y, e.z
            );
        }
    }
    let loops: usize = s.slices.iter().map(|sl| sl.loops.len()).sum();
    if loops == 0 && open == 0 {
        return Err(no_loop(&a.file, &report));
    }
    Ok((mesh, s, report, open))
}

/// The error for slices that hold no loop and no open chain: the planes miss the part,
/// or every face has its reverse twin (a double-sided export: the two sides of each
/// slice cancel).
fn no_loop(file: &str, report: &lampost_mesh::ManifoldReport) -> CliError {
    let help = if report.twin_faces > 0 {
        format!(
            "{} of the {} faces come twice, once each way round (a double-sided export): export the part single-sided (or remove each face's reversed twin) and slice again",
            report.twin_faces, report.faces
        )
    } else {
        "the planes miss the part: check --layer, --first, --build-dir or the fan (`lampost mesh info` gives the part's bounds)".to_string()
    };
    CliError::failed(format!(
        "error: {file}: the slices hold no loop; nothing written\n  = help: {help}\n"
    ))
}

pub fn slice(a: &SliceArgs) -> Result<(), CliError> {
    if a.json && a.output.is_some() {
        return Err(CliError::usage(
            "error: the argument '--json' cannot be used with '--output <OUTPUT>'
  = help: --json writes the slices to standard output
",
        ));
    }
    let (_, s, report, open) = sliced(a)?;
    if a.json {
        write_json(None, slicing_json(&a.file, &s, &report))?;
    } else if let Some(out) = &a.output {
        // Loops with open chains beside them are not a slicing to build from: the file
        // is not written (the warnings say what did not close).
        if open == 0 {
            write_out(Some(out), csv(&s).as_bytes())?;
        }
    } else {
        let loops: usize = s.slices.iter().map(|sl| sl.loops.len()).sum();
        let mut t = format!(
            "layers {}\nloops {loops}\nsegments {}\nopen chains {open}\n",
            s.slices.len(),
            s.segments
        );
        for sl in &s.slices {
            t.push_str(&format!("layer {} at {:.6}:", sl.index, sl.height));
            for l in &sl.loops {
                t.push_str(&format!(
                    " loop area {:+.6} length {:.6};",
                    l.area, l.length
                ));
            }
            if !sl.open.is_empty() {
                t.push_str(&format!(" {} open chains;", sl.open.len()));
            }
            t.push('\n');
        }
        write_out(None, t.as_bytes())?;
    }
    if open > 0 {
        return Err(open_chains(&a.file, open, &report, a.output.is_some()));
    }
    Ok(())
}

/// The error for slices whose chains did not close into loops. On a closed mesh with
/// flipped faces (edges joining faces wound against each other) the flipped faces are
/// named: a wider stitch would join a chain to its own flipped twin, a loop of no area
/// deposited with the axis reversed (h49's cube with one face flipped).
pub(crate) fn open_chains(
    file: &str,
    open: usize,
    report: &lampost_mesh::ManifoldReport,
    nothing_written: bool,
) -> CliError {
    let help = if report.inconsistent_edges > 0 && report.boundary_edges == 0 {
        format!(
            "{} edges join faces wound against each other (flipped faces): orient the mesh's faces consistently (MeshLab's Re-Orient, Blender's Recalculate Outside, trimesh's fix_normals) and slice again; a wider --stitch would join each chain to its flipped twin",
            report.inconsistent_edges
        )
    } else {
        "repair the mesh (`lampost mesh info` names its bad edges) or widen --stitch".to_string()
    };
    CliError::failed(format!(
        "error: {file}: {open} chains could not be closed into loops (see the warnings above){}\n  = help: {help}\n",
        if nothing_written { "; nothing written" } else { "" }
    ))
}

fn slicing_json(path: &str, s: &Slicing, report: &lampost_mesh::ManifoldReport) -> Obj {
    let layers: Vec<Obj> = s
        .slices
        .iter()
        .map(|sl| {
            let loops: Vec<Obj> = sl
                .loops
                .iter()
                .map(|l| obj! {"points": l.points.len(), "area": l.area, "length": l.length, "stitched": l.stitched})
                .collect();
            let open: Vec<Obj> = sl
                .open
                .iter()
                .map(|c| obj! {"points": c.points.len(), "start": p(&c.start()), "end": p(&c.end())})
                .collect();
            let gaps: Vec<Obj> = sl
                .gaps
                .iter()
                .map(|g| obj! {"from": p(&g.from), "to": p(&g.to), "length": g.length})
                .collect();
            obj! {
                "index": sl.index, "height": sl.height, "normal": p(&sl.normal), "segments": sl.segments,
                "area": sl.loops.iter().map(|l| l.area).sum::<f64>(),
                "loops": loops, "open": open, "gaps": gaps,
            }
        })
        .collect();
    obj! {
        "file": path, "units": "mm", "layers": s.slices.len(), "segments": s.segments,
        "loops": s.slices.iter().map(|sl| sl.loops.len()).sum::<usize>(),
        "open_chains": s.slices.iter().map(|sl| sl.open.len()).sum::<usize>(),
        "flipped": s.flipped, "degenerate_loops": s.degenerate_loops, "stitch": s.stitch,
        "closed": report.closed_oriented(),
        "slices": layers,
    }
}

fn csv(s: &Slicing) -> String {
    let mut t = String::from("layer,loop,point,x,y,z,face\n");
    for sl in &s.slices {
        for (li, l) in sl.loops.iter().enumerate() {
            for (i, (q, f)) in l.points.iter().zip(&l.faces).enumerate() {
                t.push_str(&format!(
                    "{},{li},{i},{:?},{:?},{:?},{f}\n",
                    sl.index, q.x, q.y, q.z
                ));
            }
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn box_3mf() -> String {
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../fixtures/meshes/3mf/box.3mf"
        )
        .to_string()
    }

    fn extent(m: &Mesh) -> [f64; 3] {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for v in &m.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]]
    }

    /// A 3MF says its units: read for an inch machine (the FADAL), the 10 × 20 × 30 mm
    /// box is 10/25.4 × 20/25.4 × 30/25.4 in, whatever the command (inspect and
    /// `post --part` took it as inches before); a units option with it is refused.
    #[test]
    fn a_3mf_is_read_in_the_units_it_says() {
        let (mm, from) = read_mesh_in(&box_3mf(), None, Units::Mm).expect("reads");
        assert_eq!(from, Units::Mm);
        let (inch, _) = read_mesh_in(&box_3mf(), None, Units::In).expect("reads");
        let (a, b) = (extent(&mm), extent(&inch));
        for k in 0..3 {
            assert!((a[k] - [10.0, 20.0, 30.0][k]).abs() < 1e-9, "{a:?}");
            assert!((b[k] - a[k] / 25.4).abs() < 1e-12, "{b:?}");
        }
        assert!(read_mesh_in(&box_3mf(), Some(MeshUnits::In), Units::In).is_err());
    }

    /// Any other mesh is in the units given, else in those wanted.
    #[test]
    fn other_meshes_are_in_the_units_given_else_those_wanted() {
        let stl = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../fixtures/meshes/block.stl"
        );
        let (as_is, from) = read_mesh_in(stl, None, Units::In).expect("reads");
        assert_eq!(from, Units::In);
        let (scaled, from) = read_mesh_in(stl, Some(MeshUnits::Mm), Units::In).expect("reads");
        assert_eq!(from, Units::Mm);
        let (a, b) = (extent(&as_is), extent(&scaled));
        for k in 0..3 {
            assert!((b[k] - a[k] / 25.4).abs() < 1e-12, "{a:?} {b:?}");
        }
    }
}
