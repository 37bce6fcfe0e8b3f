//! # lampost-gcode
//!
//! The G-code layer of lampost: a nom parser for RS274/ISO programs as FADAL
//! controls and common CAM posts write them, a modal interpreter that resolves them
//! into absolute moves, and an emitter with dialects.
//!
//! ```
//! use lampost_gcode::{Event, Options, Stream};
//! let program = b"G21 G90\nG0 X10 Y5\nG1 Z-1 F100\nG2 X20 Y5 I5 J0\n";
//! let moves: Vec<_> = Stream::from_bytes(program, Options::default(), true)
//!     .filter_map(|e| match e { Ok(Event::Move(m)) => Some(m), _ => None })
//!     .collect();
//! assert_eq!(moves.len(), 3);
//! assert_eq!(moves[2].end[0], 20.0);
//! ```
//!
//! ## Why these dependencies
//! - `nom`: the number grammar (sign, digits, decimal point in every spelling);
//! - `smallvec`: a block's words live inline, so parsing allocates nothing per block;
//! - `memchr`: line and comment scanning at memory speed;
//! - `thiserror`: the typed [`ErrorKind`];
//! - `serde`: moves and modal state serialise to JSON for `lampost trace --json`.

mod ast;
pub mod comp;
mod decimal;
mod diag;
mod emit;
mod expr;
mod flavor;
mod foreign;
pub mod generate;
mod interp;
mod lathe;
mod lines;
mod macrob;
mod modal;
mod ngc;
mod parse;
mod polar;
mod program;
mod stream;
mod turning;

pub use ast::{Block, BlockKind, Comment, CommentStyle, Item, MacroKind, Span, Text, Word};
pub use decimal::{parse_number, parse_plain, push_exact_fixed, Fixed, Readable, POW10};
pub use diag::{Diagnostic, ErrorKind, Severity, Snippet};
pub use emit::{
    fixed, fixed_into, out_of_range, push_fixed, round_half_away, whole_into, Dialect, EmitOptions,
    Emitter,
};
pub use expr::{sets_feed, Params};
pub use flavor::{detect, Flavor, Resolved, DETECT_BYTES};
pub use foreign::{foreign_language, Foreign};
pub use interp::{
    Calls, EWord, Event, Interpreter, Move, MoveKind, Options, Origin, Stop, StopKind,
    ARC_RADIUS_TOLERANCE, ARC_SPIRAL_RELATIVE, ARC_SPIRAL_TOLERANCE,
};
pub use lines::{Line, LineReader, Lines, CHECKED_CHUNK, MAX_NUL_RUN};
pub use macrob::statement_block as macro_b_statement;
pub use modal::{FeedMode, Modal, Plane, Position, Spindle, Units, WorkOffset, AXES};
pub use ngc::MAX_BLOCKS;
pub use parse::{
    comment_not_utf8, comments_made_utf8, parse_line, parse_line_into, parse_line_lenient,
    parse_line_with, parse_str_with, Reading, MAX_LINE_BYTES,
};
pub use program::{Order, ProgramReader};
pub use stream::{check, LineSource, Stream};
