//! LinuxCNC (RS274NGC) parameters and expressions, evaluated for the `linuxcnc` flavour.
//!
//! Only lines the parser marked as macro lines come here (a word whose value starts
//! with `[` or `#`, a line starting with `#`), so plain numeric programs never pay for it.
//!
//! - Parameters: numbered `#1` … `#5601` (0 until set; `#1`–`#30` are a subroutine's
//!   arguments, local to each call), named `#<name>` (local to the subroutine or main
//!   program that sets them; reading one never set is an error), global `#<_name>`;
//!   `#[expr]` and `##1` name a parameter by number. HAL pins `#<_hal[…]>` are refused (only the machine knows them); after each
//!   block `#5420`–`#5428` hold the position, and after a probing move `#5061`–`#5069` its
//!   end and `#5070` 0, as LinuxCNC's standalone `rs274` sets them.
//! - Expressions `[…]`: numbers, parameters, `**`, `*` `/` `MOD`, `+` `-`, `EQ NE GT GE LT
//!   LE`, `AND OR XOR` (that order of precedence, each left to right), unary `-`/`+`,
//!   functions `ABS ACOS ASIN ATAN[a]/[b] COS EXP FIX FUP ROUND LN SIN SQRT TAN` (degrees)
//!   and `EXISTS[#<name>]`. Division by zero, a root or logarithm out of its domain and
//!   any result that is not finite are located errors.
//! - Assignments `#… = value` take effect after the whole line is read (RS274NGC's rule),
//!   in the order written.

use std::collections::HashMap;

use crate::ast::{Block, BlockKind, Comment, CommentStyle, Item, Span, Word};
use crate::diag::{Diagnostic, ErrorKind, Severity};
use crate::parse::{fast_number, MAX_LINE_BYTES};

/// The highest numbered parameter (LinuxCNC's `RS274NGC_MAX_PARAMETERS` − 1).
pub const MAX_PARAM: usize = 5601;
/// A subroutine's argument parameters `#1` … `#30`.
pub const SUB_PARAMS: usize = 30;
/// Expressions nest at most this deep.
const MAX_DEPTH: usize = 64;
/// `EQ` and `NE` compare within this (LinuxCNC's `TOLERANCE_EQUAL`).
const TOLERANCE_EQUAL: f64 = 0.0001;

/// The parameters of one program run.
#[derive(Debug, Clone)]
pub struct Params {
    numbered: Vec<f64>,
    globals: HashMap<String, f64>,
    /// Named locals: the main program's, then one scope per subroutine call.
    locals: Vec<HashMap<String, f64>>,
    /// `#1`–`#30` of each caller, saved at a call.
    saved: Vec<[f64; SUB_PARAMS]>,
    /// Fanuc Macro B variables (see Macro B (`macrob.rs`)), when the flavour reads them.
    pub(crate) fanuc: Option<Box<FanucVars>>,
    /// The interpreter's modal state before the line being evaluated, for LinuxCNC's
    /// predefined named parameters (`#<_metric>`, `#<_feed>`…; see [`predefined`]).
    modal: Option<crate::modal::Modal>,
    /// The machine's numbered parameters ([`machine_parameter`]) the program set itself,
    /// and those read before it did, not yet warned of (taken by
    /// [`Params::take_machine_reads`]) or already warned of.
    machine_set: Vec<usize>,
    machine_reads: std::cell::RefCell<(Vec<usize>, Vec<usize>)>,
}

/// What a LinuxCNC numbered parameter holds that only the machine knows (its tool table,
/// its stored offsets and homes, its inputs), read as 0 here as LinuxCNC's standalone
/// rs274 starts it: `None` for every other.
pub fn machine_parameter(n: usize) -> Option<&'static str> {
    Some(match n {
        5161..=5169 => "G28's home position",
        5181..=5189 => "G30's home position",
        5210 => "whether a G92 offset is in force",
        5211..=5219 => "the G92 offset",
        5221..=5390 => "a work offset (G54 to G59.3) the machine holds",
        5399 => "the result of M66 (an input the machine reads)",
        5401..=5409 => "the tool's offsets in the machine's tool table",
        5410 => "the tool's diameter in the machine's tool table",
        5411..=5413 => "the tool's angles or orientation in the machine's tool table",
        5599 => "the machine's debug switch",
        5600 | 5601 => "the tool changer's fault",
        _ => return None,
    })
}

/// Fanuc Macro B variables: `#1`–`#33` local to each macro level (the main program's,
/// then one per `G65` call), common `#100`–`#199` and `#500`–`#999`; each vacant until set.
#[derive(Debug, Clone)]
pub(crate) struct FanucVars {
    pub(crate) locals: Vec<[Option<f64>; FANUC_LOCALS]>,
    pub(crate) common: Vec<Option<f64>>,
    /// The interpreter's state after the last block, for the system variables.
    state: FanucState,
    /// `#3006` stops met on lines evaluated since they were last taken (warnings).
    stops: Vec<Diagnostic>,
}

/// What the interpreter knows after a block, read through the Fanuc system variables
/// (see [`fanuc_state_var`]).
#[derive(Debug, Clone, Copy)]
struct FanucState {
    modal: crate::modal::Modal,
    /// Whether the program has said its units (G20/G21): before, `#4006` is the
    /// control's power-on setting, unknown here.
    units_given: bool,
    /// Where the last block ended: in the work system in force, and in the machine frame
    /// as the trace knows it (offsets the program sets; those held in the control are 0).
    end: crate::modal::Position,
    machine: crate::modal::Position,
}

/// The Fanuc system variables of the interpreter's state: `Some(Ok(value))`, or
/// `Some(Err(why))` for one the trace cannot know; `None` for a number that is not one of
/// them. `#4001`–`#4120`: the modal state after the last block (`#4001` G00–G03/G33,
/// `#4002` G17–G19, `#4003` G90/G91, `#4005` G93–G95, `#4006` G20/G21, `#4007` G40–G42,
/// `#4008` G49, `#4009` G80 or the canned cycle, `#4010` G98/G99, `#4014` G54–G59; `#4109`
/// F, `#4111` H, `#4119` S, `#4120` T); `#5001`–`#5006` the end of the last block in the
/// work system, `#5021`–`#5026` in the machine frame as traced (X Y Z A B C).
fn fanuc_state_var(n: usize, st: &FanucState) -> Option<Result<f64, &'static str>> {
    Some(match n {
        4001..=4120 => fanuc_modal_var(n, st),
        5001..=5006 => Ok(st.end[n - 5001]),
        5021..=5026 => Ok(st.machine[n - 5021]),
        _ => return None,
    })
}

/// The modal information `#4001`–`#4120` of [`fanuc_state_var`].
fn fanuc_modal_var(n: usize, st: &FanucState) -> Result<f64, &'static str> {
    use crate::modal::{CutterComp, Distance, FeedMode, Motion, Plane, Retract, Units, WorkOffset};
    let m = &st.modal;
    let g = |code: u32| Ok(f64::from(code));
    match n {
        4001 => match m.motion {
            Motion::Rapid => g(0),
            Motion::Linear => g(1),
            Motion::ArcCw => g(2),
            Motion::ArcCcw => g(3),
            Motion::Thread => g(33),
            _ => Err("the group 1 code under a canned cycle, G80 or a probing move is not traced"),
        },
        4002 => g(match m.plane {
            Plane::XY => 17,
            Plane::XZ => 18,
            Plane::YZ => 19,
        }),
        4003 => g(if m.distance == Distance::Absolute {
            90
        } else {
            91
        }),
        4005 => g(match m.feed_mode {
            FeedMode::InverseTime => 93,
            FeedMode::PerMinute => 94,
            FeedMode::PerRevolution => 95,
        }),
        4006 if !st.units_given => {
            Err("the program has not said G20 or G21 yet: the control's power-on units are unknown")
        }
        4006 => g(if m.units == Units::Inch { 20 } else { 21 }),
        4007 => g(match m.cutter_comp {
            CutterComp::Off => 40,
            CutterComp::Left => 41,
            CutterComp::Right => 42,
        }),
        4008 => match m.tool_length {
            None => g(49),
            Some(_) => Err("a tool length offset is on; the trace does not tell G43 from G44"),
        },
        4009 => match m.motion {
            Motion::Canned(c) => Ok(f64::from(c) / 10.0),
            _ => g(80),
        },
        4010 => g(if m.retract == Retract::InitialZ {
            98
        } else {
            99
        }),
        4014 => match m.work_offset {
            WorkOffset::G5x(i @ 1..=6) => g(53 + u32::from(i)),
            _ => Err("the work system in force is no G54-G59"),
        },
        4109 => Ok(m.feed),
        4111 => match m.tool_length {
            Some(h) => g(h),
            None => Err("no tool length offset is on: the last H is not traced"),
        },
        4119 => Ok(m.speed),
        4120 => g(m.selected_tool),
        _ => Err("this modal information is not traced"),
    }
}

/// Fanuc's alarm (`#3000`) and stop-with-message (`#3006`) variables: written, never read.
fn fanuc_message_var(n: usize) -> bool {
    matches!(n, 3000 | 3006)
}

/// The Fanuc system variables a program may read, as the numbered parameters that hold
/// them: `#5041`–`#5046` the position in the work system (after the last block, as
/// LinuxCNC's `#5420`…), `#5061`–`#5066` the skip position of the last G31 (its end:
/// no probe trips in a trace, as LinuxCNC's `#5061`…).
fn fanuc_system(n: usize) -> Option<usize> {
    match n {
        5041..=5046 => Some(5420 + (n - 5041)),
        5061..=5066 => Some(n),
        _ => None,
    }
}

/// Fanuc's local variables `#1`–`#33`.
pub const FANUC_LOCALS: usize = 33;

impl FanucVars {
    fn new() -> Self {
        FanucVars {
            locals: vec![[None; FANUC_LOCALS]],
            common: vec![None; 1000],
            state: FanucState {
                modal: crate::modal::Modal::new(crate::modal::Units::Mm),
                units_given: false,
                end: [0.0; 9],
                machine: [0.0; 9],
            },
            stops: Vec::new(),
        }
    }

    /// The variable `#n`: `None` for a number Macro B does not give programs
    /// (system variables, #34–#99, #200–#499), `Some(None)` for a vacant one.
    pub(crate) fn get(&self, n: usize) -> Option<Option<f64>> {
        match n {
            0 => Some(None),
            1..=FANUC_LOCALS => self.locals.last().map(|l| l[n - 1]),
            100..=199 | 500..=999 => self.common.get(n).copied(),
            _ => None,
        }
    }

    fn set(&mut self, n: usize, v: Option<f64>) -> bool {
        match n {
            1..=FANUC_LOCALS => match self.locals.last_mut() {
                Some(l) => {
                    l[n - 1] = v;
                    true
                }
                None => false,
            },
            100..=199 | 500..=999 => match self.common.get_mut(n) {
                Some(slot) => {
                    *slot = v;
                    true
                }
                None => false,
            },
            _ => false,
        }
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            numbered: vec![0.0; MAX_PARAM + 1],
            globals: HashMap::new(),
            locals: vec![HashMap::new()],
            saved: Vec::new(),
            fanuc: None,
            modal: None,
            machine_set: Vec::new(),
            machine_reads: std::cell::RefCell::new((Vec::new(), Vec::new())),
        }
    }
}

/// Where a parameter lives.
#[derive(Debug, Clone, PartialEq)]
enum Param {
    Numbered(usize),
    Named(String),
}

/// LinuxCNC's names of the position parameters `#5420`–`#5428` (`#<_x>` …).
const POSITION_NAMES: [&str; 9] = ["_x", "_y", "_z", "_a", "_b", "_c", "_u", "_v", "_w"];

/// LinuxCNC's predefined named parameters lampost holds (read only; rs274's values
/// from the modal state, its standalone interpreter's for `_task`), by name.
const PREDEFINED: [&str; 31] = [
    "_motion_mode",
    "_plane",
    "_ccomp",
    "_metric",
    "_imperial",
    "_absolute",
    "_incremental",
    "_inverse_time",
    "_units_per_minute",
    "_units_per_rev",
    "_coord_system",
    "_tool_offset",
    "_retract_r_plane",
    "_retract_old_z",
    "_ijk_absolute_mode",
    "_spindle_on",
    "_spindle_cw",
    "_mist",
    "_flood",
    "_feed",
    "_rpm",
    "_current_tool",
    "_selected_tool",
    "_task",
    "_call_level",
    "_remap_level",
    "_value",
    "_value_returned",
    "_spindle_rpm_mode",
    "_spindle_css_mode",
    "_lathe_radius_mode",
];

/// Read-only names LinuxCNC has that lampost does not hold (they depend on the machine's
/// configuration or switches): refused by name when read, and when set.
const PREDEFINED_UNKNOWN: [&str; 12] = [
    "_vmajor",
    "_vminor",
    "_line",
    "_current_pocket",
    "_selected_pocket",
    "_speed_override",
    "_feed_override",
    "_adaptive_feed",
    "_feed_hold",
    "_lathe_diameter_mode",
    "_abs_x",
    "_abs_y",
];

/// A predefined named parameter's value from the modal state `m` (`None` for a name
/// that is not one of [`PREDEFINED`], or that needs more than the modal state).
fn predefined(name: &str, m: &crate::modal::Modal, call_level: usize) -> Option<f64> {
    use crate::modal::{CutterComp, Distance, FeedMode, Motion, Plane, Retract, Spindle, Units};
    let b = |v: bool| if v { 1.0 } else { 0.0 };
    Some(match name {
        "_motion_mode" => f64::from(match m.motion {
            Motion::Rapid => 0,
            Motion::Linear => 10,
            Motion::ArcCw => 20,
            Motion::ArcCcw => 30,
            Motion::Thread => 330,
            Motion::Probe => 382,
            Motion::Canned(c) => c,
            Motion::None => 800,
        }),
        "_plane" => match m.plane {
            Plane::XY => 170.0,
            Plane::XZ => 180.0,
            Plane::YZ => 190.0,
        },
        "_ccomp" => match m.cutter_comp {
            CutterComp::Off => 400.0,
            CutterComp::Left => 410.0,
            CutterComp::Right => 420.0,
        },
        "_metric" => b(m.units == Units::Mm),
        "_imperial" => b(m.units == Units::Inch),
        "_absolute" => b(m.distance == Distance::Absolute),
        "_incremental" => b(m.distance == Distance::Incremental),
        "_inverse_time" => b(m.feed_mode == FeedMode::InverseTime),
        "_units_per_minute" => b(m.feed_mode == FeedMode::PerMinute),
        "_units_per_rev" => b(m.feed_mode == FeedMode::PerRevolution),
        "_coord_system" => match m.work_offset {
            crate::modal::WorkOffset::G5x(i @ 1..=6) => 530.0 + 10.0 * f64::from(i),
            crate::modal::WorkOffset::G5x(i @ 7..=9) => 584.0 + f64::from(i),
            _ => return None,
        },
        "_tool_offset" => b(m.tool_length.is_some()),
        "_retract_r_plane" => b(m.retract == Retract::RPlane),
        "_retract_old_z" => b(m.retract == Retract::InitialZ),
        "_ijk_absolute_mode" => b(m.arc_distance == Distance::Absolute),
        "_spindle_on" => b(m.spindle != Spindle::Off),
        "_spindle_cw" => b(m.spindle == Spindle::Cw),
        "_mist" => b(m.mist),
        "_flood" => b(m.flood),
        "_feed" => m.feed,
        "_rpm" => m.speed,
        "_current_tool" => f64::from(m.tool),
        "_selected_tool" => f64::from(m.selected_tool),
        // rs274 standalone (and the preview) run with 0; the machine's task with 1.
        "_task" => 0.0,
        "_call_level" => call_level as f64,
        "_remap_level" => 0.0,
        // lampost traces G97 and radius mode (G96 and G7 are named where they stand).
        "_spindle_rpm_mode" | "_lathe_radius_mode" => 1.0,
        "_spindle_css_mode" => 0.0,
        _ => return None,
    })
}

/// Whether `name` (lower case, with its `_`) is one of LinuxCNC's read-only parameters.
fn read_only(name: &str) -> bool {
    (PREDEFINED.contains(&name) && !matches!(name, "_value" | "_value_returned"))
        || PREDEFINED_UNKNOWN.contains(&name)
        || POSITION_NAMES.contains(&name)
}

impl Params {
    /// The parameters of a Fanuc Macro B program (see Macro B (`macrob.rs`)): `#` numbers are
    /// Fanuc's variables, vacant until set.
    pub fn macro_b() -> Self {
        Params {
            fanuc: Some(Box::new(FanucVars::new())),
            ..Params::default()
        }
    }

    /// Whether these are Fanuc Macro B variables.
    pub fn is_macro_b(&self) -> bool {
        self.fanuc.is_some()
    }

    /// A Fanuc variable (`None`: vacant, or not a variable programs have).
    pub fn fanuc_var(&self, n: usize) -> Option<f64> {
        self.fanuc.as_ref().and_then(|f| f.get(n)).flatten()
    }

    /// Note the interpreter's state, for Fanuc's system variables (`#4001`…, `#5001`…,
    /// `#5021`…): the stream calls it before it evaluates a Macro B line (so plain lines
    /// pay nothing); nothing for other flavours.
    pub fn after_block(&mut self, interp: &crate::interp::Interpreter) {
        if let Some(f) = self.fanuc.as_mut() {
            f.state = FanucState {
                modal: *interp.modal(),
                units_given: interp.units_given(),
                end: interp.program_position(),
                machine: *interp.position(),
            };
        }
    }

    /// Note the interpreter's modal state, for LinuxCNC's predefined named parameters:
    /// the stream calls it before it evaluates a LinuxCNC macro or O-word line.
    pub fn note_modal(&mut self, interp: &crate::interp::Interpreter) {
        if self.fanuc.is_none() {
            self.modal = Some(*interp.modal());
        }
    }

    /// The `#3006` stops (warnings) of the lines evaluated since the last call.
    pub fn take_stops(&mut self) -> Vec<Diagnostic> {
        self.fanuc
            .as_mut()
            .map(|f| std::mem::take(&mut f.stops))
            .unwrap_or_default()
    }

    /// Enter a `G65` macro: a new level of locals `#1`–`#33` holding `args`.
    pub(crate) fn enter_macro(&mut self, args: [Option<f64>; FANUC_LOCALS]) {
        if let Some(f) = self.fanuc.as_mut() {
            f.locals.push(args);
        }
    }

    /// Leave a `G65` macro: the caller's locals come back.
    pub(crate) fn leave_macro(&mut self) {
        if let Some(f) = self.fanuc.as_mut() {
            if f.locals.len() > 1 {
                f.locals.pop();
            }
        }
    }

    /// A numbered parameter.
    pub fn get(&self, n: usize) -> Option<f64> {
        self.numbered.get(n).copied()
    }

    /// A numbered parameter as a LinuxCNC program reads it: `#5220` the coordinate
    /// system in force (1 for G54 … 9 for G59.3), `#5400` the tool in the spindle, from
    /// the modal state; a [`machine_parameter`] the program has not set is noted for a
    /// warning ([`Params::take_machine_reads`]) and read as 0.
    fn read_numbered(&self, n: usize) -> f64 {
        if let Some(m) = &self.modal {
            match (n, m.work_offset) {
                (5220, crate::modal::WorkOffset::G5x(i)) => return f64::from(i),
                (5400, _) => return f64::from(m.tool),
                _ => {}
            }
        }
        if machine_parameter(n).is_some() && !self.machine_set.contains(&n) {
            let mut r = self.machine_reads.borrow_mut();
            if !r.1.contains(&n) {
                r.1.push(n);
                r.0.push(n);
            }
        }
        self.get(n).unwrap_or(0.0)
    }

    /// The machine's parameters read since the last call, each once a program, for a
    /// warning: their values here are 0, the machine's are its own.
    pub fn take_machine_reads(&mut self) -> Vec<usize> {
        std::mem::take(&mut self.machine_reads.get_mut().0)
    }

    /// A named parameter (name without `#<>`, any case). A HAL pin (`#<_hal[…]>`) is
    /// known only on the machine: never set here, as in LinuxCNC's standalone rs274
    /// ("Named parameter #<_hal[…]> not defined").
    pub fn named(&self, name: &str) -> Option<f64> {
        let name = name.to_ascii_lowercase();
        if name.starts_with("_hal[") {
            return None;
        }
        if name.starts_with('_') {
            // `#<_x>` … `#<_w>`: the position, LinuxCNC's aliases of `#5420`–`#5428`.
            if let Some(i) = POSITION_NAMES.iter().position(|&n| n == name) {
                return Some(self.numbered[5420 + i]);
            }
            if let Some(v) = self.modal.as_ref().and_then(|m| {
                (!matches!(name.as_str(), "_value" | "_value_returned"))
                    .then(|| predefined(&name, m, self.saved.len()))
                    .flatten()
            }) {
                return Some(v);
            }
            self.globals.get(&name).copied()
        } else {
            self.locals.last().and_then(|m| m.get(&name)).copied()
        }
    }

    /// Set a named parameter.
    pub fn set_named(&mut self, name: &str, v: f64) {
        let name = name.to_ascii_lowercase();
        if name.starts_with('_') {
            self.globals.insert(name, v);
        } else if let Some(m) = self.locals.last_mut() {
            m.insert(name, v);
        }
    }

    /// Set a parameter; `None` makes a Fanuc variable vacant.
    fn set_value(&mut self, p: &Param, v: Option<f64>) {
        if let (Some(f), Param::Numbered(n)) = (self.fanuc.as_mut(), p) {
            f.set(*n, v);
            return;
        }
        let Some(v) = v else { return };
        match p {
            Param::Numbered(n) => {
                if let Some(slot) = self.numbered.get_mut(*n) {
                    *slot = v;
                }
                if machine_parameter(*n).is_some() && !self.machine_set.contains(n) {
                    self.machine_set.push(*n);
                }
            }
            Param::Named(name) => self.set_named(name, v),
        }
    }

    /// Note what the machine would have set after a block's moves (LinuxCNC's system
    /// parameters as its standalone interpreter sets them): `#5420`–`#5428` the position
    /// (program coordinates), and after a probing move `#5061`–`#5069` its end and
    /// `#5070` 0 (lampost has no probe that trips).
    pub fn after_moves<'m>(&mut self, moves: impl Iterator<Item = &'m crate::interp::Move>) {
        for m in moves {
            self.numbered[5420..5429].copy_from_slice(&m.end);
            if m.kind == crate::interp::MoveKind::Probe {
                self.numbered[5061..5070].copy_from_slice(&m.end);
                self.numbered[5070] = 0.0;
            }
        }
    }

    /// Note the position (program coordinates) in `#5420`–`#5428`: a lathe profile
    /// cycle's subroutine sees its profile's current point there (`lathe.rs`).
    pub(crate) fn note_position(&mut self, p: &crate::modal::Position) {
        self.numbered[5420..5429].copy_from_slice(p);
    }

    /// Enter a subroutine: the caller's `#1`–`#30` are saved, the arguments take their
    /// place (0 for those not given), and a new scope of named locals opens.
    pub fn enter(&mut self, args: &[f64]) {
        let mut keep = [0.0; SUB_PARAMS];
        keep.copy_from_slice(&self.numbered[1..=SUB_PARAMS]);
        self.saved.push(keep);
        for i in 0..SUB_PARAMS {
            self.numbered[1 + i] = args.get(i).copied().unwrap_or(0.0);
        }
        self.locals.push(HashMap::new());
    }

    /// Leave a subroutine: the caller's `#1`–`#30` and named locals come back, and
    /// `#<_value>` holds the returned value (`#<_value_returned>` says whether there is one).
    pub fn leave(&mut self, value: Option<f64>) {
        if let Some(keep) = self.saved.pop() {
            self.numbered[1..=SUB_PARAMS].copy_from_slice(&keep);
        }
        if self.locals.len() > 1 {
            self.locals.pop();
        }
        self.globals.insert("_value".into(), value.unwrap_or(0.0));
        self.globals.insert(
            "_value_returned".into(),
            if value.is_some() { 1.0 } else { 0.0 },
        );
    }
}

/// An evaluation error: message and byte range in the text evaluated.
pub type EvalError = (String, usize, usize);

/// A reader of values and expressions over one line.
#[derive(Debug)]
pub struct Eval<'t, 'p> {
    b: &'t [u8],
    /// Where reading stands.
    pub pos: usize,
    params: &'p Params,
    depth: usize,
    /// The value just read is a vacant Fanuc variable, alone (`#1`, `-#1`, `[#1]`).
    pub vacant: bool,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Op {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl Op {
    /// RS274NGC's precedence, or Fanuc's (`macro_b`: AND with the products, OR and XOR
    /// with the sums, comparisons last).
    fn precedence(self, macro_b: bool) -> u8 {
        match self {
            Op::Pow => 6,
            Op::Mul | Op::Div | Op::Mod => 5,
            Op::And if macro_b => 5,
            Op::Add | Op::Sub => 4,
            Op::Or | Op::Xor if macro_b => 4,
            Op::Eq | Op::Ne | Op::Gt | Op::Ge | Op::Lt | Op::Le => 3,
            Op::And | Op::Or | Op::Xor => 2,
        }
    }
}

fn finite(v: f64, what: &str, s: usize, e: usize) -> Result<f64, EvalError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err((format!("{what} has no finite value"), s, e))
    }
}

/// An angle from `atan2` (degrees, −180 to 180) in Fanuc's range, 0 to 360 (360 itself,
/// from a tiny negative angle, is 0).
fn fanuc_angle(deg: f64) -> f64 {
    let d = if deg < 0.0 { deg + 360.0 } else { deg + 0.0 };
    if d >= 360.0 {
        0.0
    } else {
        d
    }
}

impl<'t, 'p> Eval<'t, 'p> {
    /// A reader of `text` from byte `pos`, reading `params`.
    pub fn new(text: &'t str, pos: usize, params: &'p Params) -> Self {
        Eval {
            b: text.as_bytes(),
            pos,
            params,
            depth: 0,
            vacant: false,
        }
    }

    fn macro_b(&self) -> bool {
        self.params.fanuc.is_some()
    }

    pub(crate) fn skip(&mut self) {
        while self.pos < self.b.len() && matches!(self.b[self.pos], b' ' | b'\t') {
            self.pos += 1;
        }
    }

    pub(crate) fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.b.get(self.pos).copied()
    }

    /// Whether a value follows (anything but the end of the line or a comment).
    pub fn peek_value(&mut self) -> bool {
        !matches!(self.peek(), None | Some(b'(' | b';'))
    }

    fn text(&self, s: usize, e: usize) -> String {
        String::from_utf8_lossy(&self.b[s..e.min(self.b.len())]).into_owned()
    }

    /// A parameter reference after its `#` (at `self.pos`).
    fn param_ref(&mut self) -> Result<Param, EvalError> {
        let start = self.pos;
        self.skip();
        match self.b.get(self.pos) {
            Some(b'<') if self.macro_b() => Err((
                "`#<name>` is LinuxCNC's; Macro B variables are numbered".into(),
                start,
                self.pos + 1,
            )),
            Some(b'<') => {
                let close = memchr::memchr(b'>', &self.b[self.pos..])
                    .ok_or_else(|| ("`#<` has no closing `>`".to_string(), start, self.b.len()))?;
                let name: String = self
                    .text(self.pos + 1, self.pos + close)
                    .chars()
                    .filter(|c| !c.is_whitespace())
                    .collect::<String>()
                    .to_ascii_lowercase();
                self.pos += close + 1;
                if name.is_empty() {
                    return Err(("a parameter name is empty".into(), start, self.pos));
                }
                Ok(Param::Named(name))
            }
            _ => {
                let v = self.value()?;
                let n = crate::emit::round_half_away(v);
                if let Some(f) = self.params.fanuc.as_deref() {
                    if (v - n).abs() > 1e-6
                        || !(0.0..=MAX_PARAM as f64).contains(&n)
                        || f.get(n as usize).is_none()
                            && fanuc_system(n as usize).is_none()
                            && fanuc_state_var(n as usize, &f.state).is_none()
                            && !fanuc_message_var(n as usize)
                    {
                        return Err((
                            format!(
                                "#{}: Macro B variables are #0 (vacant), #1-#33 (local), #100-#199 and #500-#999 (common), the alarm and stop #3000 and #3006, the modal information #4001-#4120, and the positions #5001-#5006, #5021-#5026, #5041-#5046 and #5061-#5066; other system variables are not evaluated",
                                self.text(start, self.pos)
                            ),
                            start,
                            self.pos,
                        ));
                    }
                    self.vacant = false;
                    return Ok(Param::Numbered(n as usize));
                }
                if (v - n).abs() > 1e-6 || !(0.0..=MAX_PARAM as f64).contains(&n) {
                    return Err((
                        format!(
                            "#{}: parameter numbers are whole numbers 0 to {MAX_PARAM}",
                            self.text(start, self.pos)
                        ),
                        start,
                        self.pos,
                    ));
                }
                Ok(Param::Numbered(n as usize))
            }
        }
    }

    fn read_param(&mut self, p: &Param, s: usize, e: usize) -> Result<f64, EvalError> {
        if let (Some(f), Param::Numbered(n)) = (self.params.fanuc.as_deref(), p) {
            // Vacant reads as 0 in arithmetic; `vacant` tells the callers that care
            // (a word's value, an assignment, EQ and NE).
            let v = match (fanuc_system(*n), fanuc_state_var(*n, &f.state)) {
                (Some(k), _) => self.params.numbered.get(k).copied(),
                (None, Some(known)) => {
                    Some(known.map_err(|why| (format!("#{n} is not known here: {why}"), s, e))?)
                }
                (None, None) if fanuc_message_var(*n) => {
                    return Err((
                        format!("#{n} is written (`#{n} = n (MESSAGE)`), not read"),
                        s,
                        e,
                    ))
                }
                (None, None) => f.get(*n).flatten(),
            };
            self.vacant = v.is_none();
            return Ok(v.unwrap_or(0.0));
        }
        match p {
            Param::Numbered(n) => Ok(self.params.read_numbered(*n)),
            Param::Named(name) => self.params.named(name).ok_or_else(|| {
                let what = if name.to_ascii_lowercase().starts_with("_hal[") {
                    format!("#<{name}> is a HAL pin, whose value only the running machine knows (QtPlasmaC's programs read their cut feed rate and heights from such pins); LinuxCNC's standalone rs274 refuses it too: write the pin's value in its place")
                } else if PREDEFINED_UNKNOWN.contains(&name.to_ascii_lowercase().as_str()) {
                    format!("#<{name}> is one of LinuxCNC's predefined parameters whose value depends on the machine (its configuration, switches or tool table), which lampost does not hold: write the value in its place")
                } else {
                    format!("parameter #<{name}> is not set")
                };
                (what, s, e)
            }),
        }
    }

    /// A real value: a number, a parameter, an expression `[…]`, a function, with an
    /// optional sign.
    pub fn value(&mut self) -> Result<f64, EvalError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(("expressions nest too deep".into(), self.pos, self.b.len()));
        }
        self.vacant = false;
        let r = self.value_inner();
        self.depth -= 1;
        r
    }

    /// An expression to the end of the line (or a comment), without brackets: the
    /// right-hand side of a Fanuc assignment (`#1 = #1 + 1`).
    pub fn bare_expression(&mut self) -> Result<f64, EvalError> {
        self.expression_until(true, false)
    }

    fn value_inner(&mut self) -> Result<f64, EvalError> {
        let start = {
            self.skip();
            self.pos
        };
        match self.b.get(self.pos).copied() {
            Some(b'-') => {
                self.pos += 1;
                // `-#1` of a vacant #1 stays vacant (`vacant` is left as read).
                Ok(-self.value()?)
            }
            Some(b'+') => {
                self.pos += 1;
                self.value()
            }
            Some(b'[') => self.bracket(),
            Some(b'#') => {
                self.pos += 1;
                let p = self.param_ref()?;
                self.read_param(&p, start, self.pos)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => match fast_number(&self.b[self.pos..]) {
                Some((len, v)) => {
                    self.pos += len;
                    Ok(v)
                }
                None => {
                    let len = self.b[self.pos..]
                        .iter()
                        .take_while(|c| c.is_ascii_digit() || **c == b'.')
                        .count();
                    let t = self.text(self.pos, self.pos + len);
                    self.pos += len;
                    t.parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| (format!("cannot read the number `{t}`"), start, self.pos))
                }
            },
            Some(c) if c.is_ascii_alphabetic() => self.function(),
            Some(c) => Err((
                format!("expected a value, found `{}`", char::from(c)),
                start,
                start + 1,
            )),
            None => Err((
                "expected a value at the end of the line".into(),
                start,
                start,
            )),
        }
    }

    /// `[ expression ]` at `self.pos`.
    fn bracket(&mut self) -> Result<f64, EvalError> {
        let open = self.pos;
        self.pos += 1;
        let v = self.expression()?;
        if self.peek() != Some(b']') {
            return Err((
                "`[` is not closed by `]`".into(),
                open,
                self.pos.max(open + 1),
            ));
        }
        self.pos += 1;
        Ok(v)
    }

    fn op(&mut self) -> Option<Op> {
        let c = self.peek()?;
        let two = self.b.get(self.pos + 1).copied().unwrap_or(0);
        let (op, len) = match c {
            b'*' if two == b'*' => (Op::Pow, 2),
            b'*' => (Op::Mul, 1),
            b'/' => (Op::Div, 1),
            b'+' => (Op::Add, 1),
            b'-' => (Op::Sub, 1),
            _ => {
                let word: Vec<u8> = self.b[self.pos..]
                    .iter()
                    .take(3)
                    .take_while(|c| c.is_ascii_alphabetic())
                    .map(u8::to_ascii_uppercase)
                    .collect();
                match &word[..] {
                    [b'M', b'O', b'D'] => (Op::Mod, 3),
                    [b'A', b'N', b'D'] => (Op::And, 3),
                    [b'X', b'O', b'R'] => (Op::Xor, 3),
                    [b'O', b'R', ..] => (Op::Or, 2),
                    [b'E', b'Q', ..] => (Op::Eq, 2),
                    [b'N', b'E', ..] => (Op::Ne, 2),
                    [b'G', b'T', ..] => (Op::Gt, 2),
                    [b'G', b'E', ..] => (Op::Ge, 2),
                    [b'L', b'T', ..] => (Op::Lt, 2),
                    [b'L', b'E', ..] => (Op::Le, 2),
                    _ => return None,
                }
            }
        };
        self.pos += len;
        Some(op)
    }

    /// An expression inside brackets (without them): operators by precedence, each
    /// left to right (RS274NGC).
    fn expression(&mut self) -> Result<f64, EvalError> {
        self.expression_until(false, false)
    }

    /// An expression ended by `]` or, when `bare`, by the end of the line or a comment.
    /// An expression to `]` (with `bare`, to the end of the line or a comment; with
    /// `comma`, also to a `,`: the first value of Fanuc's `ATAN[a,b]`).
    fn expression_until(&mut self, bare: bool, comma: bool) -> Result<f64, EvalError> {
        self.skip();
        let start = self.pos;
        let mb = self.macro_b();
        let first = self.value()?;
        let mut vacant = vec![self.vacant];
        let mut values: Vec<f64> = vec![first];
        let mut ops: Vec<Op> = Vec::new();
        loop {
            let at = self.pos;
            if self.peek() == Some(b']')
                || bare && !self.peek_value()
                || comma && self.peek() == Some(b',')
            {
                break;
            }
            let Some(op) = self.op() else {
                let c = self.peek();
                return Err(match c {
                    None => ("`[` is not closed by `]`".into(), start, self.b.len()),
                    Some(c) => (
                        format!("expected an operator or `]`, found `{}`", char::from(c)),
                        self.pos,
                        self.pos + 1,
                    ),
                });
            };
            while let Some(&top) = ops.last() {
                if top.precedence(mb) >= op.precedence(mb) {
                    ops.pop();
                    let (r, rv) = (values.pop().unwrap_or(0.0), vacant.pop().unwrap_or(false));
                    let (l, lv) = (values.pop().unwrap_or(0.0), vacant.pop().unwrap_or(false));
                    values.push(apply(top, (l, lv), (r, rv), mb, start, at)?);
                    vacant.push(false);
                } else {
                    break;
                }
            }
            ops.push(op);
            values.push(self.value()?);
            vacant.push(self.vacant);
        }
        let end = self.pos;
        while let Some(top) = ops.pop() {
            let (r, rv) = (values.pop().unwrap_or(0.0), vacant.pop().unwrap_or(false));
            let (l, lv) = (values.pop().unwrap_or(0.0), vacant.pop().unwrap_or(false));
            values.push(apply(top, (l, lv), (r, rv), mb, start, end)?);
            vacant.push(false);
        }
        self.vacant = vacant.pop().unwrap_or(false);
        Ok(values.pop().unwrap_or(0.0))
    }

    /// Fanuc's `ATAN` (at its `[`; `start` at its name): `ATAN[a]` (degrees, −90 to 90),
    /// and the two-argument `ATAN[a]/[b]` and `ATAN[a,b]`, the angle of the point (b, a)
    /// in degrees from 0 to 360 (Fanuc's convention: `ATAN[-1]/[-1]` is 225); `[0]/[0]`
    /// has no angle and is an error.
    fn fanuc_atan(&mut self, start: usize) -> Result<f64, EvalError> {
        let open = self.pos;
        self.pos += 1;
        let a = self.expression_until(false, true)?;
        let b = if self.peek() == Some(b',') {
            self.pos += 1;
            Some(self.expression()?)
        } else {
            None
        };
        if self.peek() != Some(b']') {
            return Err((
                "`[` is not closed by `]`".into(),
                open,
                self.pos.max(open + 1),
            ));
        }
        self.pos += 1;
        let b = match b {
            Some(b) => Some(b),
            None if self.peek() == Some(b'/') => {
                self.pos += 1;
                if self.peek() != Some(b'[') {
                    return Err(("ATAN[a]/ takes [b]: ATAN[a]/[b]".into(), start, self.pos));
                }
                Some(self.bracket()?)
            }
            None => None,
        };
        let Some(b) = b else {
            return Ok(a.atan().to_degrees());
        };
        if a == 0.0 && b == 0.0 {
            return Err((
                "ATAN of the point (0, 0) has no angle".into(),
                start,
                self.pos,
            ));
        }
        Ok(fanuc_angle(a.atan2(b).to_degrees()))
    }

    fn function(&mut self) -> Result<f64, EvalError> {
        let start = self.pos;
        let len = self.b[self.pos..]
            .iter()
            .take_while(|c| c.is_ascii_alphabetic())
            .count();
        let name = self.text(self.pos, self.pos + len).to_ascii_uppercase();
        self.pos += len;
        if self.peek() != Some(b'[') {
            return Err((
                format!("expected a value, found `{name}`"),
                start,
                start + len,
            ));
        }
        if name == "EXISTS" {
            let open = self.pos;
            self.pos += 1;
            self.skip();
            if self.b.get(self.pos) != Some(&b'#') {
                return Err((
                    "EXISTS takes a named parameter: EXISTS[#<name>]".into(),
                    open,
                    self.pos + 1,
                ));
            }
            self.pos += 1;
            let p = self.param_ref()?;
            if self.peek() != Some(b']') {
                return Err(("`[` is not closed by `]`".into(), open, self.pos));
            }
            self.pos += 1;
            return Ok(match p {
                Param::Named(n) => f64::from(u8::from(self.params.named(&n).is_some())),
                Param::Numbered(_) => 1.0,
            });
        }
        if name == "ATAN" && self.macro_b() {
            return self.fanuc_atan(start);
        }
        let a = self.bracket()?;
        let end = self.pos;
        let domain = |ok: bool| {
            if ok {
                Ok(())
            } else {
                Err((
                    format!("{name}[{a}] is outside the function's domain"),
                    start,
                    end,
                ))
            }
        };
        let v = match name.as_str() {
            "ABS" => a.abs(),
            "ACOS" => {
                domain((-1.0..=1.0).contains(&a))?;
                a.acos().to_degrees()
            }
            "ASIN" => {
                domain((-1.0..=1.0).contains(&a))?;
                a.asin().to_degrees()
            }
            "ATAN" => {
                if self.peek() != Some(b'/') {
                    return Err(("ATAN takes two values: ATAN[y]/[x]".into(), start, self.pos));
                }
                self.pos += 1;
                if self.peek() != Some(b'[') {
                    return Err(("ATAN takes two values: ATAN[y]/[x]".into(), start, self.pos));
                }
                let x = self.bracket()?;
                a.atan2(x).to_degrees()
            }
            "COS" => a.to_radians().cos(),
            "SIN" => a.to_radians().sin(),
            "TAN" => a.to_radians().tan(),
            "EXP" => a.exp(),
            // Fanuc: FIX drops the fraction, FUP raises it to 1, both away from 0's
            // side as written (FIX[-1.2] = -1, FUP[-1.2] = -2).
            "FIX" if self.macro_b() => a.trunc(),
            "FUP" if self.macro_b() => {
                if a.fract() == 0.0 {
                    a
                } else {
                    a.trunc() + a.signum()
                }
            }
            "BIN" | "BCD" if self.macro_b() => bcd(&name, a, start, end)?,
            "FIX" => a.floor(),
            "FUP" => a.ceil(),
            "ROUND" => crate::emit::round_half_away(a),
            "LN" => {
                domain(a > 0.0)?;
                a.ln()
            }
            "SQRT" => {
                domain(a >= 0.0)?;
                a.sqrt()
            }
            _ => return Err((format!("unknown function {name}"), start, start + len)),
        };
        finite(v, &name, start, self.pos)
    }
}

fn apply(
    op: Op,
    (l, lv): (f64, bool),
    (r, rv): (f64, bool),
    macro_b: bool,
    s: usize,
    e: usize,
) -> Result<f64, EvalError> {
    let b = |x: bool| if x { 1.0 } else { 0.0 };
    if macro_b {
        // Fanuc: EQ and NE tell a vacant variable from 0 and compare exactly; AND, OR and
        // XOR work bit by bit on whole numbers.
        match op {
            Op::Eq | Op::Ne => {
                let same = if lv || rv { lv && rv } else { l == r };
                return Ok(b(same == (op == Op::Eq)));
            }
            Op::And | Op::Or | Op::Xor => {
                let whole = |x: f64| x.fract() == 0.0 && x.abs() <= 2f64.powi(31);
                if !(whole(l) && whole(r)) {
                    return Err((
                        "AND, OR and XOR take whole numbers (bit by bit)".into(),
                        s,
                        e,
                    ));
                }
                let (a, c) = (l as i64, r as i64);
                return Ok(match op {
                    Op::And => a & c,
                    Op::Or => a | c,
                    _ => a ^ c,
                } as f64);
            }
            _ => {}
        }
    }
    let v = match op {
        Op::Pow => l.powf(r),
        Op::Mul => l * r,
        Op::Div => {
            if r == 0.0 {
                return Err(("division by zero".into(), s, e));
            }
            l / r
        }
        Op::Mod => {
            if r == 0.0 {
                return Err(("MOD by zero".into(), s, e));
            }
            let m = l % r;
            if m < 0.0 {
                m + r.abs()
            } else {
                m
            }
        }
        Op::Add => l + r,
        Op::Sub => l - r,
        Op::Eq => b((l - r).abs() < TOLERANCE_EQUAL),
        Op::Ne => b((l - r).abs() >= TOLERANCE_EQUAL),
        Op::Gt => b(l > r),
        Op::Ge => b(l >= r),
        Op::Lt => b(l < r),
        Op::Le => b(l <= r),
        Op::And => b(l != 0.0 && r != 0.0),
        Op::Or => b(l != 0.0 || r != 0.0),
        Op::Xor => b((l != 0.0) != (r != 0.0)),
    };
    finite(v, "the expression", s, e)
}

/// Fanuc's BIN (binary-coded decimal to binary) and BCD (binary to BCD), on whole
/// numbers 0 to 99,999,999.
fn bcd(name: &str, a: f64, s: usize, e: usize) -> Result<f64, EvalError> {
    if !(a >= 0.0 && a.fract() == 0.0 && a <= 99_999_999.0) {
        return Err((
            format!("{name}[{a}]: takes a whole number 0 to 99999999"),
            s,
            e,
        ));
    }
    let mut n = a as u64;
    let mut out = 0u64;
    let mut shift = 0u32;
    if name == "BCD" {
        while n > 0 {
            out |= (n % 10) << shift;
            n /= 10;
            shift += 4;
        }
    } else {
        let mut place = 1u64;
        while n > 0 {
            let digit = n & 0xF;
            if digit > 9 {
                return Err((format!("BIN[{a}]: not binary-coded decimal"), s, e));
            }
            out += digit * place;
            place *= 10;
            n >>= 4;
        }
    }
    Ok(out as f64)
}

/// Whether a macro line that is not evaluated sets the feed rate from a macro value
/// (`F#1`, `F[#2*3]`, FADAL `F+R4.`, `#F = …` is not one): the block is skipped with its
/// warning, and later feed moves are not blamed for a missing F.
pub fn sets_feed(raw: &str) -> bool {
    let b = raw.as_bytes();
    let mut depth = 0usize;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'(' => {
                i += memchr::memchr(b')', &b[i..]).unwrap_or(b.len() - i);
            }
            b';' | b'\'' => return false,
            b'[' => depth += 1,
            b']' => depth = depth.saturating_sub(1),
            b'F' | b'f' if depth == 0 && (i == 0 || !b[i - 1].is_ascii_alphabetic()) => {
                let mut k = i + 1;
                while k < b.len() && matches!(b[k], b' ' | b'\t' | b'+' | b'-') {
                    k += 1;
                }
                if b.get(k)
                    .is_some_and(|c| matches!(c, b'#' | b'[' | b'R' | b'r' | b'V' | b'v'))
                {
                    return true;
                }
            }
            _ => {}
        }
        i += 1;
    }
    false
}

/// Evaluate a whole macro line of the `linuxcnc` flavour into `block`: words whose
/// values are expressions or parameters get their values (each word's `text` is the
/// value as written, `[#1+2]`), comments are kept, and parameter assignments
/// (`#1 = …`, `#<name> = …`) are made after the whole line is read. The block becomes a
/// plain word block for the interpreter.
pub fn eval_line<'a>(
    line: &'a [u8],
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    params: &mut Params,
) -> Result<(), Diagnostic> {
    let err = |(msg, s, e): EvalError| {
        Diagnostic::at(
            Severity::Error,
            ErrorKind::Expression(msg),
            line_no,
            offset,
            line,
            s,
            e,
        )
    };
    block.kind = BlockKind::Words;
    block.items.clear();
    if line.len() > MAX_LINE_BYTES {
        return Err(err(("line too long".into(), 0, 1)));
    }
    let text = std::str::from_utf8(line).map_err(|_| err(("not UTF-8".into(), 0, 1)))?;
    let bytes = line;
    let macro_b = params.is_macro_b();
    let mut sets: Vec<(Param, Option<f64>)> = Vec::new();
    let mut seen: u32 = 0;
    let mut i = 0;
    while i < bytes.len() && matches!(bytes[i], b' ' | b'\t') {
        i += 1;
    }
    if bytes.get(i) == Some(&b'/') {
        block.block_delete = true;
        i += 1;
    }
    while i < bytes.len() {
        let c = bytes[i];
        match c {
            b' ' | b'\t' => i += 1,
            b'(' => match memchr::memchr(b')', &bytes[i + 1..]) {
                Some(rel) => {
                    let end = i + 1 + rel;
                    block.items.push(Item::Comment(Comment {
                        text: &text[i + 1..end],
                        style: CommentStyle::Paren,
                        span: Span::new(offset + i, offset + end + 1),
                    }));
                    i = end + 1;
                }
                None => {
                    return Err(Diagnostic::at(
                        Severity::Error,
                        ErrorKind::UnterminatedComment,
                        line_no,
                        offset,
                        line,
                        i,
                        bytes.len(),
                    ))
                }
            },
            b';' => {
                block.items.push(Item::Comment(Comment {
                    text: &text[i + 1..],
                    style: CommentStyle::Semicolon,
                    span: Span::new(offset + i, offset + bytes.len()),
                }));
                i = bytes.len();
            }
            b'#' => {
                let start = i;
                let mut ev = Eval::new(text, i + 1, params);
                let p = ev.param_ref().map_err(err)?;
                if ev.peek() != Some(b'=') {
                    return Err(err((
                        "a parameter at the start of a word needs `= value`".into(),
                        start,
                        ev.pos.max(start + 1),
                    )));
                }
                ev.pos += 1;
                // Fanuc writes the right-hand side without brackets (`#1 = #1 + 1`), and
                // a vacant variable alone copies its vacancy (`#2 = #1`).
                let v = if macro_b {
                    ev.bare_expression().map_err(err)?
                } else {
                    ev.value().map_err(err)?
                };
                i = ev.pos;
                let vacant = ev.vacant;
                if let (true, Param::Numbered(n)) = (macro_b, &p) {
                    let n = *n;
                    if fanuc_message_var(n) {
                        message_var(text, line_no, offset, params, (n, v), (start, i))?;
                        continue;
                    }
                    if params.fanuc.as_deref().and_then(|f| f.get(n)).is_none() {
                        return Err(err((
                            format!("#{n} is a system variable: read only"),
                            start,
                            i,
                        )));
                    }
                }
                let fixed = match &p {
                    Param::Named(n) => read_only(n),
                    Param::Numbered(n) => !macro_b && (5420..=5428).contains(n),
                };
                if fixed {
                    return Err(err((
                        format!(
                            "{} is read only (one of LinuxCNC's predefined parameters; rs274 refuses to set it)",
                            &text[start..i].split('=').next().unwrap_or("").trim()
                        ),
                        start,
                        i,
                    )));
                }
                sets.push((p, (!vacant).then_some(v)));
            }
            // Words; in LinuxCNC's reading also its polar coordinates, `@` (radius) and
            // `^` (angle).
            b'a'..=b'z' | b'A'..=b'Z' | b'@' | b'^' if c.is_ascii_alphabetic() || !macro_b => {
                let letter = c.to_ascii_uppercase();
                let mut ev = Eval::new(text, i + 1, params);
                ev.skip();
                let vstart = ev.pos;
                let v = ev.value().map_err(err)?;
                let end = ev.pos;
                if ev.vacant {
                    // Fanuc: a word whose value is a vacant variable is left out.
                    block.vacant |= crate::parse::letter_bit(letter);
                    i = end;
                    continue;
                }
                if letter != b'G' && letter != b'M' {
                    let bit = crate::parse::letter_bit(letter);
                    if seen & bit != 0 {
                        return Err(Diagnostic::at(
                            Severity::Error,
                            ErrorKind::DuplicateWord(char::from(letter).to_string()),
                            line_no,
                            offset,
                            line,
                            i,
                            end,
                        ));
                    }
                    seen |= bit;
                }
                block.items.push(Item::Word(Word {
                    letter,
                    register: None,
                    value: v,
                    text: &text[vstart..end],
                    span: Span::new(offset + i, offset + end),
                }));
                i = end;
            }
            _ => {
                let ch = text[i..].chars().next().unwrap_or('?');
                return Err(Diagnostic::at(
                    Severity::Error,
                    ErrorKind::UnexpectedCharacter(ch),
                    line_no,
                    offset,
                    line,
                    i,
                    i + ch.len_utf8(),
                ));
            }
        }
    }
    for (p, v) in sets {
        params.set_value(&p, v);
    }
    Ok(())
}

/// A Fanuc `#3000 = n (MESSAGE)` (an alarm: the control stops, a located error) or
/// `#3006 = n (MESSAGE)` (a stop with a message, which cycle start resumes: a warning, held
/// in `params` for the stream), the assignment at `span` of `text`.
fn message_var(
    text: &str,
    line_no: u32,
    offset: usize,
    params: &mut Params,
    (n, v): (usize, f64),
    (start, end): (usize, usize),
) -> Result<(), Diagnostic> {
    let bytes = text.as_bytes();
    let mut k = end;
    while k < bytes.len() && matches!(bytes[k], b' ' | b'\t') {
        k += 1;
    }
    let message = match bytes.get(k) {
        Some(b'(') => memchr::memchr(b')', &bytes[k + 1..])
            .map_or(&text[k + 1..], |r| &text[k + 1..k + 1 + r])
            .trim(),
        _ => "",
    };
    let number = crate::emit::round_half_away(v);
    let at = |severity, kind| Diagnostic::at(severity, kind, line_no, offset, bytes, start, end);
    if n == 3000 {
        if !(0.0..=999.0).contains(&number) || (v - number).abs() > 1e-6 {
            return Err(at(
                Severity::Error,
                ErrorKind::Expression(format!(
                    "#3000 = {v}: an alarm number is a whole number 0 to 999"
                )),
            ));
        }
        return Err(at(
            Severity::Error,
            ErrorKind::MacroAlarm {
                number: 3000 + number as u32,
                message: message.to_string(),
            },
        ));
    }
    let d = at(Severity::Warning, ErrorKind::MacroStop(message.to_string()));
    if let Some(f) = params.fanuc.as_mut() {
        f.stops.push(d);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(s: &str, p: &Params) -> Result<f64, EvalError> {
        let mut e = Eval::new(s, 0, p);
        let v = e.value()?;
        Ok(v)
    }

    #[test]
    fn operators_and_precedence() {
        let p = Params::default();
        for (s, want) in [
            ("[1 + 2 * 3]", 7.0),
            ("[2 ** 3 ** 2]", 64.0),
            ("[10 - 4 - 3]", 3.0),
            ("[7 MOD 3]", 1.0),
            ("[-7 MOD 3]", 2.0),
            ("[1 + 2 EQ 3]", 1.0),
            ("[1 LT 2 AND 3 GT 4]", 0.0),
            ("[1 OR 0]", 1.0),
            ("[1 XOR 1]", 0.0),
            ("[2 NE 2.00001]", 0.0),
            ("[2 GE 2]", 1.0),
            ("[2 LE 1]", 0.0),
            ("-[2]", -2.0),
            ("[ABS[-2.5]]", 2.5),
            ("[ATAN[1]/[1]]", 45.0),
            ("[SIN[30]]", 0.49999999999999994),
            ("[FIX[-1.5] + FUP[1.2]]", 0.0),
            ("[ROUND[2.5]]", 3.0),
            ("[SQRT[16]]", 4.0),
            ("[EXISTS[#<nope>]]", 0.0),
            ("[1.5e]", 1.5),
        ] {
            match ev(s, &p) {
                Ok(v) => assert_eq!(v, want, "{s}"),
                Err(e) if s == "[1.5e]" => assert!(e.0.contains("operator"), "{e:?}"),
                Err(e) => panic!("{s}: {e:?}"),
            }
        }
    }

    #[test]
    fn bad_expressions_are_located() {
        let p = Params::default();
        for (s, what) in [
            ("[1/0]", "division by zero"),
            ("[1 MOD 0]", "MOD by zero"),
            ("[SQRT[-1]]", "domain"),
            ("[LN[0]]", "domain"),
            ("[#<undefined> + 1]", "not set"),
            ("[1 + ]", "expected a value"),
            ("[1 + 2", "not closed"),
            ("[FOO[1]]", "unknown function"),
            ("[10 ** 400]", "finite"),
            ("[#6000]", "whole numbers"),
        ] {
            let e = ev(s, &p).expect_err(s);
            assert!(e.0.contains(what), "{s}: {e:?}");
            assert!(e.1 <= e.2 && e.2 <= s.len(), "{s}: {e:?}");
        }
        let deep = format!("{}1{}", "[".repeat(1000), "]".repeat(1000));
        assert!(ev(&deep, &p).is_err());
    }

    #[test]
    fn assignments_take_effect_after_the_line() {
        let mut p = Params::default();
        let mut b = Block::empty(1, 0);
        let line = b"#1 = 5 #2 = [#1 + 1] #<_g> = 2 #<loc> = 3";
        eval_line(line, 1, 0, &mut b, &mut p).expect("evaluates");
        assert_eq!((p.get(1), p.get(2)), (Some(5.0), Some(1.0)));
        assert_eq!((p.named("_G"), p.named("loc")), (Some(2.0), Some(3.0)));
        let line = b"G1 X[#1 * 2] Y#2 Z-#<loc> F#<_g> (c) #1 = 0";
        let mut b = Block::empty(2, 10);
        eval_line(line, 2, 10, &mut b, &mut p).expect("evaluates");
        let w: Vec<(char, f64, &str)> = b
            .words()
            .map(|w| (w.letter_char(), w.value, w.text))
            .collect();
        assert_eq!(
            w,
            [
                ('G', 1.0, "1"),
                ('X', 10.0, "[#1 * 2]"),
                ('Y', 1.0, "#2"),
                ('Z', -3.0, "-#<loc>"),
                ('F', 2.0, "#<_g>")
            ]
        );
        assert_eq!(p.get(1), Some(0.0));
        assert_eq!(b.comments().count(), 1);
        // Subroutine scopes.
        p.enter(&[7.0]);
        assert_eq!(
            (p.get(1), p.get(2), p.named("loc")),
            (Some(7.0), Some(0.0), None)
        );
        assert_eq!(p.named("_g"), Some(2.0));
        p.leave(Some(4.0));
        assert_eq!(
            (p.get(1), p.get(2), p.named("loc")),
            (Some(0.0), Some(1.0), Some(3.0))
        );
        assert_eq!(p.named("_value"), Some(4.0));
        // Errors are located in the line.
        let mut b = Block::empty(3, 0);
        let d = eval_line(b"G1 X[1/0]", 3, 0, &mut b, &mut p).expect_err("fails");
        assert_eq!(d.column, 6);
        let d = eval_line(b"G1 X#<nope>", 3, 0, &mut b, &mut p).expect_err("fails");
        assert_eq!(
            (d.column, d.kind.to_string().contains("not set")),
            (5, true)
        );
    }
}
