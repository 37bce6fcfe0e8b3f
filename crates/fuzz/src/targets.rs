//! The targets: each makes one input from its generator (a mutated seed or a generated
//! structure), runs it through the library, and checks what came back. `Err` is a
//! finding ("invalid": a broken promise such as a non-finite number in an output or a
//! posted program that fails `verify`); a refusal of bad input is `Ok`.

use std::io::Cursor;
use std::path::Path;

use lampost_align::{calib, fit, level, plane_angle, probe, register, P3};
use lampost_gcode::{
    parse_line, Dialect, EWord, EmitOptions, Emitter, Event, Flavor, LineReader, Options, Order,
    ProgramReader, Stream, Units,
};
use lampost_mesh as mesh;

/// Every resolved flavour (`auto` is resolved before a program is read).
const FLAVORS: [Flavor; 8] = [
    Flavor::Fadal,
    Flavor::LinuxCnc,
    Flavor::Fanuc,
    Flavor::Haas,
    Flavor::Mach3,
    Flavor::Marlin,
    Flavor::RepRap,
    Flavor::MakerBot,
];
use lampost_kinematics::{Joints, Machine, MachineDef, Vector3};
use lampost_post::safety::WorkBounds;
use lampost_post::{
    Frame, IntendedOptions, LayerSchedule, Orient, PostConfig, PostDialect, Process, Section,
    Source,
};

use crate::gen::{chunks, mutate, read_dir, shows_nonfinite, Rng};

/// Every target, in round-robin order.
pub const TARGETS: &[&str] = &[
    "gcode", "fmt", "post", "toml", "points", "stl", "probe", "numeric", "inspect", "robot", "plan",
];

/// G-code tokens spliced into programs.
const GCODE_TOKENS: &[&str] = &[
    "G0",
    "G1",
    "G2",
    "G3",
    "G4",
    "G10 L2 P1",
    "G10 L20",
    "G17",
    "G18",
    "G19",
    "G20",
    "G21",
    "G28",
    "G30",
    "G31",
    "G38.2",
    "G40",
    "G41 D1",
    "G43 H1",
    "G49",
    "G52",
    "G53",
    "G54",
    "G59.3",
    "G73",
    "G80",
    "G81",
    "G83",
    "G84",
    "G85",
    "G89",
    "G90",
    "G90.1",
    "G91",
    "G91.1",
    "G92",
    "G92.1",
    "G93",
    "G94",
    "G98",
    "G99",
    "M0",
    "M01",
    "M1",
    "M2",
    "M3",
    "M6",
    "T2 M6",
    "M60",
    "M600",
    "M30",
    "M98 P100",
    "M99",
    "O100",
    "L2",
    "L9101",
    "R1+1.",
    "R-5",
    "P0",
    "P2",
    "Q-1",
    "Q.0000001",
    "E0",
    "E49",
    "E1.5",
    "H1",
    "T1",
    "F0",
    "F-1",
    "X",
    "Y-",
    "(",
    ")",
    ";",
    "#V1=2",
    "X+R6.",
    "[",
    "#<a>",
    "o100 sub",
    "WHILE [#1 LT 3] DO1",
    "END1",
    "DO2",
    "GOTO 10",
    "IF [#1 EQ #0] GOTO 5",
    "IF [1 GT 0] THEN #2 = 1",
    "G65 P100 A1 X#24",
    "#1 = #1 + 1",
    "#[#1] = BCD[#2]",
    "N10",
    "%",
    "/",
    "\n",
    "\r\n",
    " ",
    "\t",
    "\u{ff}",
    "\0",
    "I0",
    "J0",
    "K0",
    "A360",
    "B-90",
    "C1e3",
    "Z-0",
    "X1e-300",
    "R10000000000",
    "Z9999999999.99",
    "P300",
    "N",
    "N99999999999",
    "S",
    "S1e308",
    "M71",
    "G65536",
];

const TOML_TOKENS: &[&str] = &[
    "=",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    ",",
    "\"",
    "'",
    "\n",
    "#",
    " = 1e308",
    " = nan",
    " = inf",
    " = -inf",
    " = \"\"",
    " = []",
    "x = 1",
    "scale = 1e308",
    "limits = [1, -1]",
    "axis = [0, 0, 0]",
    "[[head]]",
    "[[rotary]]",
    "[[section]]",
    "program = \"a.nc\"",
    "index = { A = 1e300 }",
    "\u{e9}",
    "\u{1F600}",
    "\0",
    "\"\"\"",
    "true",
    "1979-05-27",
];

const POINT_TOKENS: &[&str] = &[
    " ",
    "\t",
    ",",
    ";",
    "#",
    "\n",
    "\r\n",
    "x y z",
    "x y z i j k feed laser",
    "1 2 3",
    "0 0 1",
    "1e308 1e308 1e308",
    "nan",
    "inf",
    "\u{e9}",
    "\u{ff}",
    "\0",
    "3\n",
];

const LOG_TOKENS: &[&str] = &[
    "X",
    "Y",
    "Z",
    "X1.5",
    "Y-2",
    "Z0.1",
    ":",
    "P1:",
    "TOUCH:",
    " ",
    "\n",
    "\r",
    "\t",
    "X1e308 Y1e308 Z1e308",
    "Xnan",
    "Yinf",
    "\u{e9}",
    "\0",
];

const MESH_TOKENS: &[&str] = &[
    "OFF",
    "OFF 3 1 0",
    "3 0 1 2",
    "4 0 1 2 3",
    "v 0 0 0",
    "v nan 1 2",
    "f 1 2 3",
    "f -1 -2 -3",
    "f 1/1/1 2//2 3",
    "f 0 1 2",
    "99999999999",
    "-1",
    "#",
    "\n",
    " ",
];

const STL_TOKENS: &[&str] = &[
    "solid",
    "endsolid",
    "facet normal 0 0 1",
    "outer loop",
    "vertex 0 0 0",
    "vertex 1e308 0 0",
    "vertex nan 0 0",
    "endloop",
    "endfacet",
    "\n",
    " ",
];

/// What every input of a run shares: the machines and the seeds, read once.
#[derive(Debug)]
pub struct Ctx {
    machines: Vec<Machine>,
    machine_texts: Vec<Vec<u8>>,
    arm_texts: Vec<Vec<u8>>,
    programs: Vec<Vec<u8>>,
    post_programs: Vec<Vec<u8>>,
    csv: Vec<Vec<u8>>,
    points: Vec<Vec<u8>>,
    stl: Vec<Vec<u8>>,
    /// 3MF packages (ZIP, DEFLATE parts, model XML).
    threemf: Vec<Vec<u8>>,
    jobs: Vec<Vec<u8>>,
    /// `lampost inspect`'s inputs: a measuring plan and a sensor log for it.
    inspect: InspectSeeds,
    /// Where each input is written before it runs (`--trace`).
    trace: Option<std::path::PathBuf>,
}

impl Ctx {
    /// Seeds from `root`'s fixtures and, when it is there, the shared corpus beside it.
    pub fn new(root: &Path, trace: Option<std::path::PathBuf>) -> Result<Self, String> {
        let fx = root.join("fixtures");
        let corpus = root.join("../shared/corpus");
        let mut machine_texts: Vec<Vec<u8>> = lampost_kinematics::BUILTINS
            .iter()
            .map(|(_, t)| t.as_bytes().to_vec())
            .collect();
        // Arm files (kind = "arm", crates/robot) are fuzzed apart: `arm_texts`.
        let (arm_texts, tables): (Vec<Vec<u8>>, Vec<Vec<u8>>) =
            read_dir(&fx.join("machines"), &["toml"])
                .into_iter()
                .partition(|t| lampost_robot::is_arm_text(&String::from_utf8_lossy(t)));
        machine_texts.extend(tables);
        let mut machines = Vec::new();
        for t in &machine_texts {
            let text = String::from_utf8_lossy(t);
            let def = MachineDef::from_toml(&text, "seed.toml").map_err(|e| e.to_string())?;
            machines.push(Machine::new(def, &[]).map_err(|e| e.to_string())?);
        }
        let mut gfiles = Vec::new();
        for d in [
            fx.join("programs"),
            fx.join("linuxcnc-nc_files"),
            fx.join("post"),
            fx.join("post/bearing-seat"),
            corpus.join("linuxcnc"),
            corpus.join("fadal-probekit"),
            corpus.join("cam"),
            corpus.join("slicers"),
        ] {
            gfiles.extend(read_dir(
                &d,
                &["nc", "ngc", "gcode", "tap", "txt", "cnc", "fnc"],
            ));
        }
        let programs = chunks(&gfiles, 40);
        let mut pfiles = read_dir(&fx.join("post"), &["nc"]);
        pfiles.extend(read_dir(&fx.join("post/bearing-seat"), &["nc"]));
        let post_programs = chunks(&pfiles, 60);
        Ok(Ctx {
            machines,
            machine_texts,
            arm_texts,
            programs,
            post_programs,
            csv: read_dir(&fx.join("post"), &["csv"]),
            points: read_dir(&fx.join("points"), &[]),
            stl: read_dir(&fx.join("meshes"), &["stl"]),
            threemf: read_dir(&fx.join("meshes/3mf"), &["3mf"]),
            jobs: read_dir(&fx.join("post/bearing-seat"), &["toml"]),
            inspect: InspectSeeds::new()?,
            trace,
        })
    }

    /// Run input `index` of `target`; `input` receives the input's bytes (what a finding
    /// saves) before it runs, and `note` what else was chosen.
    pub fn run(
        &self,
        target: &str,
        r: &mut Rng,
        input: &mut Vec<u8>,
        note: &mut String,
    ) -> Result<(), String> {
        match target {
            "gcode" => self.gcode(r, input, note),
            "fmt" => self.fmt(r, input, note),
            "post" => self.post(r, input, note),
            "toml" => self.toml(r, input, note),
            "points" => self.points(r, input, note),
            "stl" => self.stl(r, input, note),
            "probe" => probe_log(self, r, input, note),
            "numeric" => numeric(self, r, input, note),
            "inspect" => inspect(self, r, input, note),
            "robot" => robot(r, input, note),
            "plan" => plan(r, input, note),
            "selftest" => selftest(self, r, input, note),
            other => Err(format!("no target {other}")),
        }
    }

    /// The input is made: with `--trace`, saved (with what was chosen) before it runs.
    fn made(&self, input: &[u8], note: &str) {
        if let Some(t) = &self.trace {
            let _ = std::fs::write(t, input);
            let _ = std::fs::write(t.with_extension("txt"), note);
        }
    }

    fn program(&self, r: &mut Rng, input: &mut Vec<u8>) {
        input.clear();
        if self.programs.is_empty() || r.one_in(8) {
            input.extend_from_slice(generated_program(r, 25.4).as_bytes());
        } else {
            input.extend_from_slice(r.pick_bytes(&self.programs));
        }
        mutate(r, input, GCODE_TOKENS);
    }

    fn gcode(&self, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
        self.program(r, input);
        let opts = Options {
            units: if r.coin() { Units::Mm } else { Units::Inch },
            e_word: if r.coin() {
                EWord::FixtureOffset
            } else {
                EWord::Extrusion
            },
            block_delete: r.coin(),
            flavor: *r.pick(&FLAVORS),
            post_notes: r.coin(),
            stops: r.coin(),
        };
        let stop = r.coin();
        let mode = r.below(4);
        *note = format!("{opts:?}, stop_on_error {stop}, mode {mode} (0 bytes, 1 file order, 2 execution order, 3 check)");
        self.made(input, note);
        let mut events = 0u64;
        let mut check = |ev: Event| -> Result<(), String> {
            events += 1;
            match ev {
                Event::Move(m) => {
                    let vals = m.start.iter().chain(m.end.iter()).chain([&m.feed]);
                    if vals.chain(m.extrusion.iter()).any(|v| !v.is_finite()) {
                        return Err(format!(
                            "line {}: a move with a non-finite number: {m:?}",
                            m.line
                        ));
                    }
                }
                Event::Diagnostic(d) => {
                    // What `lampost check` prints, for people and as JSON.
                    let text = crate::report::render("fuzz.nc", &d);
                    let j = crate::json::to_string(&crate::report::json("fuzz.nc", &d))
                        .map_err(|e| format!("a diagnostic's JSON: {}", e.message))?;
                    if text.is_empty() || j.is_empty() {
                        return Err("an empty diagnostic".into());
                    }
                }
                Event::Stop(s) if s.line == 0 => {
                    return Err(format!("a stop on no line: {s:?}"));
                }
                Event::Stop(_) => {}
            }
            Ok(())
        };
        match mode {
            0 => {
                let mut fast = Vec::new();
                for ev in Stream::from_bytes(input, opts, stop) {
                    let ev = ev.map_err(|e| e.to_string())?;
                    check(ev.clone())?;
                    fast.push(ev);
                }
                // The fast lane for plain moves and the reference path agree.
                let reference = Stream::from_bytes(input, opts, stop)
                    .reference_only()
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| e.to_string())?;
                if fast != reference {
                    let i = fast
                        .iter()
                        .zip(&reference)
                        .take_while(|(a, b)| a == b)
                        .count();
                    return Err(format!(
                        "event {i}: the fast lane gave {:?}, the reference path {:?}",
                        fast.get(i),
                        reference.get(i)
                    ));
                }
            }
            1 | 2 => {
                let order = if mode == 1 {
                    Order::File
                } else {
                    Order::Execution
                };
                let src = ProgramReader::new(Cursor::new(input.as_slice()), order);
                for ev in Stream::new(src, opts, stop) {
                    match ev {
                        Ok(ev) => check(ev)?,
                        // The reader's own refusals (a line too long) come as errors.
                        Err(_) => break,
                    }
                }
            }
            _ => {
                for d in lampost_gcode::check(input, opts) {
                    check(Event::Diagnostic(d))?;
                }
            }
        }
        Ok(())
    }

    fn fmt(&self, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
        self.program(r, input);
        let renumber = if r.coin() {
            None
        } else {
            let start = *r.pick(&[0, 1, 10, 9999, u64::MAX / 2, u64::MAX - 1, u64::MAX]);
            let step = *r.pick(&[1, 5, 10, 1000, u64::MAX / 3, u64::MAX]);
            Some((start, step))
        };
        let opts = EmitOptions {
            dialect: *r.pick(&[None, Some(Dialect::Fadal), Some(Dialect::Iso)]),
            renumber,
            suppress_modal: r.coin(),
            units: if r.coin() { Units::Mm } else { Units::Inch },
            units_given: true,
        };
        *note = format!("{opts:?}");
        self.made(input, note);
        let mut em = Emitter::new(Vec::new(), opts);
        let mut reader = LineReader::new(Cursor::new(input.as_slice()));
        loop {
            let line = match reader.next_line() {
                Ok(Some(l)) => l,
                Ok(None) => break,
                Err(_) => return Ok(()),
            };
            if let Ok(b) = parse_line(line.bytes, line.number, line.offset) {
                if em.block(&b).is_err() {
                    // A value the dialect cannot write: refused, nothing to check.
                    return Ok(());
                }
            }
        }
        let Ok(out) = em.finish() else {
            return Ok(());
        };
        // What fmt wrote must read back, every number finite.
        for l in lampost_gcode::Lines::new(&out) {
            match parse_line(l.bytes, l.number, l.offset) {
                Ok(b) => {
                    if let Some(w) = b.words().find(|w| !w.value.is_finite()) {
                        return Err(format!(
                            "output line {}: a non-finite word {}",
                            l.number, w.text
                        ));
                    }
                }
                Err(d) => {
                    return Err(format!(
                        "output line {} does not read back: {} in {:?}",
                        l.number,
                        d.kind,
                        String::from_utf8_lossy(l.bytes)
                    ))
                }
            }
        }
        Ok(())
    }

    fn post(&self, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
        let mi = r.below(self.machines.len());
        let m = &self.machines[mi];
        let k = match m.units {
            lampost_kinematics::Units::Inch => 1.0,
            lampost_kinematics::Units::Mm => 25.4,
        };
        let tolerance = k * *r.pick(&[0.0005, 0.0005, 0.005, 0.00005]);
        let head = r.below(m.heads.len());
        let process = if r.coin() {
            Process::Deposit {
                power: *r.pick(&[500.0, 1000.0, 0.0, 1e6]),
            }
        } else {
            Process::Machine {
                tool: r.coin().then(|| r.below(100) as u32),
                length_offset: r.coin().then(|| r.below(100) as u32),
                work_offset: r
                    .coin()
                    .then(|| (*r.pick(&["E1", "G54", "G59", "E48"])).to_string()),
                spindle: *r.pick(&[1000.0, 3000.0, 0.0]),
                coolant: r.coin(),
            }
        };
        let dialect = *r.pick(&[PostDialect::Fadal, PostDialect::Iso, PostDialect::Nrc]);
        let renumber = r
            .one_in(3)
            .then(|| (*r.pick(&[0, 1, 10, 99_999]), *r.pick(&[1, 5, 10, 1000])));
        let work = r.one_in(4).then(|| {
            let mut w = WorkBounds::empty();
            let lo = Vector3::new(0.0, 0.0, -0.5 * k);
            let hi = Vector3::new(
                r.range(0.1, 2.0) * k,
                r.range(0.1, 2.0) * k,
                r.range(0.0, 0.6) * k,
            );
            w.add_points([lo, hi]);
            w
        });
        let cfg = PostConfig {
            head,
            process,
            dialect,
            renumber,
            tolerance,
            intended: IntendedOptions {
                convert_units: r.coin(),
                e_extrusion: r.one_in(4),
                flavor: *r.pick(&FLAVORS),
                units: *r.pick(&[None, Some(Units::Mm), Some(Units::Inch)]),
            },
            near: [0.0, 0.0],
            program_number: *r.pick(&[1000, 1, 9999, 99_999_999]),
            header: vec!["fuzz".into()],
            verify_tolerance: 2.0 * tolerance,
            work,
            part: None,
            max_output_bytes: Some(4 << 20),
        };
        let verify_tol = cfg.verify_tolerance.max(
            k * if m.units == lampost_kinematics::Units::Inch {
                0.001
            } else {
                0.02 / 25.4
            },
        );
        if r.one_in(4) {
            return self.post_points(r, m, &cfg, verify_tol, input, note, mi);
        }
        // One to three sections (a job), each with its own program, placement and
        // orientation; the first section's program is the saved input.
        let nsec = if r.one_in(3) { 2 + r.below(2) } else { 1 };
        let layers = r.one_in(5).then(|| LayerSchedule {
            axis: Vector3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-0.2, 0.2)),
            point: Vector3::new(r.range(-1.0, 1.0), 0.0, 0.0) * k,
            deg_per_layer: r.mostly(-5.0, 5.0),
        });
        let mut sections = Vec::new();
        for s in 0..nsec {
            let mut text = Vec::new();
            if self.post_programs.is_empty() || r.coin() {
                text.extend_from_slice(generated_program(r, k).as_bytes());
                if r.one_in(4) {
                    mutate(r, &mut text, GCODE_TOKENS);
                }
            } else {
                text.extend_from_slice(r.pick_bytes(&self.post_programs));
                mutate(r, &mut text, GCODE_TOKENS);
            }
            if s == 0 {
                input.clear();
                input.extend_from_slice(&text);
            }
            let origin =
                Vector3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(0.0, 1.0)) * k;
            let frame = if r.coin() {
                Frame::translation(origin)
            } else {
                let x = Vector3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0));
                let z = Vector3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0));
                match Frame::from_axes(origin, x, z) {
                    Ok(f) => f,
                    Err(_) => Frame::translation(origin),
                }
            };
            let orient = if layers.is_none() && r.coin() {
                let mut ix = [0.0; 2];
                for (i, rot) in m.rotary.iter().enumerate() {
                    let (lo, hi) = rot.limits.unwrap_or((-180.0, 180.0));
                    ix[i] = if r.coin() {
                        (r.range(lo, hi) / 15.0).round() * 15.0
                    } else {
                        r.range(lo, hi)
                    };
                }
                Orient::Index(ix)
            } else {
                Orient::ToolAxis
            };
            sections.push(Section {
                name: format!("section{}.nc", s + 1),
                source: Source::Bytes(text),
                frame,
                orient,
                layers,
            });
        }
        let split = r.one_in(3).then(|| 256 + r.below(8192));
        // The programs of the later sections (the first is the saved input), so a
        // finding can be run outside the fuzzer.
        let later: String = sections
            .iter()
            .skip(1)
            .map(|s| match &s.source {
                Source::Bytes(b) => format!("\n--- {} ---\n{}", s.name, String::from_utf8_lossy(b)),
                _ => String::new(),
            })
            .collect();
        *note = format!(
            "machine {}, head {head}, {:?}, {dialect:?}, renumber {renumber:?}, tolerance {tolerance}, work {}, intended {:?}, split {split:?}, sections {:?}",
            m.name,
            cfg.process,
            cfg.work.is_some(),
            cfg.intended,
            sections
                .iter()
                .map(|s| (s.name.clone(), s.frame, s.orient, s.layers))
                .collect::<Vec<_>>()
        ) + &later;
        self.made(input, note);
        let mut out = Vec::new();
        let Ok(report) = lampost_post::post(m, &sections, &cfg, &mut out, |_| {}) else {
            return Ok(());
        };
        check_posted(&out)?;
        let verify = |text: &[u8]| {
            lampost_post::verify(
                m,
                &sections,
                head,
                &cfg.process,
                cfg.intended,
                ProgramReader::new(Cursor::new(text), Order::Execution),
                verify_tol,
                cfg.work.as_ref(),
                None,
            )
        };
        verify(&out).map_err(|e| {
            format!(
                "the posted program fails verify: {e}\n--- posted ---\n{}",
                shown(&out)
            )
        })?;
        if let Some(max) = split.filter(|&s| s < out.len()) {
            let pieces = lampost_post::split::split(
                &mut Cursor::new(out.as_slice()),
                out.len() as u64,
                &report,
                dialect,
                cfg.program_number,
                max,
            );
            if let Ok(pieces) = pieces {
                let mut joined = Vec::new();
                for p in &pieces {
                    // (FADAL: one file, number 0, whose subprograms are the pieces;
                    // the split checks each of those itself.)
                    if p.number > 0 && p.text.len() > max {
                        return Err(format!(
                            "split --max-bytes {max}: piece {} of {} holds {} bytes\n--- piece ---\n{}",
                            p.number,
                            pieces.len(),
                            p.text.len(),
                            shown(&p.text)
                        ));
                    }
                    check_posted(&p.text)?;
                    joined.extend_from_slice(&p.text);
                }
                verify(&joined).map_err(|e| {
                    format!(
                        "the pieces of split --max-bytes {max} fail verify: {e}\n--- pieces ---\n{}",
                        shown(&joined)
                    )
                })?;
            }
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn post_points(
        &self,
        r: &mut Rng,
        m: &Machine,
        cfg: &PostConfig,
        verify_tol: f64,
        input: &mut Vec<u8>,
        note: &mut String,
        mi: usize,
    ) -> Result<(), String> {
        input.clear();
        if self.csv.is_empty() || r.coin() {
            let k = if m.units == lampost_kinematics::Units::Inch {
                1.0
            } else {
                25.4
            };
            input.extend_from_slice(generated_csv(r, k).as_bytes());
            if r.one_in(4) {
                mutate(r, input, POINT_TOKENS);
            }
        } else {
            input.extend_from_slice(r.pick_bytes(&self.csv));
            mutate(r, input, POINT_TOKENS);
        }
        let origin = Vector3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(0.0, 1.0));
        let frame = Frame::translation(origin);
        *note = format!(
            "per-point on machine {mi} ({}), head {}, {:?}, {:?}, tolerance {}, work {}, origin {origin:?}",
            m.name,
            cfg.head,
            cfg.process,
            cfg.dialect,
            cfg.tolerance,
            cfg.work.is_some()
        );
        self.made(input, note);
        let text = String::from_utf8_lossy(input);
        let Ok(pts) = lampost_post::pointwise::read_points(&text, "fuzz.csv") else {
            return Ok(());
        };
        if let Some(p) = pts.iter().find(|p| {
            !(p.tip.iter().chain(p.axis.iter()).all(|v| v.is_finite()) && p.feed.is_finite())
        }) {
            return Err(format!("read_points: a non-finite point {p:?}"));
        }
        let mut out = Vec::new();
        if lampost_post::pointwise::post_points(m, &pts, &frame, "fuzz.csv", cfg, &mut out).is_err()
        {
            return Ok(());
        }
        check_posted(&out)?;
        lampost_post::pointwise::verify_points(
            m,
            &pts,
            &frame,
            cfg.head,
            &cfg.process,
            ProgramReader::new(Cursor::new(out.as_slice()), Order::Execution),
            verify_tol,
            cfg.work.as_ref(),
        )
        .map_err(|e| {
            format!(
                "the per-point program fails verify_points: {e}\n--- posted ---\n{}",
                shown(&out)
            )
        })?;
        Ok(())
    }

    /// An arm file (crates/robot): refused with a location, or an arm whose FK and IK
    /// answer with finite numbers and whose IK reaches what FK gives.
    fn arm(&self, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
        *note = "arm file".into();
        input.extend_from_slice(r.pick_bytes(&self.arm_texts));
        mutate(r, input, TOML_TOKENS);
        self.made(input, note);
        let text = String::from_utf8_lossy(input);
        let def = match lampost_robot::ArmDef::from_toml(&text, "fuzz.toml") {
            Ok(d) => d,
            Err(lampost_robot::RobotError::MachineFile { .. }) => return Ok(()),
            Err(e) => return Err(format!("an arm file refused without a place: {e}")),
        };
        let again = def.to_toml();
        lampost_robot::ArmDef::from_toml(&again, "again.toml")
            .map_err(|e| format!("an arm file read, written and read again fails: {e}"))?;
        let arm = lampost_robot::Arm::new(def);
        for _ in 0..4 {
            let q: lampost_robot::Q =
                std::array::from_fn(|j| r.range(arm.links[j].lo, arm.links[j].hi));
            let f = arm.flange(&q);
            if !f.t.iter().chain(f.r.iter()).all(|v| v.is_finite()) {
                return Err(format!("FK of {q:?}: {f:?}"));
            }
            let back = if arm.closed_form {
                arm.inverse_closed(&f, arm.config, q[3]).ok()
            } else {
                arm.inverse_dls(&f, &q)
            };
            if let Some(s) = back {
                let g = arm.flange(&s);
                let err = (g.t - f.t).norm() / arm.scale.max(1.0) + (g.r - f.r).abs().max();
                if err.is_nan() || err >= 1e-6 {
                    return Err(format!("IK of FK({q:?}) = {s:?} misses by {err:e}"));
                }
            }
        }
        Ok(())
    }

    fn toml(&self, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
        input.clear();
        if !self.arm_texts.is_empty() && r.below(4) == 0 {
            return self.arm(r, input, note);
        }
        match r.below(3) {
            0 => {
                *note = "machine file".into();
                input.extend_from_slice(r.pick_bytes(&self.machine_texts));
                mutate(r, input, TOML_TOKENS);
                self.made(input, note);
                let text = String::from_utf8_lossy(input);
                let Ok(def) = MachineDef::from_toml(&text, "fuzz.toml") else {
                    return Ok(());
                };
                // What the file says must survive writing and reading again.
                let again = def.to_toml();
                MachineDef::from_toml(&again, "again.toml").map_err(|e| {
                    format!("a machine file read, written and read again fails: {e}")
                })?;
                let Ok(m) = Machine::new(def, &[]) else {
                    return Ok(());
                };
                // A machine that validates answers FK and IK with finite numbers.
                for _ in 0..4 {
                    let mut j = Joints {
                        linear: [
                            r.range(-10.0, 10.0),
                            r.range(-10.0, 10.0),
                            r.range(-10.0, 10.0),
                        ],
                        rotary: [0.0; 2],
                    };
                    for (i, rot) in m.rotary.iter().enumerate() {
                        let (lo, hi) = rot.limits.unwrap_or((-180.0, 180.0));
                        j.rotary[i] = r.range(lo, hi);
                    }
                    for h in 0..m.heads.len() {
                        let p = m.forward(&j, h);
                        if !p.tip.iter().chain(p.axis.iter()).all(|v| v.is_finite()) {
                            return Err(format!("FK of {j:?} head {h}: {p:?}"));
                        }
                        if let Ok(sols) = m.inverse(&p.tip, &p.axis, h, &[0.0, 0.0]) {
                            if shows_nonfinite(&format!("{sols:?}")) {
                                return Err(format!("IK of {p:?}: {sols:?}"));
                            }
                        }
                    }
                }
            }
            1 => {
                *note = "setup file".into();
                let s = lampost_align::Setup {
                    origin: [r.extreme(), r.mostly(-10.0, 10.0), r.mostly(-10.0, 10.0)],
                    x_axis: [
                        r.mostly(-1.0, 1.0),
                        r.mostly(-1.0, 1.0),
                        r.mostly(-1.0, 1.0),
                    ],
                    z_axis: [
                        r.mostly(-1.0, 1.0),
                        r.mostly(-1.0, 1.0),
                        r.mostly(-1.0, 1.0),
                    ],
                    note: "fuzz".into(),
                };
                input.extend_from_slice(s.to_toml().as_bytes());
                mutate(r, input, TOML_TOKENS);
                self.made(input, note);
                let text = String::from_utf8_lossy(input);
                if let Ok(f) = lampost_post::read_setup(&text, "fuzz.toml") {
                    if shows_nonfinite(&format!("{f:?}")) {
                        return Err(format!("read_setup gave {f:?}"));
                    }
                }
            }
            _ => {
                *note = "job file".into();
                if self.jobs.is_empty() {
                    input.extend_from_slice(b"[[section]]\nprogram = \"a.nc\"\n");
                } else {
                    input.extend_from_slice(r.pick_bytes(&self.jobs));
                }
                mutate(r, input, TOML_TOKENS);
                self.made(input, note);
                let text = String::from_utf8_lossy(input);
                if let Ok(job) = lampost_post::read_job(&text) {
                    for s in &job.section {
                        // What the CLI makes of each section.
                        let f = Frame::from_axes(
                            Vector3::from(s.origin.unwrap_or([0.0; 3])),
                            Vector3::from(s.x_axis.unwrap_or([1.0, 0.0, 0.0])),
                            Vector3::from(s.z_axis.unwrap_or([0.0, 0.0, 1.0])),
                        );
                        if let Ok(f) = f {
                            if shows_nonfinite(&format!("{f:?}")) {
                                return Err(format!("a job section's frame {f:?}"));
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }

    fn points(&self, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
        input.clear();
        let cli = r.coin();
        *note = if cli {
            "point file (fit, align)".into()
        } else {
            "per-point CSV".into()
        };
        let seeds = if cli { &self.points } else { &self.csv };
        if seeds.is_empty() || r.coin() {
            if cli {
                for _ in 0..r.below(20) {
                    input.extend_from_slice(
                        format!(
                            "{} {} {}\n",
                            r.mostly(-10.0, 10.0),
                            r.mostly(-10.0, 10.0),
                            r.mostly(-10.0, 10.0)
                        )
                        .as_bytes(),
                    );
                }
            } else {
                input.extend_from_slice(generated_csv(r, 25.4).as_bytes());
            }
        } else {
            input.extend_from_slice(r.pick_bytes(seeds));
        }
        mutate(r, input, POINT_TOKENS);
        self.made(input, note);
        let text = String::from_utf8_lossy(input);
        if cli {
            if let Ok(pts) = crate::points::parse_points(&text, "fuzz.txt") {
                if let Some(p) = pts.iter().find(|p| !p.p.iter().all(|v| v.is_finite())) {
                    return Err(format!("parse_points: a non-finite point {p:?}"));
                }
            }
        } else if let Ok(pts) = lampost_post::pointwise::read_points(&text, "fuzz.csv") {
            if let Some(p) = pts.iter().find(|p| {
                !(p.tip.iter().chain(p.axis.iter()).all(|v| v.is_finite()) && p.feed.is_finite())
            }) {
                return Err(format!("read_points: a non-finite point {p:?}"));
            }
        }
        Ok(())
    }

    fn stl(&self, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
        input.clear();
        if !self.threemf.is_empty() && r.one_in(6) {
            // A 3MF package, its bytes mutated: the ZIP directory, the inflater (before
            // the CRC is checked) and the model XML all see damage.
            *note = "3MF package, mutated".into();
            input.extend_from_slice(r.pick_bytes(&self.threemf));
            mutate(r, input, &[]);
            self.made(input, note);
            if let Ok(t) = mesh::read_3mf(input) {
                if !(t.mm_per_unit.is_finite() && t.mm_per_unit > 0.0) {
                    return Err(format!("read_3mf: {} mm per unit", t.mm_per_unit));
                }
                check_mesh("read_3mf", &t.mesh)?;
            }
            return Ok(());
        }
        match r.below(5) {
            3 | 4 => {
                // OBJ and OFF: a generated box or sphere, written in the format, mutated.
                let c = P3::new(
                    r.mostly(-5.0, 5.0),
                    r.mostly(-5.0, 5.0),
                    r.mostly(-5.0, 5.0),
                );
                let m = if r.coin() {
                    mesh::box_mesh(
                        c,
                        c + P3::new(r.mostly(0.0, 5.0), r.mostly(0.0, 5.0), r.mostly(0.0, 5.0)),
                    )
                } else {
                    mesh::uv_sphere(
                        c,
                        r.mostly(0.0, 5.0),
                        2 + r.below(6) as u32,
                        3 + r.below(8) as u32,
                    )
                };
                let text = mesh::write_off(&m);
                if r.coin() {
                    *note = "OFF generated".into();
                    input.extend_from_slice(text.as_bytes());
                } else {
                    *note = "OBJ generated".into();
                    for v in &m.vertices {
                        input.extend_from_slice(format!("v {} {} {}\n", v.x, v.y, v.z).as_bytes());
                    }
                    for t in &m.triangles {
                        input.extend_from_slice(
                            format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1).as_bytes(),
                        );
                    }
                }
                if r.coin() {
                    mutate(r, input, MESH_TOKENS);
                }
            }
            0 if !self.stl.is_empty() => {
                *note = "ASCII STL fixture, mutated".into();
                input.extend_from_slice(r.pick_bytes(&self.stl));
                mutate(r, input, STL_TOKENS);
            }
            1 => {
                *note = "ASCII STL generated".into();
                let lo = P3::new(
                    r.mostly(-5.0, 0.0),
                    r.mostly(-5.0, 0.0),
                    r.mostly(-5.0, 0.0),
                );
                let hi = lo + P3::new(r.mostly(0.0, 5.0), r.mostly(0.0, 5.0), r.mostly(0.0, 5.0));
                let m = mesh::box_mesh(lo, hi);
                input.extend_from_slice(mesh::write_ascii_stl(&m, "fuzz").as_bytes());
                if r.coin() {
                    mutate(r, input, STL_TOKENS);
                }
            }
            _ => {
                *note = "binary STL".into();
                let mut head = [b' '; 80];
                if r.one_in(4) {
                    head[..5].copy_from_slice(b"solid");
                }
                input.extend_from_slice(&head);
                let n = r.below(40);
                let said = if r.one_in(8) {
                    r.next() as u32
                } else {
                    n as u32
                };
                input.extend_from_slice(&said.to_le_bytes());
                let mut corners: Vec<[f32; 3]> = Vec::new();
                for _ in 0..n {
                    input.extend_from_slice(&[0u8; 12]);
                    for _ in 0..3 {
                        let c = if !corners.is_empty() && r.coin() {
                            *r.pick(&corners)
                        } else {
                            [
                                r.mostly(-5.0, 5.0) as f32,
                                r.mostly(-5.0, 5.0) as f32,
                                r.mostly(-5.0, 5.0) as f32,
                            ]
                        };
                        corners.push(c);
                        for v in c {
                            input.extend_from_slice(&v.to_le_bytes());
                        }
                    }
                    input.extend_from_slice(&[0u8; 2]);
                }
                if r.one_in(3) {
                    mutate(r, input, &[]);
                }
            }
        }
        self.made(input, note);
        // Every reader on every input; each mesh read is checked and sliced.
        for (name, m) in [
            ("read_obj", mesh::read_obj(input)),
            ("read_off", mesh::read_off(input)),
        ] {
            if let Ok(m) = m {
                check_mesh(name, &m)?;
            }
        }
        let Ok(m) = mesh::read_stl(input) else {
            return Ok(());
        };
        check_mesh("read_stl", &m)?;
        // The post's part mesh (--part) built from it.
        if let Ok(part) = lampost_post::collide::PartMesh::from_mesh(&m) {
            let (lo, hi) = part.bounds();
            if !lo.iter().chain(hi.iter()).all(|v| v.is_finite()) {
                return Err(format!("PartMesh bounds {lo:?} {hi:?}"));
            }
            let p = (lo + hi) * 0.5;
            let _ = part.contains(&p);
        }
        Ok(())
    }
}

/// A mesh a reader returned: finite vertices, indices in range; its report and slices at
/// a few layer counts, every number in them finite.
fn check_mesh(name: &str, m: &mesh::Mesh) -> Result<(), String> {
    if m.vertices.iter().any(|v| !v.iter().all(|x| x.is_finite())) {
        return Err(format!("{name}: a non-finite vertex"));
    }
    if m.triangles
        .iter()
        .any(|t| t.iter().any(|&i| i as usize >= m.vertices.len()))
    {
        return Err(format!(
            "{name}: a triangle names a vertex that is not there"
        ));
    }
    let _ = mesh::manifold_report(m);
    let Some((lo, hi)) = mesh::props::bounds(m) else {
        return Ok(());
    };
    for layers in [1.0, 3.0, 17.0] {
        let layer = (hi.z - lo.z) / layers;
        let opts = lampost_plan::SliceOptions {
            planes: lampost_plan::Planes::Parallel {
                dir: P3::new(0.0, 0.0, 1.0),
                layer,
                first: None,
            },
            stitch: None,
            threads: 1,
        };
        if let Ok(s) = lampost_plan::slice(m, &opts) {
            for sl in &s.slices {
                for l in &sl.loops {
                    if !(l.area.is_finite() && l.length.is_finite())
                        || l.points.iter().any(|p| !p.iter().all(|x| x.is_finite()))
                        || l.faces.len() != l.points.len()
                        || l.faces.iter().any(|&f| f as usize >= m.triangles.len())
                    {
                        return Err(format!(
                            "{name}: slice layer {}: a bad loop {l:?}",
                            sl.index
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// A posted text for a finding's note (its first 64 KiB).
fn shown(out: &[u8]) -> String {
    String::from_utf8_lossy(&out[..out.len().min(1 << 16)]).into_owned()
}

/// Check the posted text: every line reads, every word is finite.
fn check_posted(out: &[u8]) -> Result<(), String> {
    for l in lampost_gcode::Lines::new(out) {
        match parse_line(l.bytes, l.number, l.offset) {
            Ok(b) => {
                if let Some(w) = b.words().find(|w| !w.value.is_finite()) {
                    return Err(format!(
                        "posted line {}: a non-finite word {}",
                        l.number, w.text
                    ));
                }
            }
            Err(d) => {
                return Err(format!(
                    "posted line {} does not read: {}: {:?}",
                    l.number,
                    d.kind,
                    String::from_utf8_lossy(l.bytes)
                ))
            }
        }
    }
    Ok(())
}

/// A random planar program, `k` units per inch (1 or 25.4), about a 1-in square:
/// rapids, retracts, lines, arcs (IJK and R), helices, full circles, dwell.
fn generated_program(r: &mut Rng, k: f64) -> String {
    let units = if k == 1.0 { "G20" } else { "G21" };
    let f = |v: f64| format!("{:.4}", v * k);
    let mut s = format!("{units} G90 G17\n");
    for run in 0..1 + r.below(3) {
        let (mut x, mut y) = (r.range(0.0, 1.0), r.range(0.0, 1.0));
        let z0 = 0.02 * run as f64;
        s += &format!("G0 X{} Y{} Z{}\n", f(x), f(y), f(z0 + 0.1));
        s += &format!("G1 Z{} F{}\n", f(z0), f(20.0));
        let mut z = z0;
        for _ in 0..1 + r.below(6) {
            match r.below(6) {
                0 | 1 => {
                    x = r.range(0.0, 1.0);
                    y = r.range(0.0, 1.0);
                    s += &format!("G1 X{} Y{}\n", f(x), f(y));
                }
                2 => s += "G4 P0.1\n",
                _ => {
                    let rad = r.range(0.05, 0.4);
                    let a0 = r.range(0.0, std::f64::consts::TAU);
                    let (cx, cy) = (x - rad * a0.cos(), y - rad * a0.sin());
                    let a1 = a0 + r.range(-3.0, 3.0);
                    let full = r.one_in(6);
                    let (ex, ey) = if full {
                        (x, y)
                    } else {
                        (cx + rad * a1.cos(), cy + rad * a1.sin())
                    };
                    let ez = if r.one_in(4) { z + 0.01 } else { z };
                    let g = if r.coin() { "G2" } else { "G3" };
                    if !full && r.one_in(3) {
                        let chord = ((ex - x).powi(2) + (ey - y).powi(2)).sqrt();
                        s += &format!("{g} X{} Y{} R{}\n", f(ex), f(ey), f((chord / 2.0).max(rad)));
                    } else {
                        s += &format!(
                            "{g} X{} Y{} Z{} I{} J{}\n",
                            f(ex),
                            f(ey),
                            f(ez),
                            f(cx - x),
                            f(cy - y)
                        );
                    }
                    x = ex;
                    y = ey;
                    z = ez;
                }
            }
        }
        match r.below(3) {
            0 => s += "G53 G0 Z-1.\n",
            1 => s += "G28 G91 Z0.\nG90\n",
            _ => s += &format!("G0 Z{}\n", f(z + 0.2)),
        }
    }
    s + "M30\n"
}

/// Rows `x y z i j k feed laser` of a per-point path, `k` units per inch.
fn generated_csv(r: &mut Rng, k: f64) -> String {
    let mut s = String::new();
    if r.coin() {
        s += "x y z i j k feed laser\n";
    }
    let tilt = r.range(0.0, 0.6);
    for i in 0..2 + r.below(30) {
        let a = i as f64 * r.range(0.01, 0.3);
        let (sa, ca) = a.sin_cos();
        let (x, y) = (ca * k, sa * k);
        let n = (tilt.sin() * ca, tilt.sin() * sa, tilt.cos());
        let feed = if r.one_in(3) {
            String::new()
        } else {
            format!(" {}", *r.pick(&["600", "20", "0.5", "1e9"]))
        };
        let laser = if feed.is_empty() {
            ""
        } else {
            *r.pick(&["", " 0", " 1"])
        };
        s += &format!(
            "{x:.6} {y:.6} 0 {:.6} {:.6} {:.6}{feed}{laser}\n",
            n.0, n.1, n.2
        );
    }
    s
}

/// A per-point path for `puma-lens`: points near the part frame's origin (where the
/// built-in holder brings them under the beam), the approach tilted from +z by up to
/// `tilt`, laser runs cut by travel.
fn generated_arm_path(r: &mut Rng) -> String {
    let mut s = String::new();
    if r.coin() {
        s += "x y z i j k feed laser\n";
    }
    let tilt = if r.coin() { 0.0 } else { r.range(0.0, 0.4) };
    let (x0, y0) = (r.range(-250.0, 250.0), r.range(-120.0, 120.0));
    let radius = r.range(30.0, 150.0);
    let step = r.range(0.2, 8.0);
    let zigzag = r.one_in(3);
    let z0 = r.range(0.0, 150.0);
    for i in 0..2 + r.below(40) {
        let (x, y, n) = if zigzag {
            // Raster-like runs along x, the axis along +z.
            let row = (i / 4) as f64;
            let along = (i % 4) as f64 * step * if row % 2.0 == 0.0 { 1.0 } else { -1.0 };
            (x0 + along, y0 + row * step, (0.0, 0.0, 1.0))
        } else {
            let a = i as f64 * step / radius;
            let (sa, ca) = a.sin_cos();
            (
                x0 + radius * (ca - 1.0),
                y0 + radius * sa,
                (tilt.sin() * ca, tilt.sin() * sa, tilt.cos()),
            )
        };
        let z = z0 + r.range(0.0, 2.0);
        // The first row gives the feed; later rows may leave it out (it repeats).
        let feed = if i == 0 {
            *r.pick(&["600", "300", "120", "600", "1e9"])
        } else {
            *r.pick(&["600", "600", "300", "120", "", "", "", "1e9"])
        };
        let laser = if feed.is_empty() {
            ""
        } else {
            *r.pick(&[" 1", " 1", " 0", ""])
        };
        let sep = if feed.is_empty() { "" } else { " " };
        s += &format!(
            "{x:.6} {y:.6} {z:.6} {:.9} {:.9} {:.9}{sep}{feed}{laser}\n",
            n.0, n.1, n.2
        );
    }
    s
}

/// The most locations a `robot` input is planned for: beyond it the input is skipped
/// (a legitimate long path takes seconds, which is not a finding).
const ROBOT_MAX_SAMPLES: usize = 20_000;

/// `lampost post --machine puma-lens` through the libraries: a per-point path
/// (generated within reach, or the fixtures' CSV) mutated, read, resampled at the arm's
/// spacing, planned in a random configuration, cut into chunks of a random size, each
/// written and verified as it is written (`post_chunks`), then the texts verified again
/// as `lampost verify` reads them, with the chunks listed as the manifest lists them.
/// Findings besides a panic or hang: a non-finite number or `NaN`/`inf` in a location
/// file, a posted chunk that verification refuses, a refusal of the planner or the
/// verifier that names no input line where the input was at fault.
fn robot(r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
    use lampost_robot::{chunk, plan as rplan, Arm, Config};
    input.clear();
    input.extend_from_slice(generated_arm_path(r).as_bytes());
    // Half the inputs as generated (most of them plan and post), half mutated.
    if r.coin() {
        mutate(r, input, POINT_TOKENS);
    }
    let arm = Arm::builtin("puma-lens").ok_or("puma-lens is built in")?;
    let cfg = if r.coin() {
        arm.config
    } else {
        *r.pick(&Config::ALL)
    };
    let chunk_points = *r.pick(&[2, 3, 4, 7, 50, 50, 4000, 4000]);
    let tol = *r.pick(&[arm.tolerance, arm.tolerance, arm.tolerance, 1e-9, 10.0]);
    *note = format!(
        "per-point path for puma-lens, config {}, --chunk-points {chunk_points}, tolerance {tol}",
        cfg.letters()
    );
    let text = String::from_utf8_lossy(input).into_owned();
    let Ok(pts) = lampost_post::pointwise::read_points(&text, "fuzz.csv") else {
        return Ok(());
    };
    let path: Vec<rplan::PathPoint> = pts
        .iter()
        .map(|p| rplan::PathPoint {
            tip: p.tip,
            axis: p.axis,
            feed: p.feed,
            deposit: p.deposit,
            line: p.line,
        })
        .collect();
    // The count resampling would make, worked out first (a long path is skipped).
    let length: f64 = path.windows(2).map(|w| (w[1].tip - w[0].tip).norm()).sum();
    let count = length / arm.spacing;
    if count.is_nan() || count >= ROBOT_MAX_SAMPLES as f64 {
        return Ok(());
    }
    let samples = match rplan::resample(&path, arm.spacing) {
        Ok(s) => s,
        Err(e) => return named_line(&e, "resample"),
    };
    let located = match rplan::plan(&arm, &samples, cfg) {
        Ok(l) => l,
        Err(e) => return named_line(&e, "plan"),
    };
    let Ok(ranges) = chunk::chunk_ranges(&samples, chunk_points) else {
        return Ok(());
    };
    let texts = std::sync::Mutex::new(Vec::new());
    let posted = chunk::post_chunks(
        &arm,
        cfg,
        &samples,
        &located,
        &ranges,
        tol,
        1 + r.below(2),
        |c, t| {
            texts.lock().map_err(|_| "poisoned".to_string())?.push((
                c.name.clone(),
                c.first,
                c.count,
                t.to_vec(),
            ));
            Ok::<(), String>(())
        },
    );
    let (infos, _) = match posted {
        Ok(p) => p,
        // A plan that does not verify: the post refused its own output, a finding only
        // where the tolerance is the arm's own (1e-9 may refuse rounding honestly).
        Err(chunk::PostError::Verify(_)) if tol < arm.tolerance => return Ok(()),
        Err(chunk::PostError::Verify(e)) => {
            return Err(format!("post_chunks refused its own plan: {e}"))
        }
        Err(chunk::PostError::Keep(e)) => return Err(e),
    };
    let mut texts = texts.into_inner().map_err(|_| "poisoned".to_string())?;
    texts.sort_by_key(|t| t.1);
    let mut files = Vec::new();
    for (name, first, count, t) in texts {
        let t = String::from_utf8(t).map_err(|_| format!("{name}: not UTF-8"))?;
        if shows_nonfinite(&t) {
            return Err(format!(
                "{name}: a non-finite number in\n{}",
                shown(t.as_bytes())
            ));
        }
        files.push(chunk::ChunkFile {
            name,
            first,
            count,
            text: t,
        });
    }
    if files.len() != infos.len() {
        return Err(format!("{} chunks kept of {}", files.len(), infos.len()));
    }
    chunk::verify(&arm, &samples, cfg, &files, tol)
        .map(|_| ())
        .map_err(|e| format!("verify refused what post_chunks verified: {e}"))
}

/// A refusal of the robot's planning: fine when it names a place in the input (a line,
/// or the arm's definition); a finding otherwise.
fn named_line(e: &lampost_robot::RobotError, stage: &str) -> Result<(), String> {
    let text = e.to_string();
    if text.contains("line") || text.contains("point") || text.contains("joint") {
        Ok(())
    } else {
        Err(format!(
            "{stage}: a refusal that names no place in the input: {text}"
        ))
    }
}

/// `lampost plan path` through the libraries: a generated solid (a box, a sphere or the
/// paper's plate, small) written as ASCII STL and mutated, read, sliced along a random
/// build direction and layer, planned with random options (perimeter spacing, rasters,
/// approach, offset angle), and the path written as `lampost plan path` writes it and
/// read back as `lampost post` reads it. Findings besides a panic or hang: a planned point
/// or axis not finite, an axis not of unit length, a point of the text read back more
/// than the text's rounding away, or a written path that does not read back.
fn plan(r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
    input.clear();
    let solid = r.below(3);
    let m = match solid {
        0 => mesh::box_mesh(
            P3::new(0.0, 0.0, 0.0),
            P3::new(r.range(0.5, 40.0), r.range(0.5, 40.0), r.range(0.5, 20.0)),
        ),
        1 => mesh::uv_sphere(
            P3::zeros(),
            r.range(1.0, 20.0),
            6 + r.below(20) as u32,
            8 + r.below(30) as u32,
        ),
        _ => lampost_plan::demo::twisted_plate(
            r.range(0.01, 0.1),
            3.0,
            8 + r.below(30),
            2 + r.below(6),
        )
        .ok_or("the plate")?,
    };
    input.extend_from_slice(mesh::write_ascii_stl(&m, "fuzz").as_bytes());
    mutate(
        r,
        input,
        &[
            "facet normal 0 0 1",
            "vertex 0 0 0",
            "endloop",
            "endfacet",
            "1e308",
            "nan",
        ],
    );
    let dir = *r.pick(&[P3::z(), P3::x(), P3::new(0.0, 0.3, 1.0)]);
    let layer = *r.pick(&[0.5, 1.0, 2.0, 5.0, 1e-3]);
    let opts = lampost_plan::PlanOptions {
        perimeter: lampost_plan::PerimeterOptions {
            spacing: *r.pick(&[0.5, 2.0, 50.0]),
            max_turn_deg: *r.pick(&[0.5, 2.0, 90.0]),
        },
        raster: r.coin().then(|| lampost_plan::RasterOptions {
            hatch: *r.pick(&[0.5, 1.5, 30.0]),
            inset: *r.pick(&[0.0, 0.5, 100.0]),
            angle_deg: r.range(-180.0, 180.0),
            turn_deg: *r.pick(&[0.0, 90.0, 67.5]),
        }),
        approach: if r.coin() {
            lampost_plan::Approach::Build
        } else {
            lampost_plan::Approach::Tangent
        },
        max_offset_deg: *r.pick(&[0.0, 45.0, 90.0]),
        max_tilt_deg: *r.pick(&[0.0, 30.0, 90.0]),
        threads: 1 + r.below(2),
    };
    *note = format!("solid {solid} (box, sphere, plate) as STL, mutated; build {dir:?}, layer {layer}; {opts:?}");
    let Ok(m) = mesh::read(input, mesh::Format::Stl) else {
        return Ok(());
    };
    // A mesh of more than 40 layers at this layer height is skipped (slow, not a finding).
    let Some((lo, hi)) = mesh::props::bounds(&m) else {
        return Ok(());
    };
    let layers = (hi - lo).norm() / layer;
    if layers.is_nan() || layers >= 40.0 {
        return Ok(());
    }
    let sopts = lampost_plan::SliceOptions {
        planes: lampost_plan::Planes::Parallel {
            dir,
            layer,
            first: None,
        },
        stitch: None,
        threads: 1,
    };
    let Ok(s) = lampost_plan::slice(&m, &sopts) else {
        return Ok(());
    };
    let Ok(p) = lampost_plan::plan(&m, &s, &opts) else {
        return Ok(());
    };
    let pts = p.points();
    for (i, q) in pts.iter().enumerate() {
        if !q.p.iter().chain(q.axis.iter()).all(|v| v.is_finite()) {
            return Err(format!("plan: point {i} is not finite: {q:?}"));
        }
        if (q.axis.norm() - 1.0).abs() > 1e-9 {
            return Err(format!(
                "plan: point {i}'s axis is not a unit vector: {q:?}"
            ));
        }
    }
    if pts.is_empty() {
        return Ok(());
    }
    let text = lampost_plan::perimeter::to_text(&pts, 600.0, "fuzz");
    let back = lampost_post::pointwise::read_points(&text, "fuzz.csv")
        .map_err(|e| format!("the written path does not read back: {e}"))?;
    if back.len() != pts.len() {
        return Err(format!(
            "{} points written, {} read back",
            pts.len(),
            back.len()
        ));
    }
    for (i, (a, b)) in pts.iter().zip(&back).enumerate() {
        // Six places for the point; nine for the axis, normalised again on reading.
        let near = (a.p - b.tip)
            .iter()
            .all(|d| d.abs() <= 5.1e-7 * (1.0 + a.p.norm() * 1e-9))
            && (a.axis - b.axis).norm() < 1e-8
            && a.laser == b.deposit;
        if !near {
            return Err(format!("point {i} written {a:?}, read back {b:?}"));
        }
    }
    Ok(())
}

fn probe_log(ctx: &Ctx, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
    input.clear();
    *note = "probe log".into();
    for i in 0..r.below(30) {
        match r.below(4) {
            0 => input.extend_from_slice(b"RS-232 log: ignored line\n"),
            1 => input.extend_from_slice(format!("P{i}: ").as_bytes()),
            _ => {}
        }
        input.extend_from_slice(
            format!(
                "X{:.4} Y{:.4} Z{:.4}\n",
                r.mostly(-5.0, 5.0),
                r.mostly(-5.0, 5.0),
                r.mostly(-5.0, 5.0)
            )
            .as_bytes(),
        );
    }
    mutate(r, input, LOG_TOKENS);
    ctx.made(input, note);
    let text = String::from_utf8_lossy(input);
    let Ok(pts) = probe::read_log(&text) else {
        return Ok(());
    };
    if let Some(p) = pts.iter().find(|p| !p.1.iter().all(|v| v.is_finite())) {
        return Err(format!("read_log: a non-finite point {p:?}"));
    }
    // What `probe fit` does with them.
    let p3: Vec<P3> = pts.iter().map(|p| P3::from(p.1)).collect();
    finite("sphere", &fit::sphere(&p3, None))?;
    finite("plane", &fit::plane(&p3))?;
    Ok(())
}

/// An `Ok` result must show no non-finite number.
fn finite<T: std::fmt::Debug, E>(what: &str, r: &Result<T, E>) -> Result<(), String> {
    if let Ok(v) = r {
        let s = format!("{v:?}");
        if shows_nonfinite(&s) {
            return Err(format!("{what}: a non-finite number in {s}"));
        }
    }
    Ok(())
}

/// Points of a shape of random size and place, maybe with noise, duplicates and
/// extreme coordinates.
fn shape_points(r: &mut Rng) -> (Vec<P3>, String) {
    let n = *r.pick(&[0, 1, 3, 4, 5, 6, 8, 12, 30]);
    let scale = if r.coin() {
        r.extreme().abs()
    } else {
        r.range(0.1, 10.0)
    };
    let centre = P3::new(
        r.mostly(-10.0, 10.0),
        r.mostly(-10.0, 10.0),
        r.mostly(-10.0, 10.0),
    );
    let kind = r.below(5);
    let noise = *r.pick(&[0.0, 1e-9, 1e-4, 0.1]);
    let mut pts = Vec::new();
    for i in 0..n {
        let p = match kind {
            // A sphere cap.
            0 => {
                let (t, ph) = (r.range(0.0, 1.2), r.range(0.0, std::f64::consts::TAU));
                P3::new(t.sin() * ph.cos(), t.sin() * ph.sin(), t.cos())
            }
            // A plane.
            1 => P3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), 0.0),
            // A circle.
            2 => {
                let a = i as f64 * 0.7;
                P3::new(a.cos(), a.sin(), 0.0)
            }
            // A line.
            3 => P3::new(i as f64, 0.0, 0.0),
            // Anything, extreme.
            _ => P3::new(r.extreme(), r.extreme(), r.extreme()),
        };
        let q = centre
            + p * scale
            + P3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)) * noise * scale;
        pts.push(q);
        if r.one_in(6) {
            pts.push(q);
        }
    }
    pts.retain(|p| p.iter().all(|v| v.is_finite()));
    (pts, format!("kind {kind}, scale {scale:e}, noise {noise}"))
}

fn numeric(ctx: &Ctx, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
    let (pts, how) = shape_points(r);
    input.clear();
    for p in &pts {
        input.extend_from_slice(format!("{:e} {:e} {:e}\n", p.x, p.y, p.z).as_bytes());
    }
    let which = r.below(10);
    *note = format!("numeric case {which} on the points ({how})");
    ctx.made(input, note);
    match which {
        0 => finite("sphere4", &fit::sphere4(&pts))?,
        1 => {
            let fixed = r.coin().then(|| r.extreme().abs());
            finite("sphere", &fit::sphere(&pts, fixed))?;
        }
        2 => finite("plane", &fit::plane(&pts))?,
        3 => finite("circle3d", &fit::circle3d(&pts))?,
        4 => {
            let lo = P3::new(
                r.mostly(-5.0, 0.0),
                r.mostly(-5.0, 0.0),
                r.mostly(-5.0, 0.0),
            );
            let hi = lo + P3::new(r.mostly(0.1, 5.0), r.mostly(0.1, 5.0), r.mostly(0.1, 5.0));
            let m = mesh::box_mesh(lo, hi);
            let mut locks = register::Locks::default();
            for k in 0..3 {
                locks.translate[k] = r.one_in(3);
                locks.rotate[k] = r.one_in(3);
            }
            *note += &format!(", box {lo:?}..{hi:?}, {locks:?}");
            finite("register", &register::register(&m, &pts, locks))?;
        }
        5 | 6 => {
            // Calibration on a machine: poses at random rotaries with measured centres.
            let m = &ctx.machines[r.below(ctx.machines.len())];
            let poses: Vec<calib::Pose> = pts
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    let mut rot = [0.0; 2];
                    for (k, rt) in m.rotary.iter().enumerate() {
                        let (lo, hi) = rt.limits.unwrap_or((-180.0, 180.0));
                        rot[k] = if r.coin() {
                            (r.range(lo, hi) / 45.0).round() * 45.0
                        } else {
                            r.mostly(lo, hi)
                        };
                    }
                    calib::Pose {
                        rotary: rot,
                        center: *c,
                        row: i + 1,
                        sigma: r.coin().then(|| [r.extreme().abs(); 3]),
                    }
                })
                .collect();
            *note += &format!(", machine {}, poses {poses:?}", m.name);
            let res = match r.below(4) {
                0 => calib::method_i(m, &poses),
                1 => calib::method_iii(m, &poses),
                2 => calib::method_fit(m, &poses),
                _ => {
                    finite("axes_from_circles", &calib::axes_from_circles(m, &poses))?;
                    return Ok(());
                }
            };
            // A singular design reports its condition as infinite (the CLI prints "n/a",
            // JSON null): a documented sentinel, not a number gone wrong — also under
            // Method I, whose sphere can fix R where Method III's design is singular
            // (found by the long run, seed 2027).
            let shown = res.clone().map(|mut p| {
                if p.condition == f64::INFINITY {
                    p.condition = 0.0;
                }
                p
            });
            finite("calibration", &shown)?;
            if let Ok(res) = res {
                if let Ok(def) = calib::updated_machine(m, &res) {
                    let text = def.to_toml();
                    if shows_nonfinite(&text) {
                        return Err(format!("updated_machine wrote {text}"));
                    }
                }
            }
        }
        7 => {
            let start = P3::new(r.extreme(), r.extreme(), r.extreme());
            let step = r.extreme();
            *note += &format!(", factorial start {start:?} step {step:e}");
            let d = calib::factorial_design(start, step);
            finite("factorial_design", &d)?;
            let rows: Vec<(P3, f64)> = pts.iter().map(|p| (*p, r.extreme())).collect();
            finite("factorial_fit", &calib::factorial_fit(&rows))?;
        }
        8 => {
            let pairs: Vec<(P3, P3)> = pts
                .chunks(2)
                .filter(|c| c.len() == 2)
                .map(|c| (c[0], c[1]))
                .collect();
            finite("laser_offset", &calib::laser_offset(&pairs))?;
        }
        _ => {
            let m = &ctx.machines[r.below(ctx.machines.len())];
            let n = P3::new(r.extreme(), r.extreme(), r.extreme());
            *note += &format!(", machine {}, normal {n:?}", m.name);
            finite("level", &level(m, &n, &[0.0, 0.0]))?;
            let cad = P3::new(r.extreme(), r.extreme(), r.extreme());
            let a = plane_angle(&n, &cad);
            if (n.norm() > 0.0 && cad.norm() > 0.0) && shows_nonfinite(&format!("{a:?}")) {
                return Err(format!("plane_angle({n:?}, {cad:?}) = {a:?}"));
            }
        }
    }
    Ok(())
}

/// Not a reader: the fuzzer's own check (`--target selftest`, never in `all`). About one
/// input in 5,000 each hangs, asks for 1 TiB, overflows an integer or panics, so a run
/// shows the parent catching each (`cargo xtask fuzz --target selftest`).
fn selftest(ctx: &Ctx, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
    input.clear();
    let pick = r.below(5_000);
    input.extend_from_slice(format!("{pick}\n").as_bytes());
    *note = format!("selftest {pick}");
    ctx.made(input, note);
    match pick {
        0 => loop {
            std::hint::black_box(&input);
        },
        1 => {
            let v = vec![1u8; std::hint::black_box(1usize << 40)];
            Err(format!("1 TiB allocated: {}", v.len()))
        }
        2 => {
            let x = std::hint::black_box(u32::MAX);
            Err(format!("no overflow check: {}", x + 1))
        }
        3 => panic!("selftest panic"),
        _ => Ok(()),
    }
}

/// The seeds of the `inspect` target: the NRC cell with its sensor head, a plan of
/// points on a cone (every row a different table position), its text, and a log for it.
#[derive(Debug)]
struct InspectSeeds {
    machine: Machine,
    head: usize,
    rows: Vec<lampost_inspect::PlanRow>,
    plan: Vec<u8>,
    log: Vec<u8>,
}

impl InspectSeeds {
    fn new() -> Result<Self, String> {
        use lampost_inspect::plan::{plan, to_text, Probe};
        let machine = Machine::builtin("nrc-lc", &[]).map_err(|e| e.to_string())?;
        let head = machine.head("sensor").map_err(|e| e.to_string())?;
        let targets: Vec<lampost_inspect::Target> = (0..8)
            .map(|k| {
                let a = f64::from(k) * 0.7;
                lampost_inspect::Target {
                    id: format!("p{k}"),
                    point: [20.0 * a.cos(), 20.0 * a.sin(), 5.0],
                    normal: [0.6 * a.cos(), 0.6 * a.sin(), 0.8],
                }
            })
            .collect();
        let p = plan(&machine, head, Probe::Sensor, &targets, None).map_err(|e| e.to_string())?;
        let plan = to_text(&machine, head, Probe::Sensor, &p.rows).into_bytes();
        let mut log = String::from("# id r (mm)\n");
        for (k, row) in p.rows.iter().enumerate() {
            match k % 4 {
                3 => log += &format!("{} none\n", row.id),
                _ => log += &format!("{} {:.4}\n", row.id, 0.7 * k as f64 - 2.0),
            }
        }
        // The seeds read as they are, or the target would only ever see refusals.
        let text = String::from_utf8_lossy(&plan);
        let (_, rows) = lampost_inspect::plan::read_text(&machine, head, &text)
            .map_err(|e| format!("the inspect seed plan does not read: {e}"))?;
        let readings = lampost_inspect::reduce::read_log(&log)
            .map_err(|e| format!("the inspect seed log does not read: {e}"))?;
        lampost_inspect::reduce::reduce(&machine, head, &rows, &readings)
            .map_err(|e| format!("the inspect seed log does not reduce: {e}"))?;
        Ok(InspectSeeds {
            machine,
            head,
            rows: p.rows,
            plan,
            log: log.into_bytes(),
        })
    }
}

/// Tokens spliced into plans and logs.
const INSPECT_TOKENS: &[&str] = &[
    " ",
    "\n",
    "#",
    "-",
    "0",
    "1e308",
    "-1e308",
    "NaN",
    "inf",
    "none",
    "p0",
    "p1",
    "0.000000000",
    "2.000000000",
    "99999",
    "# lampost inspect plan: machine nrc-lc, head sensor",
    "# lampost inspect plan: machine nrc-lc, head laser",
    ", stylus 0.5",
    ", stylus -1",
];

/// `lampost inspect`'s readers: a measuring plan (`plan::read_text`) and a sensor log
/// (`reduce::read_log`, then `reduce::reduce` against the seed plan). A refusal must be
/// located (a line); a plan read must hold finite values and unit normals (a deviation
/// is measured along the normal) and read back as written; every reduced point and
/// deviation must be finite, and every plan row accounted for.
fn inspect(ctx: &Ctx, r: &mut Rng, input: &mut Vec<u8>, note: &mut String) -> Result<(), String> {
    use lampost_inspect::plan::{read_text, to_text};
    use lampost_inspect::reduce::{read_log, reduce};
    use lampost_inspect::InspectError;
    let s = &ctx.inspect;
    input.clear();
    let log = r.coin();
    *note = if log { "inspect log" } else { "inspect plan" }.into();
    input.extend_from_slice(if log { &s.log } else { &s.plan });
    mutate(r, input, INSPECT_TOKENS);
    ctx.made(input, note);
    let text = String::from_utf8_lossy(input);
    let located = |e: &InspectError| {
        matches!(e, InspectError::At { .. })
            || matches!(e, InspectError::Input(w) if w.starts_with("not a lampost inspection plan"))
    };
    if log {
        let readings = match read_log(&text) {
            Ok(v) => v,
            Err(e) if located(&e) => return Ok(()),
            Err(e) => return Err(format!("read_log refused without a line: {e}")),
        };
        let out = match reduce(&s.machine, s.head, &s.rows, &readings) {
            Ok(v) => v,
            Err(e) if located(&e) => return Ok(()),
            Err(e) => return Err(format!("reduce refused without a line: {e}")),
        };
        if out.len() != s.rows.len() {
            return Err(format!(
                "reduce: {} rows for a plan of {}",
                out.len(),
                s.rows.len()
            ));
        }
        for m in &out {
            let bad = m.measured.is_some_and(|p| !p.iter().all(|v| v.is_finite()))
                || m.deviation.is_some_and(|d| !d.is_finite())
                || m.reading.is_some_and(|d| !d.is_finite());
            if bad {
                return Err(format!("reduce: a non-finite value for {m:?}"));
            }
        }
        return Ok(());
    }
    let (probe, rows) = match read_text(&s.machine, s.head, &text) {
        Ok(v) => v,
        Err(e) if located(&e) => return Ok(()),
        Err(e) => return Err(format!("read_text refused without a line: {e}")),
    };
    for row in &rows {
        let values = row.joints.values();
        let finite = values
            .iter()
            .chain(&row.point)
            .chain(&row.normal)
            .chain(&row.beam)
            .all(|v| v.is_finite())
            && row.tilt_deg.is_finite();
        let n = Vector3::from(row.normal).norm();
        if !finite || (n - 1.0).abs() > 1e-6 {
            return Err(format!(
                "read_text: a row with a non-finite value or a normal of length {n}: {row:?}"
            ));
        }
    }
    let again = to_text(&s.machine, s.head, probe, &rows);
    match read_text(&s.machine, s.head, &again) {
        Ok((p2, rows2)) if p2 == probe && to_text(&s.machine, s.head, p2, &rows2) == again => {
            Ok(())
        }
        Ok(_) => Err("read_text: a plan written again reads as another plan".into()),
        Err(e) => Err(format!("read_text: a plan written again is refused: {e}")),
    }
}
