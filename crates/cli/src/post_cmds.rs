//! `lampost post` and `lampost verify`.

use std::io::{BufReader, Write};
use std::path::{Path, PathBuf};

use lampost_kinematics::{Machine, Vector3};
use lampost_post::safety::WorkBounds;
use lampost_post::{
    Frame, IntendedOptions, LayerSchedule, Orient, PostConfig, PostDialect, PostError, Process,
    Section, Source,
};

use crate::io::{display_name, TempFile};
use crate::json::{self, obj, Obj};
use crate::kin_cmds::{load_machine, vector};
use crate::report::CliError;

/// Render a post error for people.
pub fn post_error(e: PostError) -> CliError {
    let hint = e.hint();
    render_post_error(e, hint)
}

/// Render an error met reading posted programs (`verify`, `preview`), placed in the
/// files given: an error of the posted text is no fault of the input program.
pub fn posted_error(posted: &[String], e: PostError) -> CliError {
    let of_posted = matches!(&e, PostError::Input { file, .. } if file == "the posted program");
    let e = crate::posted::locate(posted, e);
    if of_posted {
        render_post_error(e, "the posted program does not read as one lampost writes: it was changed after it was posted (post it again), or it is not a program lampost posted")
    } else {
        post_error(e)
    }
}

fn render_post_error(e: PostError, hint: &str) -> CliError {
    let msg = match &e {
        PostError::Input { file, diag } => crate::report::render(file, diag),
        _ => format!("error: {e}\n"),
    };
    CliError::failed(format!(
        "{}  = help: {hint}\n",
        if msg.ends_with('\n') {
            msg
        } else {
            format!("{msg}\n")
        }
    ))
}

/// Options that place and orient the input.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct Placement {
    /// Fixed rotary index, e.g. A=45,B=-45 (the program frame is the part frame moved to --origin).
    #[arg(long, allow_hyphen_values = true)]
    pub index: Option<String>,
    /// No summary line on stderr at the end (warnings and errors are still written).
    #[arg(long, short)]
    pub quiet: bool,
    /// Setup file (from `lampost align`): the program frame on the part; program +Z becomes the tool axis.
    #[arg(long)]
    pub setup: Option<String>,
    /// Job file with several sections, each with its program, index or setup.
    #[arg(long)]
    pub job: Option<String>,
    /// Program origin in the part frame (with --index, or without a setup).
    #[arg(long, allow_hyphen_values = true)]
    pub origin: Option<String>,
    /// Layer schedule: turn each Z level of the program about this part-frame direction…
    #[arg(long, allow_hyphen_values = true)]
    pub layer_axis: Option<String>,
    /// …through this part-frame point…
    #[arg(long, allow_hyphen_values = true)]
    pub layer_point: Option<String>,
    /// …by this many degrees per layer.
    #[arg(long, allow_hyphen_values = true)]
    pub layer_angle: Option<f64>,
    /// Starting rotary position for choosing solutions, e.g. A=0,B=0.
    #[arg(long, allow_hyphen_values = true)]
    pub near: Option<String>,
    /// Scale a program in other units to the machine's (otherwise an error).
    #[arg(long)]
    pub convert_units: bool,
    /// E words are slicer extrusion: deposit only while E grows (implied by --flavor marlin or reprap).
    #[arg(long)]
    pub e_extrusion: bool,
    /// Units of the input where it does not say (a program before any G20/G21, a
    /// per-point file); default: the machine's. Other units than the machine's need
    /// --convert-units.
    #[arg(long, value_enum)]
    pub units: Option<crate::UnitsArg>,
    /// The control the input was written for (auto: decided from the first section's program).
    #[arg(long, value_enum, default_value = "auto")]
    pub flavor: crate::FlavorArg,
    /// INPUT is a path with its own tool axis: rows `x y z i j k [feed] [laser]` (implied by a .csv name, or a first line `x y z i j k …` or of 6 to 8 numbers).
    #[arg(long)]
    pub per_point: bool,
    /// Stock as a box in the part frame, X0,Y0,Z0,X1,Y1,Z1 (machine units): safe heights clear it.
    #[arg(long, allow_hyphen_values = true)]
    pub stock: Option<String>,
    /// The part as an STL mesh in the part frame: safe heights clear it, and no rapid's
    /// tool tip or head (the machine file's head_radius, head_length) may meet it.
    #[arg(long)]
    pub part: Option<String>,
    /// Units of the --part mesh (default: the machine's).
    #[arg(long, value_parser = ["inch", "mm", "m"])]
    pub part_units: Option<String>,
}

/// The `--part` mesh, in the machine's units, with a warning when it is not closed.
fn part_mesh(
    pl: &Placement,
    m: &Machine,
) -> Result<Option<std::sync::Arc<lampost_post::collide::PartMesh>>, CliError> {
    let Some(path) = &pl.part else {
        return Ok(None);
    };
    let given = match pl.part_units.as_deref() {
        Some("mm") => Some(crate::mesh_cmds::MeshUnits::Mm),
        Some("inch") => Some(crate::mesh_cmds::MeshUnits::In),
        Some("m") => Some(crate::mesh_cmds::MeshUnits::M),
        _ => None,
    };
    let want = crate::mesh_cmds::machine_units(m.units);
    let (mesh, _) = crate::mesh_cmds::read_mesh_in(path, given, want)?;
    let bad = |e: lampost_post::collide::CollideError| {
        CliError::failed(format!(
            "error: {path}: {e}\n  = help: export the part as an STL with finite coordinates\n"
        ))
    };
    let part = lampost_post::collide::PartMesh::from_mesh(&mesh).map_err(bad)?;
    let machine_mm = m.units == lampost_kinematics::Units::Mm;
    // A mesh in other units than it is read in is far larger (or smaller) than the machine.
    let (lo, hi) = part.bounds();
    let size = (hi - lo).norm();
    let travel = Vector3::new(
        m.linear[0].limits.1 - m.linear[0].limits.0,
        m.linear[1].limits.1 - m.linear[1].limits.0,
        m.linear[2].limits.1 - m.linear[2].limits.0,
    )
    .norm();
    if size > 5.0 * travel {
        let units = if machine_mm { "mm" } else { "inch" };
        return Err(CliError::failed(format!(
            "error: {path}: the part is {size:.1} {units} across, {:.0} times the machine's travel ({travel:.1} {units})\n  = help: is the mesh in other units? give --part-units mm or --part-units inch\n",
            size / travel
        )));
    }
    let report = part.manifold();
    if !report.closed() {
        eprintln!(
            "warning: {path} is not a closed manifold ({} boundary edges, {} edges shared by more than two triangles, {} degenerate triangles): it is checked as a surface only",
            report.boundary_edges, report.non_manifold_edges, report.degenerate_triangles
        );
    }
    Ok(Some(std::sync::Arc::new(part)))
}

/// The work given besides the program's feed tips (`--stock`, the `--part` mesh's hull).
fn extra_work(
    pl: &Placement,
    part: Option<&lampost_post::collide::PartMesh>,
) -> Result<Option<WorkBounds>, CliError> {
    let mut w = WorkBounds::empty();
    if let Some(p) = part {
        w.add_points(p.hull_points().iter().copied());
    }
    let Some(text) = &pl.stock else {
        return Ok(part.map(|_| w));
    };
    let (a, b) = text
        .match_indices(',')
        .nth(2)
        .map(|(i, _)| (&text[..i], &text[i + 1..]))
        .ok_or_else(|| {
            CliError::usage(format!(
                "error: --stock `{text}`: give two corners, X0,Y0,Z0,X1,Y1,Z1\n"
            ))
        })?;
    let (lo, hi) = (vector("--stock", a)?, vector("--stock", b)?);
    let mut bx = WorkBounds::empty();
    bx.add(&lo);
    bx.add(&hi);
    w.add_points(bx.extremes());
    Ok(Some(w))
}

/// INPUT as the post reads it: a file, or standard input or a pipe spooled to a
/// temporary file (kept while the post reads it twice: it verifies what it wrote).
pub struct InputFile {
    /// The name for messages (`<stdin>` for `-`).
    name: String,
    path: PathBuf,
    _spool: Option<TempFile>,
}

impl InputFile {
    pub fn open(input: &str) -> Result<InputFile, CliError> {
        let path = Path::new(input);
        if input == "-" || crate::io::is_special(path) {
            let temp = crate::io::spool(input)?;
            return Ok(InputFile {
                name: display_name(input),
                path: temp.path().to_path_buf(),
                _spool: Some(temp),
            });
        }
        if !path.is_file() {
            return Err(CliError::usage(format!(
                "error: cannot open {input}\n  = help: check the path; use - for standard input\n"
            )));
        }
        crate::io::note_input(path);
        Ok(InputFile {
            name: input.to_string(),
            path: PathBuf::from(input),
            _spool: None,
        })
    }

    /// Whether it is a per-point path: `--per-point`, a `.csv` name, or a first line
    /// that reads as one ([`lampost_post::pointwise::looks_like_points`]; standard input
    /// too, so `lampost plan path … -o - | lampost post -` needs no flag).
    fn per_point(&self, pl: &Placement) -> bool {
        if pl.per_point || self.name.to_ascii_lowercase().ends_with(".csv") {
            return true;
        }
        let mut head = Vec::with_capacity(4096);
        let read = std::fs::File::open(&self.path)
            .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, 4096), &mut head));
        read.is_ok() && lampost_post::pointwise::looks_like_points(&String::from_utf8_lossy(&head))
    }
}

/// INPUT opened; standard input when none is named for `--per-point` (a job or a
/// missing program is for [`sections`] to judge).
fn input_file(pl: &Placement, input: Option<&str>) -> Result<Option<InputFile>, CliError> {
    match input {
        Some(i) => InputFile::open(i).map(Some),
        None if pl.per_point => InputFile::open("-").map(Some),
        None => Ok(None),
    }
}

/// INPUT when it is a per-point path.
fn per_point_path<'a>(pl: &Placement, input: Option<&'a InputFile>) -> Option<&'a InputFile> {
    input.filter(|i| i.per_point(pl))
}

/// The frame and points of a per-point input.
/// `--units` as the G-code layer's units.
fn gcode_units(u: crate::UnitsArg) -> lampost_gcode::Units {
    match u {
        crate::UnitsArg::Inch => lampost_gcode::Units::Inch,
        crate::UnitsArg::Mm => lampost_gcode::Units::Mm,
    }
}

/// A per-point path in `--units` other than the machine's: scaled to the machine's with
/// `--convert-units` (positions and feeds), else refused, naming both.
fn per_point_units(
    m: &Machine,
    pl: &Placement,
    name: &str,
    pts: &mut [lampost_post::pointwise::PathPoint],
) -> Result<(), CliError> {
    let machine_mm = m.units == lampost_kinematics::Units::Mm;
    let Some(given) = pl.units else {
        return Ok(());
    };
    let given_mm = matches!(given, crate::UnitsArg::Mm);
    if given_mm == machine_mm {
        return Ok(());
    }
    let (from, to) = if given_mm {
        ("millimetres", "inches")
    } else {
        ("inches", "millimetres")
    };
    if !pl.convert_units {
        return Err(CliError::usage(format!(
            "error: {name}: the points are in {from} (--units), the machine {} works in {to}\n  = help: add --convert-units to scale the points and feeds to {to}\n",
            m.name
        )));
    }
    let k = if given_mm { 1.0 / 25.4 } else { 25.4 };
    for p in pts.iter_mut() {
        p.tip *= k;
        p.feed *= k;
    }
    Ok(())
}

fn per_point_input(
    pl: &Placement,
    input: &InputFile,
) -> Result<(Frame, Vec<lampost_post::pointwise::PathPoint>, String), CliError> {
    if pl.part.is_some() {
        return Err(CliError::usage("error: --part checks rapids of planar programs against the part; a per-point path is not checked against a mesh yet: leave out --part (use --stock for safe heights)\n".to_string()));
    }
    if pl.index.is_some() || pl.job.is_some() || pl.layer_axis.is_some() {
        return Err(CliError::usage("error: a per-point path carries its own tool axis: use --setup or --origin, not --index, --job or a layer schedule\n".to_string()));
    }
    let frame = match &pl.setup {
        Some(st) => setup_frame(st)?,
        None => Frame::translation(
            pl.origin
                .as_deref()
                .map(|o| crate::kin_cmds::position("--origin", o))
                .transpose()?
                .unwrap_or_else(Vector3::zeros),
        ),
    };
    let name = input.name.clone();
    let text = crate::io::read_file_to_string(&input.path)
        .map_err(|e| CliError::usage(format!("error: cannot read {name}: {e}\n")))?;
    let pts = lampost_post::pointwise::read_points(&text, &name).map_err(post_error)?;
    Ok((frame, pts, name))
}

fn index_arg(m: &Machine, text: &str) -> Result<[f64; 2], CliError> {
    let v = crate::kin_cmds::joints_arg(m, "--index", text, &[3, 4], &[3, 4])?;
    let index = [v[3].unwrap_or(0.0), v[4].unwrap_or(0.0)];
    // A continuous rotary indexed past a turn would wind the table round for nothing
    // (a FADAL moves a rotary at most 1080° in a block: `A1500.` stops it).
    for (r, a) in m.rotary.iter().zip(index) {
        if r.continuous && a.abs() > 360.0 {
            return Err(CliError::usage(format!(
                "error: --index {}={}: more than a turn; the same orientation is {}={}\n  = help: give a continuous rotary's index within ±360°\n",
                r.name,
                lampost_gcode::Readable(a),
                r.name,
                lampost_gcode::Readable(a.rem_euclid(360.0))
            )));
        }
    }
    Ok(index)
}

fn file_error(file: &str, text: &str, e: &toml::de::Error) -> CliError {
    // Without a span (a check after reading, e.g. an array with extra values), the line
    // that sets the key the message names in backquotes.
    let at = e.span().map(|sp| sp.start).or_else(|| {
        let key = e.message().split('`').nth(1)?;
        let last = key
            .rsplit(['.', ']'])
            .find(|k| !k.is_empty() && !k.contains('['))?;
        lampost_kinematics::key_offset(text, last)
    });
    let (line, col) = at.map_or((0, 0), |start| {
        let before = &text[..start.min(text.len())];
        (
            before.matches('\n').count() + 1,
            before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1,
        )
    });
    let shown = text.lines().nth(line.saturating_sub(1)).unwrap_or("");
    CliError::failed(format!("error: {}\n  --> {file}:{line}:{col}\n   | {shown}\n  = help: see docs/post.md for the file's keys\n", e.message().trim()))
}

fn setup_frame(path: &str) -> Result<Frame, CliError> {
    let text = crate::io::read_file_to_string(path)
        .map_err(|e| CliError::usage(format!("error: cannot read {path}: {e}\n")))?;
    lampost_post::read_setup(&text, path).map_err(post_error)
}

/// The flavour of the sections' programs: given, or for `auto` decided from the first
/// section's first bytes.
pub fn section_flavor(
    pl: &Placement,
    secs: &[Section],
) -> Result<lampost_gcode::Resolved, CliError> {
    use lampost_gcode::DETECT_BYTES;
    use std::io::Read;
    let mut head = Vec::new();
    if pl.flavor == crate::FlavorArg::Auto {
        match secs.first().map(|s| &s.source) {
            Some(Source::Bytes(b)) => head.extend_from_slice(&b[..b.len().min(DETECT_BYTES)]),
            Some(Source::Path(p)) => {
                std::fs::File::open(p)
                    .and_then(|f| f.take(DETECT_BYTES as u64).read_to_end(&mut head))
                    .map_err(|e| {
                        CliError::usage(format!("error: cannot read {}: {e}\n", p.display()))
                    })?;
            }
            None => {}
        }
    }
    Ok(lampost_gcode::Resolved::new(pl.flavor.flavor(), &head))
}

/// With E read as extrusion (`--e-extrusion`, or a slicer flavour), programs none of
/// whose moves extrudes would be posted as travel alone: refused, located at the first
/// feed move (or the first move) of the first such section. The programs are read as the
/// post reads them, up to the first extruding move (the start of a slicer program); a
/// program that fails to read, or has no moves, is left to the post to report.
fn refuse_dry(
    secs: &[Section],
    opts: &IntendedOptions,
    given: bool,
    flavor: &lampost_gcode::Resolved,
) -> Result<(), CliError> {
    use lampost_gcode::{
        Diagnostic, EWord, ErrorKind, Event, LineReader, MoveKind, Options, Order, ProgramReader,
        Severity, Stream, Units,
    };
    if !opts.e_extrusion {
        return Ok(());
    }
    fn open(sec: &Section) -> Result<Box<dyn crate::io::ReadSeek + '_>, CliError> {
        Ok(match &sec.source {
            Source::Path(p) => Box::new(std::fs::File::open(p).map_err(|e| {
                CliError::usage(format!("error: cannot open {}: {e}\n", p.display()))
            })?),
            Source::Bytes(b) => Box::new(std::io::Cursor::new(b.as_slice())),
        })
    }
    // (section, line, whether a feed move) of the first feed move, else the first move.
    let mut first: Option<(usize, u32, bool)> = None;
    for (k, sec) in secs.iter().enumerate() {
        let o = Options {
            units: opts.units.unwrap_or(Units::Mm),
            e_word: EWord::Extrusion,
            flavor: opts.flavor,
            ..Options::default()
        };
        let src = ProgramReader::new(open(sec)?, Order::Execution);
        for ev in Stream::new(src, o, true) {
            let m = match ev {
                Ok(Event::Move(m)) => m,
                Ok(Event::Diagnostic(d)) if d.severity == Severity::Error => return Ok(()),
                Ok(Event::Diagnostic(_) | Event::Stop(_)) => continue,
                Err(_) => return Ok(()),
            };
            // As the post deposits: a feed along which E grows (a rapid never deposits).
            let feed = !matches!(m.kind, MoveKind::Rapid);
            if feed && m.extruded.is_some_and(|grown| grown > 0.0) {
                return Ok(());
            }
            if first.is_none_or(|(_, _, f)| !f && feed) {
                first = Some((k, m.line, feed));
            }
        }
    }
    let Some((k, line, _)) = first else {
        return Ok(());
    };
    let sec = &secs[k];
    let mut lines = LineReader::new(BufReader::new(open(sec)?));
    while let Ok(Some(l)) = lines.next_line() {
        if l.number == line {
            let why = if given {
                "--e-extrusion".to_string()
            } else if flavor.auto {
                format!(
                    "implied by the printer flavour {}, which --flavor auto chose from {}; give --flavor for the control the program was written for when it is not a printer's",
                    flavor.flavor.name(),
                    flavor.reason
                )
            } else {
                format!("implied by --flavor {}", flavor.flavor.name())
            };
            let d = Diagnostic::at(
                Severity::Error,
                ErrorKind::NoExtrusion(why),
                line,
                l.offset,
                l.bytes,
                0,
                l.bytes.len(),
            );
            return Err(CliError::failed(crate::report::render(&sec.name, &d)));
        }
    }
    Ok(())
}

/// How the sections' programs are read. A slicer flavour implies E as extrusion for
/// deposition only: a machining job cuts along its feeds, E or none (a program `auto`
/// took for a printer's on one `G4 S1` lost every cut as travel).
fn intended_options(
    pl: &Placement,
    flavor: &lampost_gcode::Resolved,
    process: &lampost_post::Process,
) -> IntendedOptions {
    let flavor = flavor.flavor;
    let deposit = matches!(process, lampost_post::Process::Deposit { .. });
    IntendedOptions {
        convert_units: pl.convert_units,
        e_extrusion: pl.e_extrusion || (deposit && flavor.is_slicer()),
        flavor,
        units: pl.units.map(gcode_units),
    }
}

/// Build the sections from the placement options and INPUT (kept open while the
/// sections are read).
pub fn sections(
    m: &Machine,
    pl: &Placement,
    input: Option<&InputFile>,
) -> Result<Vec<Section>, CliError> {
    let chosen = [pl.index.is_some(), pl.setup.is_some(), pl.job.is_some()]
        .iter()
        .filter(|x| **x)
        .count();
    if chosen > 1 {
        return Err(CliError::usage(
            "error: give one of --index, --setup or --job\n".to_string(),
        ));
    }
    let layers = match (&pl.layer_axis, pl.layer_angle) {
        (None, None) => None,
        (Some(a), Some(d)) => {
            let axis = vector("--layer-axis", a)?;
            if axis.norm() < 1e-12 {
                return Err(CliError::usage(
                    "error: --layer-axis has zero length\n".to_string(),
                ));
            }
            let point = pl
                .layer_point
                .as_deref()
                .map(|p| vector("--layer-point", p))
                .transpose()?
                .unwrap_or_else(Vector3::zeros);
            Some(LayerSchedule {
                axis,
                point,
                deg_per_layer: d,
            })
        }
        _ => {
            return Err(CliError::usage(
                "error: a layer schedule needs both --layer-axis and --layer-angle\n".to_string(),
            ))
        }
    };
    if layers.is_some() && pl.index.is_some() {
        return Err(CliError::usage("error: a layer schedule re-indexes every layer; use --setup or --origin, not --index\n".to_string()));
    }
    let origin = pl
        .origin
        .as_deref()
        .map(|o| crate::kin_cmds::position("--origin", o))
        .transpose()?
        .unwrap_or_else(Vector3::zeros);
    if let Some(job) = &pl.job {
        let text = crate::io::read_file_to_string(job)
            .map_err(|e| CliError::usage(format!("error: cannot read {job}: {e}\n")))?;
        let jf = lampost_post::read_job(&text).map_err(|e| file_error(job, &text, &e))?;
        let dir = Path::new(job).parent().unwrap_or(Path::new("."));
        let mut out = Vec::new();
        for (k, s) in jf.section.iter().enumerate() {
            let path = dir.join(&s.program);
            let name = path.to_string_lossy().into_owned();
            let axes_frame = || {
                if s.origin
                    .is_some_and(|o| o.iter().any(|c| c.abs() > crate::kin_cmds::MAX_PLACE))
                {
                    return Err(CliError::failed(format!(
                        "error: {job}: section {}: the origin lies more than 1e9 from the part's origin\n  = help: give it in the machine's units (in or mm)\n",
                        k + 1
                    )));
                }
                Frame::from_axes(
                    Vector3::from(s.origin.unwrap_or([0.0; 3])),
                    Vector3::from(s.x_axis.unwrap_or([1.0, 0.0, 0.0])),
                    Vector3::from(s.z_axis.unwrap_or([0.0, 0.0, 1.0])),
                )
                .map_err(|e| CliError::failed(format!("error: {job}: section {}: {e}\n", k + 1)))
            };
            let (frame, orient) = match (&s.index, &s.setup) {
                (Some(_), Some(_)) => {
                    return Err(CliError::failed(format!(
                        "error: {job}: section {} gives both index and setup\n",
                        k + 1
                    )))
                }
                (Some(ix), None) => {
                    let text: String = ix
                        .iter()
                        .map(|(n, v)| format!("{n}={v}"))
                        .collect::<Vec<_>>()
                        .join(",");
                    (axes_frame()?, Orient::Index(index_arg(m, &text)?))
                }
                (None, Some(st)) => (
                    setup_frame(&dir.join(st).to_string_lossy())?,
                    Orient::ToolAxis,
                ),
                (None, None) => (axes_frame()?, Orient::ToolAxis),
            };
            if !path.is_file() {
                return Err(CliError::failed(format!(
                    "error: {job}: section {}: cannot open {name}\n",
                    k + 1
                )));
            }
            crate::io::note_input(&path);
            out.push(Section {
                name,
                source: Source::Path(path),
                frame,
                orient,
                layers,
            });
        }
        if out.is_empty() {
            return Err(CliError::failed(format!(
                "error: {job} has no [[section]]\n"
            )));
        }
        return Ok(out);
    }
    let input = input
        .ok_or_else(|| CliError::usage("error: give the INPUT program (or --job)\n".to_string()))?;
    let (frame, orient) = match (&pl.index, &pl.setup) {
        (Some(ix), None) => (Frame::translation(origin), Orient::Index(index_arg(m, ix)?)),
        (None, Some(st)) => (setup_frame(st)?, Orient::ToolAxis),
        _ => (Frame::translation(origin), Orient::ToolAxis),
    };
    Ok(vec![Section {
        name: input.name.clone(),
        source: Source::Path(input.path.clone()),
        frame,
        orient,
        layers,
    }])
}

/// The process options: what `post` writes, and what `verify` holds the posted text to
/// (the same flags for both).
#[derive(clap::Args, Debug, Clone)]
pub struct ProcessArgs {
    /// deposit or machine.
    #[arg(long, default_value = "deposit")]
    pub process: String,
    /// Laser power for deposition.
    #[arg(long, default_value_t = 1000.0)]
    pub power: f64,
    /// Machining: tool number (T… M6) of the first tool; the input's tool changes post each later tool with its own T, G43 H and S.
    #[arg(long)]
    pub tool: Option<u32>,
    /// Machining: tool length offset register (G43 H…) of the first tool; needed when the input changes tools.
    #[arg(long)]
    pub length_offset: Option<u32>,
    /// Machining: work offset, e.g. E1 (FADAL) or G54.
    #[arg(long)]
    pub work_offset: Option<String>,
    /// Machining: spindle speed of the first tool.
    #[arg(long, default_value_t = 3000.0)]
    pub spindle: f64,
    /// Machining: coolant on.
    #[arg(long)]
    pub coolant: bool,
}

impl ProcessArgs {
    /// The library's process from the flags.
    pub fn to_process(&self) -> Result<Process, CliError> {
        match self.process.as_str() {
            "deposit" => Ok(Process::Deposit { power: self.power }),
            "machine" => Ok(Process::Machine {
                tool: self.tool,
                length_offset: self.length_offset,
                work_offset: self.work_offset.clone(),
                spindle: self.spindle,
                coolant: self.coolant,
            }),
            other => Err(CliError::usage(format!(
                "error: --process {other}: use deposit or machine\n"
            ))),
        }
    }

    /// Whether a machining option is given (an arm's post has none).
    pub fn machining_options(&self) -> Vec<&'static str> {
        [
            (self.tool.is_some(), "--tool"),
            (self.length_offset.is_some(), "--length-offset"),
            (self.work_offset.is_some(), "--work-offset"),
            (self.coolant, "--coolant"),
        ]
        .into_iter()
        .filter_map(|(given, flag)| given.then_some(flag))
        .collect()
    }
}

/// Options of `lampost post`.
#[derive(clap::Args, Debug, Clone)]
pub struct PostArgs {
    /// Built-in machine name or machine file.
    #[arg(long)]
    pub machine: String,
    /// Also draw the posted program (part frame, one colour per index, rapids dashed, the travel at each index) as SVG into this file; needs -o.
    #[arg(long, value_name = "FILE.svg")]
    pub preview: Option<String>,
    /// The preview's view: top (part XY) or iso.
    #[arg(long, default_value = "top", value_name = "top|iso")]
    pub view: String,
    #[command(flatten)]
    pub place: Placement,
    /// Head: laser, spindle, … (default: laser for deposit, spindle for machine; machining
    /// on a machine without a spindle head needs one named).
    #[arg(long)]
    pub head: Option<String>,
    #[command(flatten)]
    pub proc: ProcessArgs,
    /// fadal, iso or nrc (default: fadal for an inch machine, nrc for nrc-lc, else iso).
    #[arg(long)]
    pub dialect: Option<String>,
    /// Override a machine parameter (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Chord tolerance for linearised arcs (default 0.0005 in / 0.01 mm).
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Number blocks: START,STEP.
    #[arg(long)]
    pub renumber: Option<String>,
    /// Program number (FADAL O word).
    #[arg(long, default_value_t = 1000)]
    pub program_number: u32,
    /// The largest posted program, as a multiple of the input's size (at least 16 MiB).
    #[arg(long, default_value_t = 50.0)]
    pub max_growth: f64,
    /// Arms: configuration letters, l/r shoulder, u/d elbow, n/f wrist (default: the arm file's).
    #[arg(long)]
    pub config: Option<String>,
    /// Arms: largest distance between locations along the path (default: the arm file's).
    #[arg(long)]
    pub spacing: Option<f64>,
    /// Arms: locations per controller file, the two safe ones included (default: the arm file's).
    #[arg(long)]
    pub chunk_points: Option<usize>,
}

/// The head a process uses unless one is named (the library's choice, which refuses
/// machining on a machine without a spindle).
fn default_head(m: &Machine, process: &str, named: Option<&str>) -> Result<String, CliError> {
    if let Some(n) = named {
        return Ok(n.to_string());
    }
    let h = lampost_post::process_head(m, process == "deposit")
        .map_err(|e| CliError::usage(format!("error: {e}\n  = help: {}\n", e.hint())))?;
    Ok(m.heads.get(h).map_or_else(String::new, |h| h.name.clone()))
}

/// The post configuration from the options, the sections and their flavour (resolved once,
/// by [`section_flavor`]).
pub fn config(
    m: &Machine,
    a: &PostArgs,
    sections: &[Section],
    flavor: &lampost_gcode::Resolved,
) -> Result<PostConfig, CliError> {
    let part = part_mesh(&a.place, m)?;
    let process = a.proc.to_process()?;
    let intended = intended_options(&a.place, flavor, &process);
    // The library's defaults (head, dialect, tolerances), then what the flags say.
    let defaults = PostConfig::new(m, process.clone());
    let head = match a.head.as_deref() {
        Some(h) => m.head(h).map_err(crate::kin_cmds::kin_error)?,
        None => {
            // (The library's choice, refused for machining without a spindle.)
            default_head(m, &a.proc.process, None)?;
            defaults.head
        }
    };
    let head_name = m.heads[head].name.clone();
    let dialect = match a.dialect.as_deref() {
        Some("fadal") => PostDialect::Fadal,
        Some("iso") => PostDialect::Iso,
        Some("nrc") => PostDialect::Nrc,
        Some(other) => {
            return Err(CliError::usage(format!(
                "error: --dialect {other}: use fadal, iso or nrc\n"
            )))
        }
        None => defaults.dialect,
    };
    let tolerance = a.tolerance.unwrap_or(defaults.tolerance);
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(CliError::usage(format!(
            "error: --tolerance {tolerance}: must be positive\n"
        )));
    }
    // The written numbers are on the output's grid (0.0001 in, 0.001 mm, or the
    // machine's coarser resolution): a tolerance below half its step cannot be held, and
    // the in-process check would call it a fault.
    let step = m.def.linear.iter().map(|l| l.resolution).fold(
        match m.units {
            lampost_kinematics::Units::Inch => 1e-4,
            lampost_kinematics::Units::Mm => 1e-3,
        },
        f64::max,
    );
    if tolerance < step / 2.0 {
        return Err(CliError::usage(format!(
            "error: --tolerance {}: finer than the program can be written (its linear words are on a grid of {step}); give at least {}\n",
            lampost_gcode::Readable(tolerance),
            step / 2.0
        )));
    }
    let renumber = a
        .renumber
        .as_deref()
        .map(|r| {
            let bad = || CliError::usage(format!("error: --renumber {r}: expected START,STEP\n"));
            let (s, t) = r.split_once(',').ok_or_else(bad)?;
            Ok::<_, CliError>((
                s.trim().parse::<u64>().map_err(|_| bad())?,
                t.trim().parse::<u64>().map_err(|_| bad())?.max(1),
            ))
        })
        .transpose()?;
    let near = crate::kin_cmds::near_rotary(m, a.place.near.as_deref())?;
    let mut header = defaults.header.clone();
    header.push(format!("head {head_name}, process {}", a.proc.process));
    for s in sections {
        let f = &s.frame;
        let place = match s.orient {
            Orient::Index(r) => format!(
                "index {}{:.3} {}{:.3}",
                m.rotary[0].name, r[0], m.rotary[1].name, r[1]
            ),
            Orient::ToolAxis => "program +Z as the tool axis".to_string(),
        };
        header.push(format!(
            "{}: {place}; origin {:.4} {:.4} {:.4}; x {:.4} {:.4} {:.4}; z {:.4} {:.4} {:.4}",
            Path::new(&s.name)
                .file_name()
                .map_or(s.name.clone(), |n| n.to_string_lossy().into_owned()),
            f.origin.x,
            f.origin.y,
            f.origin.z,
            f.rot[(0, 0)],
            f.rot[(1, 0)],
            f.rot[(2, 0)],
            f.rot[(0, 2)],
            f.rot[(1, 2)],
            f.rot[(2, 2)]
        ));
        if let Some(l) = &s.layers {
            header.push(format!("layers turned {:.4} deg each about ({:.4} {:.4} {:.4}) through ({:.4} {:.4} {:.4})", l.deg_per_layer, l.axis.x, l.axis.y, l.axis.z, l.point.x, l.point.y, l.point.z));
        }
    }
    Ok(PostConfig {
        head,
        process,
        dialect,
        renumber,
        tolerance,
        intended,
        near,
        program_number: a.program_number,
        header,
        verify_tolerance: 2.0 * tolerance,
        work: extra_work(&a.place, part.as_deref())?,
        part,
        max_output_bytes: Some(output_bound(
            a.max_growth,
            sections
                .iter()
                .map(|s| match &s.source {
                    Source::Path(p) => std::fs::metadata(p).map_or(0, |m| m.len()),
                    Source::Bytes(b) => b.len() as u64,
                })
                .sum(),
        )?),
    })
}

/// The bound on a posted program's size: `growth` times the input's `bytes`, at least
/// 16 MiB.
fn output_bound(growth: f64, bytes: u64) -> Result<u64, CliError> {
    if !(growth.is_finite() && growth >= 1.0) {
        return Err(CliError::usage(format!(
            "error: --max-growth {growth}: give a number of at least 1 (the output may be that many times the input)\n"
        )));
    }
    let bound = (growth * bytes as f64).min(u64::MAX as f64) as u64;
    Ok(bound.max(16 << 20))
}

fn werr(e: std::io::Error) -> CliError {
    CliError::write(&e)
}

#[allow(clippy::too_many_arguments)]
pub fn post(
    a: &PostArgs,
    input: Option<&str>,
    output: Option<&str>,
    max_bytes: Option<usize>,
    json_report: Option<&str>,
) -> Result<(), CliError> {
    let t0 = std::time::Instant::now();
    crate::io::distinct_outputs(
        &[
            ("-o", output),
            ("--json-report", json_report),
            ("--preview", a.preview.as_deref()),
        ],
        &[
            ("input", input),
            ("part mesh (--part)", a.place.part.as_deref()),
            ("machine file (--machine)", Some(a.machine.as_str())),
        ],
    )?;
    if let Some(arm) = crate::robot_cmds::arm_for(&a.machine)? {
        return crate::robot_cmds::post(&arm, a, input, output, max_bytes, json_report);
    }
    if a.config.is_some() || a.spacing.is_some() || a.chunk_points.is_some() {
        return Err(CliError::usage(format!(
            "error: --config, --spacing and --chunk-points are for arms; {} is a table machine\n",
            a.machine
        )));
    }
    let m = load_machine(&a.machine, &a.set)?;
    if let Some(max) = max_bytes {
        if max < MIN_PIECE_BYTES {
            return Err(CliError::usage(format!(
                "error: --max-bytes {max}: too small to hold a program piece; the minimum is {MIN_PIECE_BYTES}\n"
            )));
        }
        if output.is_none_or(|o| o == "-") {
            return Err(CliError::usage(
                "error: --max-bytes needs -o OUT (the pieces are files)\n".to_string(),
            ));
        }
        // The pieces are files beside OUT (OUT.001, …): beside a device they would be
        // files in /dev.
        if let Some(o) = output.filter(|o| crate::io::is_special(Path::new(o))) {
            return Err(CliError::usage(format!(
                "error: --max-bytes with -o {o}: the pieces are files named after OUT ({o}.001, …), and {o} is a device or a pipe\n  = help: give -o a file path\n"
            )));
        }
    }
    let view = view_arg(&a.view)?;
    if a.preview.is_some() && output.is_none_or(|o| o == "-") {
        return Err(CliError::usage(
            "error: --preview needs -o OUT (the picture is drawn from the written program)\n"
                .to_string(),
        ));
    }
    let input = input_file(&a.place, input)?;
    let (tmp, file) = crate::io::TempFile::beside(output)?;
    let mut bw = std::io::BufWriter::with_capacity(1 << 16, file);
    let (report, cfg) = if let Some(path) = per_point_path(&a.place, input.as_ref()) {
        // The per-point post, then its verification of what was written.
        let (frame, mut pts, name) = per_point_input(&a.place, path)?;
        per_point_units(&m, &a.place, &name, &mut pts)?;
        let mut cfg = config(&m, a, &[], &section_flavor(&a.place, &[])?)?;
        let csv_bytes = std::fs::metadata(&path.path).map_or(0, |md| md.len());
        cfg.max_output_bytes = Some(output_bound(a.max_growth, csv_bytes)?);
        let short = Path::new(&name)
            .file_name()
            .map_or(name.clone(), |n| n.to_string_lossy().into_owned());
        cfg.header.push(format!(
            "{short}: per-point tool axis; origin {:.4} {:.4} {:.4}",
            frame.origin.x, frame.origin.y, frame.origin.z
        ));
        let mut report =
            lampost_post::pointwise::post_points(&m, &pts, &frame, &name, &cfg, &mut bw)
                .map_err(post_error)?;
        bw.flush().map_err(werr)?;
        let posted = std::fs::File::open(tmp.path()).map_err(werr)?;
        report.verify = lampost_post::pointwise::verify_points(
            &m,
            &pts,
            &frame,
            cfg.head,
            &cfg.process,
            BufReader::new(posted),
            cfg.verify_tolerance,
            cfg.work.as_ref(),
        )
        .map_err(post_error)?;
        (report, cfg)
    } else {
        let secs = sections(&m, &a.place, input.as_ref())?;
        let flavor = section_flavor(&a.place, &secs)?;
        let cfg = config(&m, a, &secs, &flavor)?;
        refuse_dry(&secs, &cfg.intended, a.place.e_extrusion, &flavor)?;
        let bar = crate::progress::Progress::counting("posting", "moves", a.place.quiet);
        // The post verifies every written feed point in-process (FK of the values as
        // written) and every rapid against the safe height; nothing reaches the user's
        // path unless that passed.
        let r = lampost_post::post(&m, &secs, &cfg, &mut bw, |n| bar.set(n as u64))
            .map_err(post_error)?;
        bw.flush().map_err(werr)?;
        drop(bar);
        (r, cfg)
    };
    drop(bw);
    let v = report.verify;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    let total = std::fs::metadata(tmp.path()).map_err(werr)?.len();
    // Everything to write is staged in temporary files first, and renamed into place
    // together at the end: the program (or all its pieces) and the report.
    let mut staged: Vec<(crate::io::TempFile, PathBuf)> = Vec::new();
    let mut written: Vec<String> = Vec::new();
    let mut whole = Some(tmp);
    let file_out = output.filter(|o| *o != "-");
    match (max_bytes, file_out) {
        (Some(max), Some(out)) if total as usize > max => {
            let path = whole
                .as_ref()
                .map(|t| t.path().to_path_buf())
                .unwrap_or_default();
            let mut f = std::fs::File::open(&path).map_err(werr)?;
            let pieces = lampost_post::split::split(
                &mut f,
                total,
                &report,
                cfg.dialect,
                cfg.program_number,
                max,
            )
            .map_err(post_error)?;
            // The whole program's temporary file goes: the first piece takes its name.
            drop(f);
            drop(whole.take());
            for p in pieces {
                let name = if p.number == 0 {
                    out.to_string()
                } else {
                    numbered(out, p.number)
                };
                let (t, mut f) = crate::io::TempFile::beside(Some(&name))?;
                f.write_all(&p.text).map_err(werr)?;
                f.flush().map_err(werr)?;
                staged.push((t, PathBuf::from(&name)));
                written.push(name);
            }
        }
        (_, Some(out)) => {
            if let Some(t) = whole.take() {
                staged.push((t, PathBuf::from(out)));
            }
            written.push(out.to_string());
        }
        (_, None) => written.push("<stdout>".into()),
    }
    if let Some(path) = json_report {
        let limits: Vec<Obj> = report
            .limits_used
            .iter()
            .map(|(n, lo, hi)| obj! {"axis": n, "min": lo, "max": hi})
            .collect();
        let j = obj! {
            "moves": report.moves, "warnings": report.warnings, "limits_used": limits,
            "indexes": report.indexes, "verify": v, "bytes": total, "files": written,
            "flavor": cfg.intended.flavor,
            "time_s": t0.elapsed().as_secs_f64(),
        };
        let j = json::to_string(&j)?;
        if path == "-" {
            println!("{j}");
        } else {
            let (t, mut f) = crate::io::TempFile::beside(Some(path))?;
            f.write_all(format!("{j}\n").as_bytes()).map_err(werr)?;
            staged.push((t, PathBuf::from(path)));
        }
    }
    // Every file in place as one step (an interrupt waits), with the pieces of an
    // earlier, longer split removed.
    let pieces = written.len();
    crate::io::persist_set(staged, None, || {
        if let Some(out) = file_out {
            remove_stale_pieces(out, pieces);
        }
    })?;
    if let (None, Some(t)) = (file_out, whole) {
        let mut f = std::fs::File::open(t.path()).map_err(werr)?;
        let mut out = std::io::stdout().lock();
        std::io::copy(&mut f, &mut out).map_err(werr)?;
        out.flush().map_err(werr)?;
    }
    if !a.place.quiet {
        eprintln!(
            "posted {} moves, {total} bytes, to {}; verified: max tip error {:.2e} {}, max axis error {:.2e}°; {:.2} s",
            report.moves,
            written.join(", "),
            v.max_position_error,
            units_name(&m),
            v.max_axis_error_deg,
            t0.elapsed().as_secs_f64()
        );
    }
    if let Some(svg) = &a.preview {
        // Drawn from the program as written (read back as verify reads it); the program
        // stays written whatever happens here.
        let head_name = default_head(&m, &a.proc.process, a.head.as_deref())?;
        let h = m.head(&head_name).map_err(crate::kin_cmds::kin_error)?;
        preview_files(&m, h, &written, svg, a.proc.process == "deposit", view).map_err(|e| {
            CliError::failed(format!(
                "{}{}  = note: the program was written ({}); only the preview failed\n",
                e.message,
                if e.message.ends_with('\n') { "" } else { "\n" },
                written.join(", ")
            ))
        })?;
        if !a.place.quiet {
            eprintln!("preview: {svg}");
        }
    }
    Ok(())
}

/// `--view top|iso`.
fn view_arg(v: &str) -> Result<lampost_post::preview::View, CliError> {
    match v {
        "top" => Ok(lampost_post::preview::View::Top),
        "iso" => Ok(lampost_post::preview::View::Iso),
        other => Err(CliError::usage(format!(
            "error: --view {other}: give top or iso\n"
        ))),
    }
}

/// Draw the posted files (one program, FADAL subprograms followed, or DNC pieces in
/// order) into an SVG file.
fn preview_files(
    m: &Machine,
    head: usize,
    posted: &[String],
    out: &str,
    deposit: bool,
    view: lampost_post::preview::View,
) -> Result<(), CliError> {
    let f = crate::posted::open(posted)?;
    let p = lampost_post::preview::replay(m, head, f).map_err(|e| posted_error(posted, e))?;
    let title = format!("{} on {}", posted.join(", "), m.def.name);
    let text = lampost_post::preview::svg(
        m,
        head,
        &p,
        view,
        &title,
        deposit,
        lampost_post::preview::Colouring::Position,
    );
    let mut o = crate::io::Output::create(Some(out))?;
    o.writer().write_all(text.as_bytes()).map_err(werr)?;
    o.commit()
}

/// `verify --preview`: the posted files drawn with each feed coloured by its deviation.
#[allow(clippy::too_many_arguments)]
fn deviation_preview(
    m: &Machine,
    head: usize,
    posted: &[String],
    out: &str,
    deposit: bool,
    view: lampost_post::preview::View,
    errors: &std::collections::HashMap<u32, f64>,
    tolerance: f64,
) -> Result<(), CliError> {
    let f = crate::posted::open(posted)?;
    let p = lampost_post::preview::replay(m, head, f).map_err(|e| posted_error(posted, e))?;
    let title = format!(
        "{} on {}: deviation from the intended path",
        posted.join(", "),
        m.def.name
    );
    let colouring = lampost_post::preview::Colouring::Deviation { errors, tolerance };
    let text = lampost_post::preview::svg(m, head, &p, view, &title, deposit, colouring);
    let mut o = crate::io::Output::create(Some(out))?;
    o.writer().write_all(text.as_bytes()).map_err(werr)?;
    o.commit()
}

/// `lampost preview POSTED… --machine M -o FILE.svg`.
#[allow(clippy::too_many_arguments)]
pub fn preview(
    machine: &str,
    sets: &[String],
    head: Option<&str>,
    process: &str,
    posted: &[String],
    output: &str,
    view: &str,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let view = view_arg(view)?;
    let head_name = default_head(&m, process, head)?;
    let h = m.head(&head_name).map_err(crate::kin_cmds::kin_error)?;
    preview_files(&m, h, posted, output, process == "deposit", view)
}

/// The machine's length unit, as outputs name it.
fn units_name(m: &Machine) -> &'static str {
    match m.units {
        lampost_kinematics::Units::Inch => "in",
        lampost_kinematics::Units::Mm => "mm",
    }
}

/// Pieces of an earlier split of `out` beyond the `count` files this run wrote (`OUT.NNN`
/// numbered on from there) are stale: removed, so a set on disk is always one run's.
fn remove_stale_pieces(out: &str, count: usize) {
    let first = if count > 1 { count + 1 } else { 1 };
    for n in first.. {
        let stale = numbered(out, n);
        if std::fs::remove_file(&stale).is_err() {
            break;
        }
        eprintln!("removed {stale}: a piece of an earlier split");
    }
}

/// The smallest `--max-bytes`: a piece must hold the header and preamble.
const MIN_PIECE_BYTES: usize = 256;

fn numbered(out: &str, n: usize) -> String {
    let p = Path::new(out);
    let stem = p
        .file_stem()
        .map_or("out".into(), |s| s.to_string_lossy().into_owned());
    let ext = p
        .extension()
        .map_or(String::new(), |e| format!(".{}", e.to_string_lossy()));
    p.with_file_name(format!("{stem}.{n:03}{ext}"))
        .to_string_lossy()
        .into_owned()
}

#[allow(clippy::too_many_arguments)]
pub fn verify(
    machine: &str,
    sets: &[String],
    place: &Placement,
    head: Option<&str>,
    proc: &ProcessArgs,
    input: Option<&str>,
    posted: &[String],
    tolerance: Option<f64>,
    json: bool,
    preview: Option<&str>,
    view: &str,
) -> Result<(), CliError> {
    let t0 = std::time::Instant::now();
    let view = view_arg(view)?;
    let m = load_machine(machine, sets)?;
    let process = proc.to_process()?;
    let head_name = default_head(&m, &proc.process, head)?;
    let h = m.head(&head_name).map_err(crate::kin_cmds::kin_error)?;
    let tol = tolerance.unwrap_or(match m.units {
        lampost_kinematics::Units::Inch => 0.001,
        lampost_kinematics::Units::Mm => 0.02,
    });
    // One file, or DNC pieces in order; FADAL subprograms are followed.
    let f = crate::posted::open(posted)?;
    let located = |e| posted_error(posted, e);
    let part = part_mesh(place, &m)?;
    let bar = crate::progress::Progress::working("verifying", place.quiet);
    // Posted line → the largest deviation of a point it wrote, for `--preview`.
    let mut errors: std::collections::HashMap<u32, f64> = std::collections::HashMap::new();
    let mut record = |line: u32, e: f64| {
        if preview.is_some() {
            let v = errors.entry(line).or_insert(0.0);
            *v = v.max(e);
        }
    };
    let input = input_file(place, input)?;
    let checked = if let Some(path) = per_point_path(place, input.as_ref()) {
        let (frame, mut pts, name) = per_point_input(place, path)?;
        per_point_units(&m, place, &name, &mut pts)?;
        lampost_post::pointwise::verify_points_traced(
            &m,
            &pts,
            &frame,
            h,
            &process,
            f,
            tol,
            extra_work(place, None)?.as_ref(),
            &mut record,
        )
    } else {
        let secs = sections(&m, place, input.as_ref())?;
        let opts = intended_options(place, &section_flavor(place, &secs)?, &process);
        let work = extra_work(place, part.as_deref())?;
        lampost_post::verify_traced(
            &m,
            &secs,
            h,
            &process,
            opts,
            f,
            tol,
            work.as_ref(),
            part.as_deref(),
            &mut record,
        )
    };
    if let Some(svg) = preview {
        // Drawn whether or not the check passed: a failed check's picture shows how far
        // it got and how close the path was until then.
        let drawn = deviation_preview(
            &m,
            h,
            posted,
            svg,
            proc.process == "deposit",
            view,
            &errors,
            tol,
        );
        match (&checked, drawn) {
            (_, Ok(())) if !place.quiet => eprintln!("preview: {svg}"),
            (Ok(_), Err(e)) => return Err(e),
            (Err(_), Err(e)) if !place.quiet => {
                eprint!("{}", e.message);
            }
            _ => {}
        }
    }
    let v = checked.map_err(located)?;
    drop(bar);
    let s = if json {
        format!(
            "{}\n",
            json::to_string(
                &obj! {"max_position_error": v.max_position_error, "max_axis_error_deg": v.max_axis_error_deg, "moves": v.moves, "compared": v.compared, "ok": true}
            )?
        )
    } else {
        format!("ok: {} moves, {} feed points compared\nmax_position_error {:.3e}\nmax_axis_error_deg {:.3e}\n", v.moves, v.compared, v.max_position_error, v.max_axis_error_deg)
    };
    let mut o = crate::io::Output::create(None)?;
    o.writer().write_all(s.as_bytes()).map_err(werr)?;
    o.commit()?;
    if !place.quiet {
        eprintln!(
            "verified {} moves ({} feed points) of {}: max tip error {:.2e} {}, max axis error {:.2e}°; {:.2} s",
            v.moves,
            v.compared,
            posted.join(", "),
            v.max_position_error,
            units_name(&m),
            v.max_axis_error_deg,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
