//! The intended path: each input move placed on the part, with the tool axis it should
//! have. The post turns it into joint moves; `verify` compares a posted program with it.

use std::io::{Read, Seek};
use std::path::PathBuf;

use lampost_gcode::{
    EWord, ErrorKind, Event, Move, MoveKind, Options, Order, Origin, ProgramReader, Severity,
    StopKind, Stream, Units,
};
use lampost_kinematics::{Machine, Units as MUnits};
use nalgebra::Vector3;

use crate::error::PostError;
use crate::frame::Frame;
use crate::post::Process;

/// How a section's rotaries are chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Orient {
    /// Fixed rotary positions (file order); the program frame is not re-oriented.
    Index([f64; 2]),
    /// The program's +Z becomes the tool axis; rotaries from inverse kinematics.
    ToolAxis,
}

/// Each layer (Z level) of a planar program turned about a line, `deg_per_layer` more
/// for each layer: a straight wall built as a curved one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerSchedule {
    /// Direction of the turning line, part frame.
    pub axis: Vector3<f64>,
    /// A point on it, part frame.
    pub point: Vector3<f64>,
    /// Degrees per layer.
    pub deg_per_layer: f64,
}

/// Where a section's program comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// A file.
    Path(PathBuf),
    /// In memory (standard input, tests).
    Bytes(Vec<u8>),
}

/// A program the post reads: out of order, as calls and loops jump (see
/// [`ProgramReader`]).
pub(crate) trait ReadSeek: Read + Seek {}
impl<T: Read + Seek> ReadSeek for T {}

/// A section's program as the post reads it.
type Input = Stream<ProgramReader<Box<dyn ReadSeek>>>;

impl Source {
    fn open(&self) -> Result<Box<dyn ReadSeek>, PostError> {
        Ok(match self {
            Source::Path(p) => Box::new(
                std::fs::File::open(p)
                    .map_err(|e| PostError::Io(format!("cannot open {}: {e}", p.display())))?,
            ),
            Source::Bytes(b) => Box::new(std::io::Cursor::new(b.clone())),
        })
    }
}

/// One planar program placed on the part.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    /// Name for messages.
    pub name: String,
    /// The program.
    pub source: Source,
    /// Program frame on the part.
    pub frame: Frame,
    /// How the rotaries are chosen.
    pub orient: Orient,
    /// Optional layer schedule.
    pub layers: Option<LayerSchedule>,
}

/// The geometry of one intended move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepKind {
    /// Travel.
    Rapid,
    /// A machine-coordinate move that only raises Z (G53, G28/G30: the common CAM
    /// retract): the head goes up to the safe height where it is. Start and end are the
    /// point it leaves from.
    Retract,
    /// Straight feed.
    Feed,
    /// A program stop (`M0`, `M1`, `M60`): the head lifts off the end of the run to the
    /// safe height, with the process off, and the control halts there. Start and end are
    /// where the last move ended.
    Stop(StopKind),
    /// A tool change of the input's (machining): the head lifts off the end of the run to
    /// the safe height, the spindle stops, the new tool is loaded and its length offset
    /// and spindle speed applied. Start and end are where the last move ended.
    ToolChange(ToolChange),
    /// Arc about `center` (part frame) turning about `normal` (part frame, right-hand),
    /// `sweep` radians in all.
    Arc {
        /// Centre (at the start's height along the normal).
        center: Vector3<f64>,
        /// Unit normal of the arc's plane; positive sweep turns right-handed about it.
        normal: Vector3<f64>,
        /// Signed angle from start to end.
        sweep: f64,
    },
}

/// A tool change of the input's (see [`StepKind::ToolChange`], [`Intended::one_tool`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ToolChange {
    /// The tool loaded (T).
    pub tool: u32,
    /// Its tool length offset (the input's `G43 H` at its first cut), where the program
    /// is posted with length offsets.
    pub length_offset: Option<u32>,
    /// The spindle speed its cuts are made at (the input's S at its first cut), as bits
    /// of the `f64` (so the change compares whole).
    pub speed_bits: u64,
}

impl ToolChange {
    /// The spindle speed its cuts are made at.
    pub fn speed(&self) -> f64 {
        f64::from_bits(self.speed_bits)
    }
}

/// One intended move, part frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// Section index (a `u32` keeps the step, with its tool, within 144 bytes: the reading
    /// thread moves every step once more above that size).
    pub section: u32,
    /// Layer within the section (0 without a schedule).
    pub layer: usize,
    /// Input line.
    pub line: u32,
    /// Geometry.
    pub kind: StepKind,
    /// Start, part frame.
    pub start: Vector3<f64>,
    /// End, part frame.
    pub end: Vector3<f64>,
    /// Feed in machine units per minute (0 for rapids).
    pub feed: f64,
    /// A deposition move (feed, and extrusion increasing where E means extrusion).
    pub deposit: bool,
    /// The input's tool (T) the move is made with (0: none), as its own modal state says.
    pub tool: u32,
}

/// The program frame of a section's layer: the section's frame, turned by its layer
/// schedule (if any) for `layer`.
pub fn section_frame(s: &Section, layer: usize) -> Frame {
    match &s.layers {
        Some(l) => s
            .frame
            .rotated(&l.axis, &l.point, l.deg_per_layer * layer as f64),
        None => s.frame,
    }
}

impl Step {
    /// The program frame's +Z in the part frame (the tool axis under
    /// `Orient::ToolAxis`). `sections` are those the step came from.
    pub fn program_z(&self, sections: &[Section]) -> Vector3<f64> {
        section_frame(&sections[self.section as usize], self.layer).dir(&Vector3::z())
    }

    /// The orientation rule of the step's section (`sections` as for
    /// [`Step::program_z`]).
    pub fn orient(&self, sections: &[Section]) -> Orient {
        sections[self.section as usize].orient
    }

    /// The point a fraction `t` along the move.
    pub fn at(&self, t: f64) -> Vector3<f64> {
        match self.kind {
            StepKind::Arc {
                center,
                normal,
                sweep,
            } => {
                // Rodrigues' rotation of the start about the (unit) normal through the
                // centre, plus the helix's rise; inline degree trigonometry.
                let (s, c) = lampost_kinematics::trig::sin_cos_deg((sweep * t).to_degrees());
                let rel = self.start - center;
                let rotated =
                    rel * c + normal.cross(&rel) * s + normal * (normal.dot(&rel) * (1.0 - c));
                let h = (self.end - self.start).dot(&normal);
                center + rotated + normal * (h * t)
            }
            _ => self.start + (self.end - self.start) * t,
        }
    }
}

/// Settings of the intended path.
#[derive(Debug, Clone, Copy)]
pub struct IntendedOptions {
    /// Scale programs in other units to the machine's instead of refusing them.
    pub convert_units: bool,
    /// E words are slicer extrusion (deposit only while E grows).
    pub e_extrusion: bool,
    /// The control the programs were written for (resolved; LinuxCNC parameters,
    /// expressions and O-word control flow are evaluated, as `trace` does).
    pub flavor: lampost_gcode::Flavor,
    /// Units of a program that does not say (no G20/G21 before its numbers); `None`: the
    /// machine's.
    pub units: Option<Units>,
}

/// The intended path over every section, as an iterator.
pub struct Intended<'a> {
    machine: &'a Machine,
    sections: &'a [Section],
    opts: IntendedOptions,
    idx: usize,
    stream: Option<Input>,
    layer: usize,
    layer_z: Option<f64>,
    moves_in_section: usize,
    /// The tool (not T0) the input's moves are made with so far (see [`Intended::one_tool`]).
    tool: Option<u32>,
    /// Whether a tool change is posted (machining) or refused (deposition); see
    /// [`Intended::one_tool`].
    tools: Tools,
    /// The move a tool change was found at, read again after the change's step.
    pending: Option<Move>,
    /// The spindle a machining program is posted with (see [`Intended::holding_spindle`]),
    /// and the section in which the input's speed and coolant were last warned of.
    posted_spindle: Option<PostedSpindle>,
    warned_spindle: [Option<usize>; 4],
    /// The power a deposition program is posted at (`--power`), and the line of the
    /// section's first deposit made at a power (see [`Intended::holding_spindle`]).
    posted_power: Option<f64>,
    first_powered: u32,
    done: bool,
    /// The last move's end, in the program and the part frame, with its (section,
    /// layer): the next move starts there, so its start needs no transform.
    last_end: Option<(Vector3<f64>, Vector3<f64>, usize, usize)>,
    /// (section, layer, its frame).
    frame_cache: Option<(usize, usize, Frame)>,
    /// The program Z a machine-coordinate retract left the head at: a feed may not start
    /// from there (its height on the part is not known).
    retract_z: Option<f64>,
    /// What the user should hear of (a program read in units it did not name, the
    /// interpreter's warnings).
    notes: Vec<String>,
    /// The section a G0 that extrudes in X or Y was warned of in.
    warned_wet_rapid: Option<usize>,
    /// The axes the section's moves named before the move being read (bits of
    /// [`lampost_gcode::AXES`]), and the section a feed from a start the program never
    /// gave (no X or Y yet) was warned of in.
    axes_before: u16,
    warned_unplaced: Option<usize>,
    /// The section a feed at a machine-coordinate retract's height was noted in (see
    /// [`Intended::positioning_at_retract`]).
    noted_positioning: Option<usize>,
    /// The section's warnings so far, one note per kind: (kind, first line, how many).
    warned: Vec<(std::mem::Discriminant<ErrorKind>, u32, usize)>,
    /// A rotary or extra axis word at zero has been noted (see `extra_axes_at_zero`).
    noted_zero_axes: bool,
    /// The laser (spindle) state the section's moves have shown: (section, turned on
    /// by M3/M4, run at a power S above 0, a feed with it off noted).
    laser_seen: (usize, bool, bool, bool),
    /// In a deposition program that never turns a laser on with M3/M4: the section and
    /// coolant state (M7/M8 on) of its first feed ([`Intended::laser_off_feed`]).
    coolant_at_first: Option<(usize, bool)>,
    /// What the look at the section's first moves found of its laser ([`laser_ahead`]):
    /// the first move made with it on, and the first made with it on at a power above
    /// S0.
    laser_ahead: LaserAhead,
    power_ahead: LaserAhead,
    /// The input line of the section's first feed made at S0 with the laser on and
    /// taken for a deposit, no power above S0 having been seen within [`LASER_LOOK`]
    /// moves (see [`Intended::laser_off_feed`]).
    dim_deposit: Option<u32>,
    /// The powers (S above 0) the section's deposits were made at in the input: the
    /// least, the greatest, and the line of the first whose power differs from the
    /// first's (a greyscale image's). The post deposits at one power.
    powers: Option<(f64, f64, Option<u32>)>,
    /// A printer's program: the extruder (T, T0 among them) its first deposit of the
    /// section was made with (see [`Intended::one_extruder`]).
    extruder: Option<u32>,
    /// The input line of the section's first feed deposited with the laser off (in a
    /// program not seen to turn it on within [`LASER_LOOK`] moves).
    dark_deposit: Option<u32>,
    /// Where the section's last step ended, when it was a deposit: a feed of no length
    /// from there continues the run (see [`Intended::move_step`]).
    deposit_end: Option<[f64; 9]>,
    /// The section's frame on the machine at its first move: the X, Y, Z offsets in
    /// force (G92, G52, a work offset set by G10) and the work offset selected (see
    /// `frame_kept`).
    frame_at_first: Option<(usize, [f64; 3], lampost_gcode::Modal)>,
}

/// How many of a section's moves the post reads ahead at most (5,000) to learn whether
/// the program turns its laser (spindle) on: a feed made with it off is travel in a
/// program that does, a deposit in one that never does; a program that feeds longer than
/// that with it off before it first turns it on is refused at that line.
pub const LASER_LOOK: usize = 5_000;

/// Whether a section's program turns its laser (spindle) on, as [`laser_ahead`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LaserAhead {
    /// A move at this input line is made with it on (M3/M4 before it).
    On(u32),
    /// No move is: the program ends (or stops at an error) first.
    Never,
    /// None of the first [`LASER_LOOK`] moves is.
    NotWithin,
}

/// The section's program read ahead, on a reader of its own, until a move is made with
/// the laser (spindle) on, and until one is made with it on at a power above S0: what
/// the post decides its feeds with the laser off, and at S0, by. A program that turns it
/// on burns nothing along its feeds with it off; one that never does is a bare path and
/// deposits along every feed. A program that runs it at a power burns nothing along its
/// feeds at S0 (LightBurn's image rows and overscans at `S0` before the first power:
/// GRBL's laser mode, Marlin's and RepRapFirmware's lasers burn nothing at S0); one that
/// never gives a power (M3 and no S) deposits along every feed made with it on. Reads at
/// most [`LASER_LOOK`] moves; the program's own errors are left to the post's reading,
/// which meets them first.
fn laser_ahead(source: &Source, opts: Options) -> Result<(LaserAhead, LaserAhead), PostError> {
    let src = ProgramReader::new(source.open()?, Order::Execution);
    let mut moves = 0usize;
    let mut on = None;
    for ev in Stream::new(src, opts, true) {
        match ev {
            Ok(Event::Move(m)) => {
                if m.modal.spindle != lampost_gcode::Spindle::Off {
                    let first = *on.get_or_insert(m.line);
                    if m.modal.speed > 0.0 {
                        return Ok((LaserAhead::On(first), LaserAhead::On(m.line)));
                    }
                }
                moves += 1;
                if moves >= LASER_LOOK {
                    let on = on.map_or(LaserAhead::NotWithin, LaserAhead::On);
                    return Ok((on, LaserAhead::NotWithin));
                }
            }
            Ok(Event::Diagnostic(d)) if d.severity == Severity::Error => break,
            Ok(Event::Diagnostic(_) | Event::Stop(_)) => {}
            Err(_) => break,
        }
    }
    Ok((
        on.map_or(LaserAhead::Never, LaserAhead::On),
        LaserAhead::Never,
    ))
}

/// The axes past X, Y, Z (A, B, C, U, V, W), as bits of [`lampost_gcode::AXES`].
const EXTRA_AXES: u16 = 0b1_1111_1000;

impl std::fmt::Debug for Intended<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Intended")
            .field("section", &self.idx)
            .finish()
    }
}

fn units_name(u: Units) -> &'static str {
    match u {
        Units::Inch => "inches",
        Units::Mm => "millimetres",
    }
}

impl<'a> Intended<'a> {
    /// The intended path of `sections` on `machine`.
    pub fn new(machine: &'a Machine, sections: &'a [Section], opts: IntendedOptions) -> Self {
        Intended {
            machine,
            sections,
            opts,
            idx: 0,
            stream: None,
            layer: 0,
            layer_z: None,
            moves_in_section: 0,
            tool: None,
            tools: Tools::Follow,
            pending: None,
            posted_spindle: None,
            warned_spindle: [None; 4],
            done: false,
            last_end: None,
            frame_cache: None,
            retract_z: None,
            notes: Vec::new(),
            warned_wet_rapid: None,
            axes_before: 0,
            warned_unplaced: None,
            noted_positioning: None,
            warned: Vec::new(),
            noted_zero_axes: false,
            laser_seen: (usize::MAX, false, false, false),
            coolant_at_first: None,
            laser_ahead: LaserAhead::Never,
            dark_deposit: None,
            deposit_end: None,
            power_ahead: LaserAhead::Never,
            dim_deposit: None,
            powers: None,
            posted_power: None,
            first_powered: 0,
            extruder: None,
            frame_at_first: None,
        }
    }

    /// A move of a program that names a rotary or extra axis: posted only while every such
    /// axis stays at 0 (CAM posts for a machine with a fourth axis write `A0.` in the
    /// first block of a 3-axis job), which is no rotation of the part; noted once. Any
    /// other value is refused at its line: the post places a planar program itself.
    fn extra_axes_at_zero(&mut self, file: &str, m: &Move) -> Result<(), PostError> {
        let named: Vec<char> = (3..lampost_gcode::AXES.len())
            .filter(|&a| m.axes_named & (1 << a) != 0)
            .map(|a| char::from(lampost_gcode::AXES[a]))
            .collect();
        let moved = (3..lampost_gcode::AXES.len()).find(|&a| m.start[a] != 0.0 || m.end[a] != 0.0);
        if let Some(a) = moved {
            return Err(PostError::Unsupported {
                file: file.to_string(),
                line: m.line,
                what: format!(
                    "the input puts its {} axis at {} (not 0): a rotary or extra axis of the program's own machine; give a planar (X Y Z) program, the post chooses the rotaries",
                    char::from(lampost_gcode::AXES[a]),
                    if m.end[a] != 0.0 { m.end[a] } else { m.start[a] }
                ),
            });
        }
        if !self.noted_zero_axes {
            self.noted_zero_axes = true;
            let names: String = named.iter().collect();
            self.notes.push(format!(
                "{file}:{}: the program names axis {names} at 0 (no rotation of the part): ignored",
                m.line
            ));
        }
        Ok(())
    }

    /// A program moves the frame it is placed by only before its first move: after it,
    /// an offset change (`G92`, `G52`, a `G10` setting the work offset in force) or
    /// another work offset (`G55`…, FADAL `E2`…) is refused at the first move made in
    /// it. A control
    /// applies them (LinuxCNC's canonical positions are in the work system in force, and
    /// the machine goes there plus the offsets), so such a program's later moves are
    /// somewhere else on the machine than the same numbers before; the post places one
    /// program frame on the part, and the offsets of another work system are not known.
    /// Checked on the offsets in X, Y and Z (a MakerBot program's `G92 A0` resets its
    /// extruder).
    fn frame_kept(&mut self, file: &str, m: &Move) -> Result<(), PostError> {
        let Some(interp) = self.stream.as_ref().map(|s| s.interpreter()) else {
            return Ok(());
        };
        let (here, prog) = (interp.position(), interp.program_position());
        let off = [here[0] - prog[0], here[1] - prog[1], here[2] - prog[2]];
        match &self.frame_at_first {
            Some((sec, first, modal)) if *sec == self.idx => {
                let other_offset = modal.work_offset != m.modal.work_offset;
                if !other_offset && off == *first {
                    return Ok(());
                }
                // Located where the frame moved, when the interpreter saw it (a
                // slicer's `G92 Z0 E0` after its purge lines), else at this move.
                let (line, next) = match interp.offset_line() {
                    0 => (m.line, String::new()),
                    l if l == m.line => (l, String::new()),
                    l => (l, format!(" (the first at line {})", m.line)),
                };
                let what = if other_offset {
                    format!("another work offset (G54…G59, FADAL E…) than the first move's is in force for the moves after this line{next}: the post places the program's frame once, and the other offsets are not known here")
                } else {
                    format!("the program's frame moves here, after the first move (G92, G52, or G10 setting the work offset in force): the control would run the moves after it{next} shifted by the change, and the post places the frame once; program one frame, or post the parts as sections of a job")
                };
                Err(PostError::Unsupported {
                    file: file.to_string(),
                    line,
                    what,
                })
            }
            // A move that goes nowhere (the Fanuc safety line `G00 G17 G40 G49 G80`,
            // which rs274 reads as a traverse to where it stands) is no first move: the
            // frame may still be placed after it.
            _ if (0..3).all(|k| m.start[k] == m.end[k]) => Ok(()),
            _ => {
                if off != [0.0; 3] {
                    // Placed by a shift the program states (G52 X10 Y5 before its
                    // first move): the numbers it cuts at are not its work offset's.
                    let at = match interp.offset_line() {
                        0 => String::new(),
                        l => format!(" at line {l}"),
                    };
                    let r = lampost_gcode::Readable;
                    self.notes.push(format!(
                        "{file}:{}: the program's moves are in a frame shifted by ({}, {}, {}) from its work offset's zero (G52, G92 or G10{at}, before its first move): --origin places that shifted frame on the part; where the part's zero is the work offset's, add the shift to --origin",
                        m.line,
                        r(off[0]),
                        r(off[1]),
                        r(off[2])
                    ));
                }
                self.frame_at_first = Some((self.idx, off, m.modal));
                Ok(())
            }
        }
    }

    /// Notes for the report, so far: each section whose program gave no G20/G21, with the
    /// units it was read in.
    pub fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    /// The units a program is read in until it says (`--units`, else the machine's).
    /// Units of a program that gives no G20/G21: `--units`; else millimetres for a
    /// printer's program (Marlin, RepRapFirmware, Klipper and Sailfish work in mm, and
    /// slicers such as Cura never write G21); else the machine's.
    fn assumed_units(&self) -> Units {
        self.opts.units.unwrap_or_else(|| {
            if self.printer_program() {
                Units::Mm
            } else {
                self.machine_units()
            }
        })
    }

    /// Whether the programs are a printer's (the flavour is a printer firmware's).
    fn printer_program(&self) -> bool {
        use lampost_gcode::Flavor;
        matches!(
            self.opts.flavor,
            Flavor::Marlin | Flavor::RepRap | Flavor::MakerBot
        )
    }

    fn machine_units(&self) -> Units {
        match self.machine.units {
            MUnits::Inch => Units::Inch,
            MUnits::Mm => Units::Mm,
        }
    }

    /// The current section's frame for `layer`, worked out once per layer.
    fn frame(&mut self, s: &Section, layer: usize) -> Frame {
        match self.frame_cache {
            Some((i, l, f)) if i == self.idx && l == layer => f,
            _ => {
                let f = section_frame(s, layer);
                self.frame_cache = Some((self.idx, layer, f));
                f
            }
        }
    }

    /// The next step, `None` at the end: the iterator's item, as the post's reading
    /// thread takes it (without the iterator's `Option<Result<…>>`, a copy of every
    /// step). After an error it is not to be called again.
    pub(crate) fn next_step(&mut self) -> Result<Option<Step>, PostError> {
        loop {
            if self.done {
                return Ok(None);
            }
            if self.idx >= self.sections.len() {
                self.done = true;
                return Ok(None);
            }
            let sec = &self.sections[self.idx];
            if self.stream.is_none() {
                let opts = Options {
                    units: self.assumed_units(),
                    e_word: if self.opts.e_extrusion {
                        EWord::Extrusion
                    } else {
                        EWord::FixtureOffset
                    },
                    flavor: self.opts.flavor,
                    // The user hears of what the post changes: the dwells it leaves out
                    // (it writes none), the block-delete lines it runs.
                    post_notes: true,
                    // The program's stops are carried to the posted program.
                    stops: true,
                    ..Options::default()
                };
                // Slicer programs go by E alone (see `laser_off_feed`).
                (self.laser_ahead, self.power_ahead) = if self.opts.e_extrusion {
                    (LaserAhead::Never, LaserAhead::Never)
                } else {
                    laser_ahead(&sec.source, opts)?
                };
                self.dark_deposit = None;
                self.deposit_end = None;
                self.dim_deposit = None;
                self.powers = None;
                // In execution order, as `trace` reads it: subprogram calls (M98, M97,
                // LinuxCNC O-word calls) and loops are followed by the one reader, and
                // the flavour's parameters evaluated by the stream.
                let src = ProgramReader::new(sec.source.open()?, Order::Execution);
                self.stream = Some(Stream::new(src, opts, true));
                self.warned.clear();
                self.axes_before = 0;
                self.layer = 0;
                self.layer_z = None;
                self.moves_in_section = 0;
                // A deposition program's tool is one a section; a machining program's
                // tool changes are posted, across sections too.
                if self.tools == Tools::Refuse {
                    self.tool = None;
                }
                self.extruder = None;
            }
            // The move a tool change was found at comes again after the change's step.
            if let Some(m) = self.pending.take() {
                return self.move_step(&m).map(Some);
            }
            // Read in place (a move is some hundreds of bytes: each move of it a copy).
            let ev = self.stream.as_mut().and_then(Iterator::next);
            let ev = match &ev {
                None => {
                    if self.moves_in_section == 0 {
                        return Err(PostError::Empty(sec.name.clone()));
                    }
                    for &(_, first, n) in self.warned.iter().filter(|w| w.2 > 1) {
                        self.notes.push(format!(
                            "{}: {} more warning(s) like that of line {first}",
                            sec.name,
                            n - 1
                        ));
                    }
                    match (self.powers, self.posted_power) {
                        (Some((lo, hi, Some(line))), _) => self.notes.push(format!(
                            "{}:{line}: the input's laser power varies (S{} to S{}: a greyscale image's, or power by speed), and the posted program deposits at one power throughout (the machine's laser_on with --power)",
                            sec.name,
                            lampost_gcode::Readable(lo),
                            lampost_gcode::Readable(hi)
                        )),
                        // One power throughout, another than the post's: said as a
                        // machining program's other spindle speed is.
                        (Some((s, _, None)), Some(p))
                            if (s - p).abs() > 1e-9 * p.abs().max(1.0) =>
                        {
                            self.notes.push(format!(
                                "{}:{}: the input deposits at S{}; the posted program deposits at power {} (--power, in the machine's laser_on and laser_power_word)",
                                sec.name,
                                self.first_powered,
                                lampost_gcode::Readable(s),
                                lampost_gcode::Readable(p)
                            ))
                        }
                        _ => {}
                    }
                    if self
                        .stream
                        .as_ref()
                        .is_some_and(|s| !s.interpreter().units_given())
                    {
                        let u = self.assumed_units();
                        self.notes.push(format!(
                            "{}: the program gives no G20/G21: its numbers were read as {} ({})",
                            sec.name,
                            units_name(u),
                            if self.opts.units.is_some() {
                                "--units"
                            } else if self.printer_program() {
                                "a printer's firmware works in mm; say otherwise with --units"
                            } else {
                                "the machine's units; say otherwise with --units"
                            }
                        ));
                    }
                    self.stream = None;
                    self.idx += 1;
                    continue;
                }
                Some(Err(e)) => return Err(PostError::Io(format!("{}: {e}", sec.name))),
                Some(Ok(ev)) => ev,
            };
            match ev {
                Event::Diagnostic(d) => {
                    let file = sec.name.clone();
                    if d.severity == Severity::Error {
                        if matches!(d.kind, ErrorKind::EmptyProgram) {
                            return Err(PostError::Empty(file));
                        }
                        return Err(PostError::Input {
                            file,
                            diag: Box::new(d.clone()),
                        });
                    }
                    let refuse = match &d.kind {
                        // A deposition program that never turns a laser on with M3/M4
                        // is a bare path, deposited along every feed; an M-code of the
                        // machine's own between its feeds may be what switches its
                        // laser (a DED cell's `M201 (SDC 36.7)`, a printer's laser on
                        // `M106`), and then its lifts and moves between tracks would be
                        // deposited too. (Codes before the first feed set the machine
                        // up: Rotrics' `M2000` header.)
                        ErrorKind::MCodeLeftOut(code)
                            if self.posted_spindle.is_none()
                                && !self.opts.e_extrusion
                                && self.laser_seen.0 == self.idx
                                && !matches!(self.laser_ahead, LaserAhead::On(_)) =>
                        {
                            Some(format!(
                                "{code} between the feeds of a program that never turns a laser on with M3/M4: such a program is a bare path, deposited along every feed, and {code} may be the machine's own laser switch (then its lifts and moves between tracks would be deposited too); if it is, write M3 (with S for the power) where it turns the laser on and M5 where it turns it off, then post again; if it is not, remove it (the post leaves it out in any case)"
                            ))
                        }
                        ErrorKind::MacroNotEvaluated(what) => Some(format!(
                            "{what}: macros would need evaluating to know the path"
                        )),
                        ErrorKind::NotSimulated(what) if what.contains("after M2") => None,
                        ErrorKind::NotSimulated(what) if what.starts_with("a `%` line with text after it") => Some(
                            "a `%` line with text after it (a user's note, `% vfd enable`): a Fanuc, Haas or FADAL control stops reading the program there, other controls read past it, so where the program ends cannot be told; remove the line (or write the note as a comment in parentheses) if the moves after it are meant, or end the program there".to_string(),
                        ),
                        ErrorKind::MainProgramLoops(control) => Some(format!(
                            "M99 in the main program: a {control} control runs it again without end, and the post writes one pass; end the program with M30"
                        )),
                        ErrorKind::NotSimulated(what) if what.contains("firmware") => Some(format!(
                            "{what} changes the path; the post cannot follow it"
                        )),
                        ErrorKind::NotSimulated(what) => Some(format!(
                            "{what} changes the path; the post cannot follow it: have the CAM system write the moves it stands for (a pocket or circle as its arcs and lines, a rotated, scaled or mirrored frame as the moves in the program's own frame), or remove it where it changes nothing"
                        )),
                        ErrorKind::CutterCompTraced(what) => Some(format!(
                            "{what}: cutter radius compensation changes the path; the post writes no compensated path (program the tool's centre path, G40)"
                        )),
                        ErrorKind::IntegerWord { word, control, .. } => Some(format!(
                            "`{word}` has no decimal point, and {control} reads such a number in least increments by default: whether whole units or increments are meant cannot be told, and the post does not guess; write the decimal point (`{word}.`) in every such word"
                        )),
                        ErrorKind::FirmwareMacro(what) => Some(format!(
                            "`{what}` is a printer firmware's own macro or command: its moves, if any, are not known, so the post cannot place them; {}",
                            if self.extruder.is_some() {
                                "it comes after the first deposit: remove it from the slicer's per-layer custom G-code (before or after the layer change, a timelapse frame), or from the end code if the print is over"
                            } else {
                                "remove the printer's start and end code from the slicer's custom G-code"
                            }
                        )),
                        ErrorKind::LatheProgram(evidence) => Some(format!(
                            "{evidence} makes this a lathe (turning) program; lampost posts mill programs only (a lathe's X is a diameter, its cycles and corner words a lathe's)"
                        )),
                        ErrorKind::LatheCycle(c) => Some(format!(
                            "{c} is a lathe's roughing or finishing cycle; the post does not write lathe cycles"
                        )),
                        ErrorKind::CannedCyclePassedThrough(c) => {
                            Some(format!("canned cycle G{c} cannot be posted (not expanded)"))
                        }
                        ErrorKind::SubprogramNotFollowed(w) => Some(format!(
                            "{w}: subprogram calls cannot be posted; inline them"
                        )),
                        _ => None,
                    };
                    if let Some(what) = refuse {
                        return Err(PostError::Unsupported {
                            file,
                            line: d.line,
                            what,
                        });
                    }
                    // A warning the post passes: the user hears of it, once per kind
                    // (with a count at the section's end).
                    let key = std::mem::discriminant(&d.kind);
                    match self.warned.iter_mut().find(|w| w.0 == key) {
                        Some(w) => w.2 += 1,
                        None => {
                            self.warned.push((key, d.line, 1));
                            let said = match &d.kind {
                                // A machining program's dwell is no laser's: mostly the
                                // spindle's spin-up after M3 (`G04 P4000`).
                                ErrorKind::DwellLeftOut(what) if self.posted_spindle.is_some() => format!(
                                    "{what}: the dwell is left out of the posted program (the post writes no dwells); where it lets the spindle reach its speed after M3 before the first cut, make sure the control waits for the speed"
                                ),
                                kind => kind.to_string(),
                            };
                            self.notes.push(format!("{file}:{}: {said}", d.line));
                        }
                    }
                    continue;
                }
                Event::Stop(stop) => return Ok(Some(self.stop_step(*stop))),
                Event::Move(m) => return self.move_step(m).map(Some),
            }
        }
    }

    /// The step of move `m` of the section being read (a tool change's first, when the
    /// move is the first cut made with a new tool: the move comes again after it).
    /// Inlined into [`Intended::next_step`], as this was before it became a function of
    /// its own (the post's reading thread ran some 4 % slower without).
    #[inline(always)]
    fn move_step(&mut self, m: &Move) -> Result<Step, PostError> {
        let sections = self.sections;
        let sec = &sections[self.idx];
        let positioning;
        let m = match self.retract_z {
            Some(z) => match self.positioning_at_retract(&sec.name, m, z) {
                Some(p) => {
                    positioning = p;
                    &positioning
                }
                None => m,
            },
            None => m,
        };
        if m.axes_named & EXTRA_AXES != 0 {
            self.extra_axes_at_zero(&sec.name, m)?;
        }
        if let Some(change) = self.one_tool(&sec.name, m)? {
            let line = m.line;
            self.pending = Some(*m);
            return Ok(self.here_step(StepKind::ToolChange(change), line));
        }
        let axes_before = std::mem::replace(&mut self.axes_before, m.axes_named);
        self.frame_kept(&sec.name, m)?;
        if let Some(posted) = self.posted_spindle {
            self.spindle_kept(&sec.name, m, posted)?;
        }
        if let Some(step) = self.machine_coordinate_move(m)? {
            self.moves_in_section += 1;
            return Ok(step);
        }
        let mu = self.machine_units();
        let scale = if m.modal.units == mu {
            1.0
        } else if self.opts.convert_units {
            m.modal.units.mm() / mu.mm()
        } else {
            return Err(PostError::Units {
                file: sec.name.clone(),
                line: m.line,
                program: units_name(m.modal.units),
                machine: units_name(mu),
            });
        };
        self.moves_in_section += 1;
        let p = |a: &[f64; 9]| Vector3::new(a[0], a[1], a[2]) * scale;
        let (start, end) = (p(&m.start), p(&m.end));
        // With E as extrusion, a G1 (or arc) along which E does not grow is travel:
        // the head moves with the laser off (a slicer's travel written as G1, its
        // wipes, the lift off the finished part), and its tips are not work.
        let dry = self.opts.e_extrusion
            && matches!(m.kind, MoveKind::Linear | MoveKind::Arc { .. })
            && !m.extruded.is_some_and(|grown| grown > 0.0);
        // A G0 along which E grows is travel here, as slicers mean it: their start and
        // end code primes the nozzle on a lift (Cura: `G0 F10000 Z1.5 E4.5`), which is
        // no deposit. The firmware would extrude along it, so one that also moves in
        // X or Y (a deposit written as G0 by hand) is warned of, once a section.
        if self.opts.e_extrusion
            && matches!(m.kind, MoveKind::Rapid)
            && m.origin == Origin::Block
            && m.extruded.is_some_and(|grown| grown > 0.0)
            && (m.end[0] != m.start[0] || m.end[1] != m.start[1])
            && self.warned_wet_rapid != Some(self.idx)
        {
            self.warned_wet_rapid = Some(self.idx);
            self.notes.push(format!(
                "{}:{}: a G0 that extrudes while it moves in X or Y is posted as travel (laser off): the firmware would extrude along it; write deposits as G1",
                sec.name, m.line
            ));
        }
        // A laser (or spindle) program's feed made with the laser off again (M5 after
        // M3/M4) or at zero power (S0 after a power above 0: LightBurn's and
        // LaserGRBL's raster gaps, `G1 X0.62 S0`) burns nothing: travel, as a slicer's
        // G1 that does not extrude. A program that never turns it on deposits along
        // every feed, as before.
        let dry = dry || self.laser_off_feed(sec, m)?;
        // A straight feed of no length that continues no deposit (a CAM system's point
        // repeated after a rapid, a DED program's `G1 Z20` to where the head is) moves
        // nothing and burns nothing: travel. Posted as a deposit it turned the laser on
        // and off over one spot.
        let dry = dry
            || matches!(m.kind, MoveKind::Linear)
                && m.start == m.end
                && self.deposit_end != Some(m.start);
        let is_feed = !matches!(m.kind, MoveKind::Rapid) && !dry;
        // A cut or deposit from a start the program never gave (`G1 Z-1` before any X or
        // Y): the interpreter starts from 0 there, as rs274 does, and so does the posted
        // program; on the machine the move would start wherever the head stands. (Not a
        // lift written as a feed, `G1 Z3.81` first thing, as Easel and GRBLGRU write.)
        const XY: u16 = 0b11;
        let lift = m.end[0] == m.start[0] && m.end[1] == m.start[1] && m.end[2] > m.start[2];
        if is_feed && !lift && axes_before & XY != XY && self.warned_unplaced != Some(self.idx) {
            self.warned_unplaced = Some(self.idx);
            let missing = match axes_before & XY {
                0 => "X and Y",
                1 => "Y",
                _ => "X",
            };
            self.notes.push(format!(
                "{}:{}: this feed starts before the program gives {missing}: it is posted from {missing} = 0 of the program (as rs274 reads it), while the machine would start it wherever the head stands; give the start first (a G0 to it) if 0 is not meant",
                sec.name, m.line
            ));
        }
        // Layers: a feed move ending at a new Z level starts a new layer.
        if is_feed && sec.layers.is_some() {
            match self.layer_z {
                None => self.layer_z = Some(end.z),
                Some(z) if (z - end.z).abs() > 1e-9 => {
                    self.layer += 1;
                    self.layer_z = Some(end.z);
                }
                _ => {}
            }
        }
        let frame = self.frame(sec, self.layer);
        // A feed deposits exactly when E grows along it (absolute or relative E, the
        // interpreter gives the growth); E-only and F-only blocks are no moves.
        let deposit = is_feed && (!self.opts.e_extrusion || m.extruded.is_some_and(|g| g > 0.0));
        if deposit && self.opts.e_extrusion {
            self.one_extruder(&sec.name, m)?;
        }
        let kind = match m.kind {
            _ if dry => StepKind::Rapid,
            MoveKind::Rapid => StepKind::Rapid,
            MoveKind::Linear | MoveKind::Probe => StepKind::Feed,
            MoveKind::Arc {
                clockwise,
                center,
                plane,
                turns,
            } => {
                let (u, v, n) = plane.axes();
                let mut nrm = Vector3::zeros();
                nrm[n] = 1.0;
                let c = Vector3::new(center[0], center[1], center[2]) * scale;
                let su = (start[u] - c[u], start[v] - c[v]);
                let eu = (end[u] - c[u], end[v] - c[v]);
                let tau = std::f64::consts::TAU;
                let full = (su.0 - eu.0).hypot(su.1 - eu.1) <= 1e-9 * (1.0 + su.0.hypot(su.1));
                // Angle from start to end, right-handed about the plane's normal.
                let delta = eu.1.atan2(eu.0) - su.1.atan2(su.0);
                let extra = tau * f64::from(turns.saturating_sub(1));
                let sweep = if clockwise {
                    let mut d = delta.rem_euclid(tau) - tau; // in [−2π, 0)
                    if full {
                        d = -tau;
                    }
                    d - extra
                } else {
                    let mut d = delta.rem_euclid(tau); // in [0, 2π)
                    if full || d == 0.0 {
                        d = tau;
                    }
                    d + extra
                };
                StepKind::Arc {
                    center: frame.apply(&c),
                    normal: frame.dir(&nrm),
                    sweep,
                }
            }
        };
        if let Some(z) = self.retract_z {
            if is_feed && m.start[2] == z {
                return Err(PostError::Unsupported {
                    file: sec.name.clone(),
                    line: m.line,
                    what: "a feed starts at the height a machine-coordinate retract (G53/G28/G30) left the head at, which is not known on the part; rapid to a program Z first".into(),
                });
            }
            if m.end[2] != z {
                self.retract_z = None;
            }
        }
        let feed = if is_feed { m.feed * scale } else { 0.0 };
        if is_feed && m.modal.feed_mode == lampost_gcode::FeedMode::InverseTime {
            return Err(PostError::Unsupported {
                file: sec.name.clone(),
                line: m.line,
                what: "G93 inverse-time feeds in the planar input cannot be posted".into(),
            });
        }
        let start_part = match self.last_end {
            Some((raw, part, sec_i, layer))
                if raw == start && sec_i == self.idx && layer == self.layer =>
            {
                part
            }
            _ => frame.apply(&start),
        };
        let end_part = frame.apply(&end);
        self.last_end = Some((end, end_part, self.idx, self.layer));
        self.deposit_end = deposit.then_some(m.end);
        Ok(Step {
            section: self.idx as u32,
            layer: self.layer,
            line: m.line,
            kind,
            start: start_part,
            end: end_part,
            feed,
            deposit,
            tool: m.modal.tool,
        })
    }
}

impl Intended<'_> {
    /// The input's tool changes (`M6`, `M61`). A machining program's change from one tool
    /// to another is a [`StepKind::ToolChange`] before the first cut made with the new
    /// tool (its rapids before that cut are travel, rebuilt at the safe height after the
    /// change): the tool, its `G43 H` and its S as the input has them at that cut. It is
    /// refused there when the program is posted without tool length offsets (the new
    /// tool would cut at the first one's length: post with `--length-offset`), when the
    /// input gives the new tool no `G43 H` by its first cut, or no spindle speed. A
    /// deposition program is posted for one tool a section: a change is refused at the
    /// first move made with the new tool. The first tool loaded after moves made with
    /// none (T0: pcb2gcode moves to its tool-change height, then `M6`), and T0 put back
    /// at the end, are no change of the tool that cuts.
    #[inline]
    fn one_tool(&mut self, file: &str, m: &Move) -> Result<Option<ToolChange>, PostError> {
        if self.opts.e_extrusion {
            // A printer's tools are its extruders: held by `one_extruder`.
            return Ok(None);
        }
        let now = m.modal.tool;
        match self.tool {
            _ if now == 0 => return Ok(None),
            None => {
                self.tool = Some(now);
                return Ok(None);
            }
            Some(t) if t == now => return Ok(None),
            Some(_) => {}
        }
        self.tool_change(file, m)
    }

    /// A straight feed that stays at the height a machine-coordinate retract left the
    /// head at (`z`), moving only across: Fusion's positioning after `G53 G0 Z0.` and a
    /// tool change (`G1 X5.1 Y-1.975 F650.`, then `G0 G43 Z0.6 H10`) is such a move, a
    /// rapid written as a feed. Nothing is cut up there, and its height on the part is not
    /// known: it is travel, as a rapid there is (rebuilt at the safe height), noted once a
    /// section. `None` for any other move (a feed that leaves that height is refused in
    /// [`Intended::move_step`]).
    #[cold]
    fn positioning_at_retract(&mut self, file: &str, m: &Move, z: f64) -> Option<Move> {
        let across = matches!(m.kind, MoveKind::Linear)
            && m.origin == Origin::Block
            && m.start[2] == z
            && m.end[2] == z;
        if !across {
            return None;
        }
        if self.noted_positioning != Some(self.idx) {
            self.noted_positioning = Some(self.idx);
            self.notes.push(format!(
                "{file}:{}: a feed across at the height a machine-coordinate retract (G53/G28/G30) left the head at is positioning (a rapid written as a feed): posted as travel at the safe height",
                m.line
            ));
        }
        Some(Move {
            kind: MoveKind::Rapid,
            ..*m
        })
    }

    /// A printer's program (E as extrusion) deposits with one extruder a section: its
    /// tools are its extruders, `T0` the first, changed by a bare `T1` (Marlin,
    /// RepRapFirmware, Klipper; PrusaSlicer's MMU, Cura's dual extrusion, Orca's and
    /// Bambu's filament changes write them so). A deposit made with another extruder than
    /// the section's first deposit is refused at its line: the post deposits one powder
    /// a program, and two materials would be posted as one. Travel with any extruder is
    /// no deposit and says nothing; without a process (the work's bounds) changes are
    /// followed.
    #[cold]
    fn one_extruder(&mut self, file: &str, m: &Move) -> Result<(), PostError> {
        let now = m.modal.tool;
        match self.extruder {
            Some(t) if t != now && self.tools != Tools::Follow => Err(PostError::Unsupported {
                file: file.to_string(),
                line: m.line,
                what: format!(
                    "a deposit made with extruder T{now}, after deposits made with T{t}: the slicer's program prints two materials (or two nozzles), and the post deposits one powder a program; post each extruder's part as a program of its own (slice it with one extruder)"
                ),
            }),
            _ => {
                self.extruder = Some(now);
                Ok(())
            }
        }
    }

    /// See [`Intended::one_tool`]: a move made with another tool than the last.
    #[cold]
    fn tool_change(&mut self, file: &str, m: &Move) -> Result<Option<ToolChange>, PostError> {
        let (t, now) = (self.tool.unwrap_or(0), m.modal.tool);
        if self.tools == Tools::Refuse {
            return Err(tool_changed(file, m, t));
        }
        // Taken at the first cut made with the new tool (a canned cycle's feeds are cuts);
        // its rapids and machine-coordinate retracts before it are travel.
        if matches!(m.kind, MoveKind::Rapid)
            || matches!(m.origin, Origin::Home | Origin::MachineCoords)
        {
            return Ok(None);
        }
        let md = &m.modal;
        let refuse = |what: String| {
            Err(PostError::Unsupported {
                file: file.to_string(),
                line: m.line,
                what,
            })
        };
        let mut change = ToolChange {
            tool: now,
            length_offset: md.tool_length,
            speed_bits: md.speed.to_bits(),
        };
        if let (Tools::Machine, Some(posted)) = (self.tools, self.posted_spindle.as_mut()) {
            if let Some(x) = posted.tool.filter(|&x| x != t) {
                return refuse(format!(
                    "a tool change from T{t} to T{now} (its M6 before this line, the first cut with the new tool), and the program is posted with T{x} for T{t} (--tool): the post takes each later tool's number from the input, so the numbering would mix; post with --tool {t}"
                ));
            }
            if posted.length_offset.is_none() && md.tool_length.is_none() {
                // Neither the options nor the input give lengths: saying only one of
                // them would send the user from one refusal to the other.
                return refuse(format!(
                    "a tool change from T{t} to T{now} (its M6 before this line, the first cut with the new tool), and neither the options nor the input give tool length offsets (no --length-offset, no G43 H for T{now} by this cut): T{now} would cut at T{t}'s length; give each tool its G43 H in the input (the offset the control holds the tool's length under) and post with --length-offset for the first, or post each tool's operations as a program of their own"
                ));
            }
            if posted.length_offset.is_none() {
                return refuse(format!(
                    "a tool change from T{t} to T{now} (its M6 before this line, the first cut with the new tool), and the program is posted without tool length offsets: T{now} would cut at T{t}'s length; post with --length-offset (the first tool's H; each later tool takes the input's G43 H)"
                ));
            }
            let Some(h) = md.tool_length else {
                return refuse(format!(
                    "T{now}'s first cut (after its tool change from T{t}) is made without a tool length offset: give it its G43 H before this line, or post each tool's operations as a program of their own"
                ));
            };
            if md.spindle == lampost_gcode::Spindle::Off || md.speed <= 0.0 {
                return refuse(format!(
                    "T{now}'s first cut (after its tool change from T{t}) is made with the spindle stopped or at S0: give its S and M3 before this line"
                ));
            }
            change.length_offset = Some(h);
            posted.tool = Some(now);
            posted.length_offset = Some(h);
            posted.speed = md.speed;
        }
        self.tool = Some(now);
        Ok(Some(change))
    }

    /// Hold the input's spindle to the one `process` posts, when it machines: a cut made
    /// with the spindle turning the other way than the machine's `spindle_on` code turns
    /// it (`M4` where that is `M3`) is refused at its line (the post would drive the tool
    /// backwards); a cut at another speed than `--spindle`, with coolant when the
    /// program is posted without it, or with another tool or tool length offset than
    /// `--tool` and `--length-offset` give, is warned of once a section. They used to be
    /// replaced without a word.
    pub fn holding_spindle(mut self, process: &Process) -> Self {
        if let Process::Machine {
            spindle,
            coolant,
            tool,
            length_offset,
            ..
        } = process
        {
            // The way the machine's spindle_on code turns it (M3 or M4 among its words).
            let on =
                crate::post::code_words(&self.machine.def.process.spindle_on).unwrap_or_default();
            let turns = |code: f64| on.iter().any(|&(l, v)| l == b'M' && v == code);
            let way = if turns(3.0) {
                Some(lampost_gcode::Spindle::Cw)
            } else if turns(4.0) {
                Some(lampost_gcode::Spindle::Ccw)
            } else {
                None
            };
            self.posted_spindle = Some(PostedSpindle {
                speed: *spindle,
                coolant: *coolant,
                way,
                tool: *tool,
                length_offset: *length_offset,
            });
            self.tools = Tools::Machine;
        } else {
            self.tools = Tools::Refuse;
        }
        if let Process::Deposit { power } = process {
            self.posted_power = Some(*power);
        }
        self
    }

    /// See [`Intended::holding_spindle`].
    #[inline]
    fn spindle_kept(
        &mut self,
        file: &str,
        m: &Move,
        posted: PostedSpindle,
    ) -> Result<(), PostError> {
        if matches!(m.kind, MoveKind::Rapid) {
            return Ok(());
        }
        let md = &m.modal;
        if let Some(way) = posted
            .way
            .filter(|&w| md.spindle != lampost_gcode::Spindle::Off && md.spindle != w)
        {
            let (theirs, ours) = match way {
                lampost_gcode::Spindle::Ccw => (("clockwise", "M3"), ("counter-clockwise", "M4")),
                _ => (("counter-clockwise", "M4"), ("clockwise", "M3")),
            };
            return Err(PostError::Unsupported {
                file: file.to_string(),
                line: m.line,
                what: format!(
                    "a cut with the spindle turning {} ({}): the posted program turns it by the machine's spindle_on code ({}, {}), which would drive the tool backwards; post a program that cuts with {}",
                    theirs.0, theirs.1, ours.0, ours.1, ours.1
                ),
            });
        }
        let on = md.spindle != lampost_gcode::Spindle::Off;
        if on
            && md.speed > 0.0
            && (md.speed - posted.speed).abs() > 1e-9 * posted.speed.abs().max(1.0)
            && self.warned_spindle[0] != Some(self.idx)
        {
            self.warned_spindle[0] = Some(self.idx);
            self.notes.push(format!(
                "{file}:{}: the input cuts at S{}; the posted program turns the spindle at S{} (--spindle)",
                m.line,
                lampost_gcode::Readable(md.speed),
                lampost_gcode::Readable(posted.speed)
            ));
        }
        let named =
            |v: Option<u32>, letter: char| v.map_or("none".to_string(), |n| format!("{letter}{n}"));
        if md.tool != 0 && posted.tool != Some(md.tool) && self.warned_spindle[2] != Some(self.idx)
        {
            self.warned_spindle[2] = Some(self.idx);
            self.notes.push(format!(
                "{file}:{}: the input cuts with tool T{}; the posted program {} (--tool)",
                m.line,
                md.tool,
                posted
                    .tool
                    .map_or("makes no tool change".to_string(), |t| format!(
                        "changes to T{t}"
                    ))
            ));
        }
        if let Some(h) = md.tool_length.filter(|&h| posted.length_offset != Some(h)) {
            if self.warned_spindle[3] != Some(self.idx) {
                self.warned_spindle[3] = Some(self.idx);
                self.notes.push(format!(
                    "{file}:{}: the input cuts with tool length offset H{h} (G43); the posted program applies {} (--length-offset): check the tool's Z before running it",
                    m.line,
                    named(posted.length_offset, 'H')
                ));
            }
        }
        if (md.flood || md.mist) && !posted.coolant && self.warned_spindle[1] != Some(self.idx) {
            self.warned_spindle[1] = Some(self.idx);
            self.notes.push(format!(
                "{file}:{}: the input cuts with coolant on ({}); the posted program has none (post with --coolant)",
                m.line,
                if md.flood { "M8" } else { "M7" }
            ));
        }
        Ok(())
    }

    /// The step of a program stop: where the last move of the section (and layer) ended.
    #[cold]
    fn stop_step(&mut self, stop: lampost_gcode::Stop) -> Step {
        self.here_step(StepKind::Stop(stop.kind), stop.line)
    }

    /// A step of `kind` between moves (a stop, a tool change), at input line `line`:
    /// where the last move of the section (and layer) ended.
    #[cold]
    fn here_step(&mut self, kind: StepKind, line: u32) -> Step {
        let here = match self.last_end {
            Some((_, part, sec_i, layer)) if sec_i == self.idx && layer == self.layer => part,
            _ => {
                let sec = &self.sections[self.idx];
                self.frame(sec, self.layer).apply(&Vector3::zeros())
            }
        };
        Step {
            section: self.idx as u32,
            layer: self.layer,
            line,
            kind,
            start: here,
            end: here,
            feed: 0.0,
            deposit: false,
            tool: self.tool.unwrap_or(0),
        }
    }

    /// Whether `m` is a feed that burns nothing (see its call): made with the laser
    /// (spindle) off in a program that turns it on (before its first M3/M4, as
    /// [`laser_ahead`] found, or after an M5), or at zero power after the section ran it
    /// at a power; noted once a section. A program that never turns it on deposits along
    /// every feed; one that first does after [`LASER_LOOK`] moves, having fed with it off
    /// before, is refused at that line (those feeds were taken for deposits). Slicer
    /// programs (E as extrusion) go by E alone.
    fn laser_off_feed(
        &mut self,
        sec: &Section,
        m: &lampost_gcode::Move,
    ) -> Result<bool, PostError> {
        if self.opts.e_extrusion || !matches!(m.kind, MoveKind::Linear | MoveKind::Arc { .. }) {
            return Ok(false);
        }
        if self.laser_seen.0 != self.idx {
            self.laser_seen = (self.idx, false, false, false);
        }
        let on = m.modal.spindle != lampost_gcode::Spindle::Off;
        let coolant = m.modal.flood || m.modal.mist;
        let bare = !on
            && !self.laser_seen.1
            && !matches!(self.laser_ahead, LaserAhead::On(_))
            && self.posted_spindle.is_none();
        match self.coolant_at_first {
            Some((idx, first)) if idx == self.idx && bare && first != coolant => {
                // A bare path deposits along every feed; a torch or powder switched by
                // the coolant codes (a WAAM program's `M08` weld, `M09` stop) would
                // have its travel deposited too.
                return Err(PostError::Unsupported {
                    file: sec.name.clone(),
                    line: m.line,
                    what: format!(
                        "the coolant is turned {} (M7/M8/M9) between the feeds of a program that never turns a laser on with M3/M4: such a program is a bare path, deposited along every feed, and on a welding or DED machine these codes may switch the torch or the powder (then its travel would be deposited too); if they do, write M3 (with S for the power) where the deposit starts and M5 where it stops, then post again; if not, remove them (a deposition program is posted without coolant)",
                        if coolant { "on" } else { "off" }
                    ),
                });
            }
            Some((idx, _)) if idx == self.idx => {}
            _ => self.coolant_at_first = Some((self.idx, coolant)),
        }
        if let (true, Some(dark)) = (on, self.dark_deposit) {
            return Err(PostError::Unsupported {
                file: sec.name.clone(),
                line: m.line,
                what: format!(
                    "the laser (spindle) is first on here, after more than {LASER_LOOK} moves; the feeds before it (from line {dark}) were made with it off and taken for deposits, as in a program that never turns it on; turn it on (M3/M4) before the first feed, or leave M3/M4 out of a bare path"
                ),
            });
        }
        let powered = on && m.modal.speed > 0.0;
        if let (true, Some(dim)) = (powered, self.dim_deposit) {
            return Err(PostError::Unsupported {
                file: sec.name.clone(),
                line: m.line,
                what: format!(
                    "the laser first runs at a power above S0 here, after more than {LASER_LOOK} moves; the feeds before it made at S0 (from line {dim}) were taken for deposits, as in a program that never gives a power; give the power (S) before the first feed, or leave the S0 feeds out"
                ),
            });
        }
        self.laser_seen.1 |= on;
        self.laser_seen.2 |= powered;
        let off = if on {
            // At S0 it burns nothing, once the program is seen to run it at a power
            // (before this move, or ahead of it).
            (self.laser_seen.2 || matches!(self.power_ahead, LaserAhead::On(_)))
                && m.modal.speed == 0.0
        } else {
            self.laser_seen.1 || matches!(self.laser_ahead, LaserAhead::On(_))
        };
        if !on && !off && self.laser_ahead == LaserAhead::NotWithin {
            self.dark_deposit.get_or_insert(m.line);
        }
        if on && !off && !powered && self.power_ahead == LaserAhead::NotWithin {
            self.dim_deposit.get_or_insert(m.line);
        }
        if powered && self.posted_spindle.is_none() {
            let s = m.modal.speed;
            if self.powers.is_none() {
                self.first_powered = m.line;
            }
            let p = self.powers.get_or_insert((s, s, None));
            if s != p.0 || s != p.1 {
                p.2.get_or_insert(m.line);
            }
            (p.0, p.1) = (p.0.min(s), p.1.max(s));
        }
        if off && !self.laser_seen.3 {
            self.laser_seen.3 = true;
            // Said in the process's own words: a machining program's M3 runs a spindle.
            let note = if self.posted_spindle.is_some() {
                "a feed made with the spindle stopped (before the program's first M3/M4, or after M5) or at S0 is posted as travel, not as a cut; so is every such feed"
            } else {
                "a feed made with the laser off (before the program's first M3/M4, or after M5) or at zero power (S0) is posted as travel (laser off), not deposited; so is every such feed"
            };
            self.notes.push(format!("{}:{}: {note}", sec.name, m.line));
        }
        Ok(off)
    }

    /// A G53, G28 or G30 move: a retract step when it only moves Z (every other axis
    /// within 1e-9 of where it was), a refusal otherwise; `None` for program moves.
    fn machine_coordinate_move(
        &mut self,
        m: &lampost_gcode::Move,
    ) -> Result<Option<Step>, PostError> {
        let what = match m.origin {
            Origin::Home => "G28/G30 (a move to a home position)",
            Origin::MachineCoords => "G53 (a move in machine coordinates)",
            Origin::Block | Origin::CannedCycle => return Ok(None),
        };
        let sec = &self.sections[self.idx];
        // Home and machine positions are not known here: judge by the axes the block
        // names (G28/G30 with none sends every axis home).
        let named_only_z = m.block_axes == 1 << 2;
        let z_only =
            named_only_z && (0..9).all(|a| a == 2 || (m.end[a] - m.start[a]).abs() <= 1e-9);
        if !z_only || !matches!(m.kind, MoveKind::Rapid) {
            // A block naming axes but not Z: a mill program's park (`G53 G0 X0. Y0.`,
            // `G28 G91 Y0.`: the table brought to the operator at the end or at a stop).
            // (A printer's `G28 X0` or Prusa's `G28 W` is its homing, said below.)
            let park = !self.opts.e_extrusion && m.block_axes != 0 && m.block_axes & (1 << 2) == 0;
            let what = if park {
                format!(
                    "{what} that parks the table (a CAM program's `G53 G0 X0. Y0.` or `G28 G91 X0. Y0.` at its end or before a stop) cannot be placed on the part, and the post writes no moves in machine coordinates: remove the line (the posted program lifts to the safe height before each stop and at its end, and stays over the part)"
                )
            } else {
                let moves = if m.block_axes == 0 {
                    "with no axes named (every axis sent home)"
                } else {
                    "that moves more than Z"
                };
                format!(
                    "{what} {moves} cannot be placed on the part: keep only Z retracts in machine coordinates; remove the line (a mill program homes this way at its start or end: the posted program lifts to the safe height at its end; a slicer's start code homes the printer this way: remove its homing and bed-levelling lines)"
                )
            };
            return Err(PostError::Unsupported {
                file: sec.name.clone(),
                line: m.line,
                what,
            });
        }
        let scale = if m.modal.units == self.machine_units() {
            1.0
        } else {
            m.modal.units.mm() / self.machine_units().mm()
        };
        let frame = self.frame(sec, self.layer);
        let here = frame.apply(&(Vector3::new(m.start[0], m.start[1], m.start[2]) * scale));
        self.retract_z = Some(m.end[2]);
        // The next move starts from the program position the interpreter reports.
        self.last_end = None;
        Ok(Some(Step {
            section: self.idx as u32,
            layer: self.layer,
            line: m.line,
            kind: StepKind::Retract,
            start: here,
            end: here,
            feed: 0.0,
            deposit: false,
            tool: m.modal.tool,
        }))
    }
}

/// The spindle a machining program is posted with: its speed and whether coolant is on.
#[derive(Debug, Clone, Copy)]
struct PostedSpindle {
    speed: f64,
    coolant: bool,
    /// The way the machine's `spindle_on` code turns it, where it says (M3 or M4).
    way: Option<lampost_gcode::Spindle>,
    /// `--tool` and `--length-offset`.
    tool: Option<u32>,
    length_offset: Option<u32>,
}

/// What [`Intended::one_tool`] does with a tool change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tools {
    /// Machining ([`Intended::holding_spindle`]): posted, held to the process.
    Machine,
    /// Deposition: refused (one tool a section).
    Refuse,
    /// No process given (the work's bounds): followed as the input makes it.
    Follow,
}

/// The refusal of a tool change (see [`Intended::one_tool`]): from `t` to `m`'s tool.
#[cold]
fn tool_changed(file: &str, m: &Move, t: u32) -> PostError {
    PostError::Unsupported {
        file: file.to_string(),
        line: m.line,
        what: format!(
            "a tool change from T{t} to T{} (its M6 before this line, the first move with the new tool): a deposition program is posted for one tool, and would go on with the first; post each tool's moves as a program of their own",
            m.modal.tool
        ),
    }
}

impl Iterator for Intended<'_> {
    type Item = Result<Step, PostError>;

    fn next(&mut self) -> Option<Self::Item> {
        match self.next_step() {
            Ok(Some(s)) => Some(Ok(s)),
            Ok(None) => None,
            Err(e) => {
                self.done = true;
                Some(Err(e))
            }
        }
    }
}
