//! Modal state and the tables of G and M codes.

use serde::Serialize;

/// Axis letters in the order positions are stored.
pub const AXES: [u8; 9] = *b"XYZABCUVW";
/// True for the rotary axes A, B, C.
pub fn is_rotary(axis: usize) -> bool {
    (3..6).contains(&axis)
}
/// Position of every axis, in [`AXES`] order.
pub type Position = [f64; 9];

/// Axis index of a letter.
pub fn axis_index(letter: u8) -> Option<usize> {
    AXES.iter().position(|&a| a == letter)
}

/// Length units.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Units {
    /// G20 (FADAL G70)
    Inch,
    /// G21 (FADAL G71)
    Mm,
}

impl Units {
    /// Millimetres per unit.
    pub fn mm(self) -> f64 {
        match self {
            Units::Inch => 25.4,
            Units::Mm => 1.0,
        }
    }
}

/// Arc plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Plane {
    /// G17
    XY,
    /// G18
    XZ,
    /// G19
    YZ,
}

impl Plane {
    /// Axis indices (first, second, normal) such that first × second = normal,
    /// so counter-clockwise in (first, second) is G3.
    pub fn axes(self) -> (usize, usize, usize) {
        match self {
            Plane::XY => (0, 1, 2),
            Plane::XZ => (2, 0, 1),
            Plane::YZ => (1, 2, 0),
        }
    }
}

/// G90 / G91.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Distance {
    /// G90
    Absolute,
    /// G91
    Incremental,
}

/// G93 / G94 / G95.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FeedMode {
    /// G94: units per minute.
    PerMinute,
    /// G93: 1/F minutes per move.
    InverseTime,
    /// G95: units per revolution.
    PerRevolution,
}

/// The active motion mode (group 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// None active (start, or after G80).
    None,
    /// G0
    Rapid,
    /// G1
    Linear,
    /// G2
    ArcCw,
    /// G3
    ArcCcw,
    /// G33 spindle-synchronised (traced as straight moves).
    Thread,
    /// G38.x straight probe.
    Probe,
    /// A canned cycle: the code times ten (810 for G81).
    Canned(u16),
}

/// G40 / G41 / G42.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CutterComp {
    /// G40
    Off,
    /// G41
    Left,
    /// G42
    Right,
}

/// Spindle state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Spindle {
    /// M5
    Off,
    /// M3
    Cw,
    /// M4
    Ccw,
}

/// G98 / G99.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Retract {
    /// G98: back to the initial Z.
    InitialZ,
    /// G99: back to the R plane.
    RPlane,
}

/// The active work offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WorkOffset {
    /// G54 = 1 … G59 = 6, G59.1 = 7, G59.2 = 8, G59.3 = 9.
    G5x(u8),
    /// FADAL fixture offset E1 … E48 (E0: none).
    Fixture(u8),
    /// An extended work offset: Fanuc `G54.1 P1`–`P300`, Haas `G154 P1`–`P99` (and its
    /// `G110`–`G129`, which are `G154 P1`–`P20`). Its values live on the control: a
    /// trace stays in program coordinates, as it does for G55.
    Extended(u16),
}

impl WorkOffset {
    /// The work offset a code of the coordinate-system group selects (in tenths: `G54`
    /// 540 … `G59.3` 593); `None` for any other code.
    pub fn of_code(code: u16) -> Option<WorkOffset> {
        Some(WorkOffset::G5x(match code {
            591 => 7,
            592 => 8,
            593 => 9,
            540 | 550 | 560 | 570 | 580 | 590 => ((code - 530) / 10) as u8,
            _ => return None,
        }))
    }
}

impl std::fmt::Display for WorkOffset {
    /// As a program selects it: `G55`, `G59.2`, `E3`, `G54.1 P3`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            WorkOffset::G5x(i @ 1..=6) => write!(f, "G{}", 53 + u32::from(i)),
            WorkOffset::G5x(i) => write!(f, "G59.{}", i.saturating_sub(6)),
            WorkOffset::Fixture(e) => write!(f, "E{e}"),
            WorkOffset::Extended(p) => write!(f, "G54.1 P{p}"),
        }
    }
}

/// The modal state that goes with each move.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Modal {
    /// Group 1.
    pub motion: Motion,
    /// G17/G18/G19.
    pub plane: Plane,
    /// G90/G91.
    pub distance: Distance,
    /// G90.1/G91.1 (arc centres).
    pub arc_distance: Distance,
    /// G93/G94/G95.
    pub feed_mode: FeedMode,
    /// G20/G21.
    pub units: Units,
    /// G40/G41/G42.
    pub cutter_comp: CutterComp,
    /// Tool length offset register (G43 H, FADAL H), `None` after G49.
    pub tool_length: Option<u32>,
    /// G98/G99.
    pub retract: Retract,
    /// G54… or E….
    pub work_offset: WorkOffset,
    /// F as last programmed.
    pub feed: f64,
    /// S as last programmed.
    pub speed: f64,
    /// M3/M4/M5.
    pub spindle: Spindle,
    /// M7 on.
    pub mist: bool,
    /// M8 on.
    pub flood: bool,
    /// Tool selected with T.
    pub selected_tool: u32,
    /// Tool in the spindle (after M6).
    pub tool: u32,
}

impl Modal {
    /// The state at program start.
    pub fn new(units: Units) -> Self {
        Modal {
            motion: Motion::None,
            plane: Plane::XY,
            distance: Distance::Absolute,
            arc_distance: Distance::Incremental,
            feed_mode: FeedMode::PerMinute,
            units,
            cutter_comp: CutterComp::Off,
            tool_length: None,
            retract: Retract::InitialZ,
            work_offset: WorkOffset::G5x(1),
            feed: 0.0,
            speed: 0.0,
            spindle: Spindle::Off,
            mist: false,
            flood: false,
            selected_tool: 0,
            tool: 0,
        }
    }
}

/// The modal group of a G-code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GGroup {
    /// Non-modal codes that use axis words or act once (G4, G10, G28, G30, G92, G31…).
    NonModal,
    /// G53 and G9: modifiers of the block's own move.
    Modifier,
    /// Group 1: motion.
    Motion,
    /// G17/G18/G19.
    Plane,
    /// G90/G91.
    Distance,
    /// G90.1/G91.1.
    ArcDistance,
    /// G93/G94/G95.
    FeedMode,
    /// G20/G21/G70/G71.
    Units,
    /// G40/G41/G42.
    CutterComp,
    /// G43/G44/G49.
    ToolLength,
    /// G98/G99.
    Retract,
    /// G54–G59.3.
    CoordSystem,
    /// G61/G64.
    PathControl,
    /// G96/G97.
    SpindleMode,
    /// G15/G16 polar coordinates (FADAL).
    Polar,
    /// G50/G51 scaling (FADAL).
    Scaling,
    /// G50.1/G51.1 mirroring.
    Mirror,
    /// G68/G69 rotation.
    Rotation,
    /// Codes of real controls that lampost reads but does not model as state (settings,
    /// splines, macro calls, pocket cycles, tilted planes; see [`other_code`]).
    Other,
}

impl GGroup {
    /// Name for messages.
    pub fn name(self) -> &'static str {
        match self {
            GGroup::NonModal => "non-modal",
            GGroup::Modifier => "modifier",
            GGroup::Motion => "motion",
            GGroup::Plane => "plane",
            GGroup::Distance => "distance mode",
            GGroup::ArcDistance => "arc distance mode",
            GGroup::FeedMode => "feed mode",
            GGroup::Units => "units",
            GGroup::CutterComp => "cutter compensation",
            GGroup::ToolLength => "tool length",
            GGroup::Retract => "canned-cycle return",
            GGroup::CoordSystem => "work offset",
            GGroup::PathControl => "path control",
            GGroup::SpindleMode => "spindle speed mode",
            GGroup::Polar => "polar coordinates",
            GGroup::Scaling => "scaling",
            GGroup::Mirror => "mirroring",
            GGroup::Rotation => "coordinate rotation",
            GGroup::Other => "other",
        }
    }
}

/// The drilling cycles G81–G89 and the rigid tapping codes G84.1 and G74.1 (FADAL, as
/// Fusion's FADAL post writes them, after its rigid-tap mode block `G84.2`/`G74.2`),
/// G84.2 and G84.3 (Fanuc: right- and left-hand rigid tapping), given as ten times their
/// number. No other code from G81 to G89.9 is one: `G85.1` or `G82.7` (other controls'
/// variants, whose motion lampost does not know) are unknown, never read as G81.
pub fn is_drill_cycle(code: u16) -> bool {
    matches!(
        code,
        741 | 742 | 810 | 820 | 830 | 840 | 841 | 842 | 843 | 850 | 860 | 870 | 880 | 890
    )
}

/// The group of a G-code given as ten times its number (`G31.1` = 311), or `None` when
/// the code is unknown to both LinuxCNC and the FADAL.
pub fn g_group(code: u16) -> Option<GGroup> {
    use GGroup::*;
    Some(match code {
        0 | 10 | 20 | 30 | 330 | 331 | 382..=385 | 730 | 740 | 760 | 800 => Motion,
        c if is_drill_cycle(c) => Motion,
        40
        | 100
        | 280
        | 281
        | 290
        | 300
        | 301
        | 310
        | 311
        | 450..=480
        | 520
        | 920..=923
        | 1610
        | 1620 => NonModal,
        90 | 530 => Modifier,
        150 | 160 => Polar,
        170 | 180 | 190 => Plane,
        200 | 210 | 700 | 710 => Units,
        400 | 410 | 420 | 411 | 421 => CutterComp,
        430 | 431 | 432 | 440 | 490 => ToolLength,
        500 | 510 => Scaling,
        501 | 511 => Mirror,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => CoordSystem,
        610 | 611 | 640 => PathControl,
        680 | 690 => Rotation,
        900 | 910 => Distance,
        901 | 911 => ArcDistance,
        930 | 940 | 950 => FeedMode,
        960 | 970 => SpindleMode,
        980 | 990 => Retract,
        50..=53
        | 70
        | 80
        | 120
        | 130
        | 434
        | 435
        | 531
        | 541
        | 650
        | 660
        | 670
        | 682..=684
        | 1030
        | 1500
        | 1540
        | 1870
        | 2340
        | 2540
        | 2550
        | 2680
        | 2690 => Other,
        _ => return None,
    })
}

/// How lampost reads a code of [`GGroup::Other`] (given as ten times its number).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OtherCode {
    /// A setting of the control that leaves the path alone: look-ahead and smoothing
    /// (Fanuc `G05 P10000`, `G05.1 Q1`, `G08 P1`, Haas `G103 P1`, `G187 P1 E.01`), radius
    /// mode (LinuxCNC `G8`), modal macro cancel (`G67`), a printer firmware's unretract
    /// `G11` (firmware retraction: the firmware moves the filament, never the head; its
    /// retract `G10` without L is read as G10's tool data, which leaves the path alone
    /// too). The block's words are its own.
    Setting,
    /// A code whose words are its own and that changes the path in a way lampost does not
    /// simulate (macro calls, pocket cycles, tilted planes, tool centre point): a
    /// warning names it, and the post refuses it.
    Unsimulated(&'static str),
    /// LinuxCNC splines `G5` (cubic) and `G5.1` (quadratic), when the block has axis or
    /// I/J words (without them, `G5`/`G5.1` are the Fanuc settings above).
    Spline,
    /// LinuxCNC `G5.2` (NURBS start) and `G5.3` (end).
    Nurbs(bool),
    /// An extended work offset (Fanuc `G54.1 P…`, Haas `G154 P…`, `G110`–`G129`):
    /// selected as [`WorkOffset::Extended`] when its number is one ([`extended_offset`]).
    ExtendedOffset,
    /// LinuxCNC lathe diameter mode `G7`: X words are diameters.
    DiameterMode,
}

/// LinuxCNC's lathe roughing and finishing cycles: G70, G71, G71.1, G71.2, G72, G72.1,
/// G72.2 (ten times their number). Elsewhere G70 and G71 set inch and millimetre units.
pub fn is_lathe_cycle(code: u16) -> bool {
    matches!(code, 700 | 710..=712 | 720..=722)
}

/// Haas codes read as [`GGroup::Other`] with `--flavor haas` (their words are their own,
/// their path is not traced), and what each is.
pub fn haas_pattern(code: u16) -> Option<&'static str> {
    Some(match code {
        470 => "Haas text engraving: its X Y are where the text starts, Z its depth",
        700 | 710 | 720 => "on a Haas mill a bolt hole pattern, whose holes the active canned cycle drills; on a Haas lathe a finishing or roughing cycle",
        _ => return None,
    })
}

/// Haas's additional work offsets G110–G129 (the same as `G154 P1`–`P20`), read as
/// [`GGroup::Other`] with `--flavor haas` and warned as G154 is; not G112 and G113 (a Haas
/// lathe's XY-to-XC interpolation), which stay unknown.
pub fn haas_work_offset(code: u16) -> bool {
    code % 10 == 0 && matches!(code, 1100 | 1110 | 1140..=1290)
}

/// The extended work offset a block selects with code `code` (in tenths) and P word `p`:
/// `G54.1 P1`–`P300` (Fanuc), `G154 P1`–`P99` (Haas), Haas `G110`–`G129` (`G154 P1`–`P20`,
/// no P); `None` for a P that is no such number.
pub fn extended_offset(code: u16, p: Option<f64>) -> Option<u16> {
    let whole = |hi: f64| {
        p.filter(|p| p.fract() == 0.0 && (1.0..=hi).contains(p))
            .map(|p| p as u16)
    };
    match code {
        541 => whole(300.0),
        1540 => whole(99.0),
        c if haas_work_offset(c) => Some(c / 10 - 109),
        _ => None,
    }
}

/// What a code of [`GGroup::Other`] is (`None` for any other code).
pub fn other_code(code: u16) -> Option<OtherCode> {
    use OtherCode::*;
    Some(match code {
        50 | 51 => Spline,
        52 => Nurbs(true),
        53 => Nurbs(false),
        70 => DiameterMode,
        // G11 is no G-code of the machining controls: only a printer program (where an
        // unknown code is the firmware's) reaches here with it.
        // Haas's cancels of its dynamic work offset (G255) and feature coordinates (G269).
        80 | 110 | 670 | 1030 | 1870 | 2550 | 2690 => Setting,
        120 | 130 => Unsimulated("circular pocket milling"),
        // Only a program recognised as a lathe's brings G75 here.
        750 => Unsimulated("a lathe's grooving or cut-off cycle"),
        // Only LinuxCNC's reading brings these here (elsewhere G70/G71 set the units).
        700 | 710..=712 | 720..=722 => Unsimulated("lathe roughing or finishing cycle"),
        434 | 435 => Unsimulated("tool centre point control"),
        531 => Unsimulated("tool axis to the tilted work plane (moves the rotaries)"),
        541 | 1540 => ExtendedOffset,
        c if haas_work_offset(c) => ExtendedOffset,
        650 => Unsimulated("macro call"),
        660 => Unsimulated("modal macro call after every move"),
        682..=684 => Unsimulated("tilted work plane"),
        1500 => Unsimulated("pocket milling cycle"),
        2340 => Unsimulated("Haas tool centre point control, TCPC"),
        2540 => Unsimulated("Haas dynamic work offset, DWO"),
        2680 => Unsimulated("Haas feature coordinates: a tilted work plane"),
        _ => return None,
    })
}

/// The modal group of an M-code, for conflict checks (`None`: no group).
pub fn m_group(code: u16) -> Option<&'static str> {
    match code {
        0 | 10 | 20 | 300 | 600 | 990 => Some("stopping"),
        30 | 40 | 50 => Some("spindle"),
        60 | 610 => Some("tool change"),
        90 => Some("coolant off"),
        480..=530 => Some("override"),
        _ => None,
    }
}

/// True for the M-codes the interpreter acts on (program stops and ends, spindle,
/// tool change, coolant, overrides, subprogram calls and returns, M82/M83 extrusion
/// modes), given as ten times their number. Any other M-code is a *setting* of the
/// control or firmware (`M104 S200`, `M201 X4000`, `M205 X1 Y1 Z1 E1`): in a block with
/// no G-code its words are its own, never positions, feeds or tools.
pub fn m_known(code: u16) -> bool {
    matches!(
        code,
        0 | 10 | 20 | 30 | 40 | 50 | 60 | 70 | 80 | 90 | 300 | 480
            ..=530 | 600 | 610 | 820 | 830 | 970 | 980 | 990
    )
}

/// Whether LinuxCNC (2.9's rs274) has G-code `code` (ten times its number): every other
/// is "Unknown g code used" there, or "G-code out of range" from G100 on, as a sweep of
/// G0–G199.9 through rs274 found (`findings_cli::linuxcnc_refuses_the_g_codes_it_does_not_have`).
pub fn linuxcnc_knows(code: u16) -> bool {
    matches!(
        code,
        0 | 10 | 20 | 30 | 40 | 50 | 51 | 52 | 53 | 70 | 80 | 100 | 170 | 171 | 180 | 181
            | 190 | 191 | 200 | 210 | 280 | 281 | 300 | 301 | 330 | 331 | 382..=385 | 400
            | 410 | 411 | 420 | 421 | 430 | 431 | 432 | 490 | 520 | 530 | 540 | 550 | 560
            | 570 | 580 | 590..=593 | 610 | 611 | 640 | 700 | 710..=712 | 720..=722 | 730
            | 740 | 760 | 800 | 810 | 820 | 830 | 840 | 850 | 860 | 870 | 880 | 890 | 900
            | 901 | 910 | 911 | 920..=923 | 930 | 940 | 950 | 960 | 970 | 980 | 990
    )
}

/// Format a code given as ten times its number: 311 → "31.1", 10 → "1".
pub fn code_text(code: u16) -> String {
    if code % 10 == 0 {
        format!("{}", code / 10)
    } else {
        format!("{}.{}", code / 10, code % 10)
    }
}
