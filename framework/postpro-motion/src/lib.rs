//! # postpro-motion: the motion program
//!
//! The third stage of the pipeline. The solved tool path (the reader's items in CL order and the
//! policy's axis values) becomes **one list of machine-space blocks** — rapid, linear, B-spline,
//! tool change, spindle, coolant, dwell, stop, comment — built once. The prediction reads it and
//! attaches its findings; the emitter renders it per dialect. Neither re-derives what is decided
//! here: which points a mode writes, the F word of every feed move, which runs are B-splines and
//! their control points, where each IKT decision is said.
//!
//! [`build`] hands the blocks to a [`MotionSink`] as they are made (a `Vec<Block>` collects them).

mod arc;
mod block;
mod build;
mod clearance;
mod cycle;
pub mod frame;
pub mod survey;
pub mod tooling;
pub mod travel;

pub use block::{
    Arc, AxisSet, Block, BlockKind, Cycle, CycleMove, FeedWord, Hole, Linear, MachineRetract, Mode, Plane, PlaneKind,
    Position, Rapid, Spline, ToolCall, WorkPlane,
};
pub use build::{Arcs, Job, Options, Stage, build, collect, study, unknown_words};
pub use frame::{WorkFrame, part_zero_frame, work_frame};
pub use survey::{AxisStretches, SetUps, Survey, Surveyor};
pub use tooling::{Tool, Tooling, ToolingReader, tooling};

use postpro_cl::Span;

/// Where the blocks go, one at a time.
pub trait MotionSink {
    /// Takes the next block.
    fn block(&mut self, block: Block);
}

impl MotionSink for Vec<Block> {
    fn block(&mut self, block: Block) {
        self.push(block);
    }
}

/// Something the program does that the user must hear about (a feed limited, a tool assumed),
/// with the CL statement it concerns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// The CL statement.
    pub span: Span,
    /// What happened, and what to set to change it.
    pub message: String,
}

/// Counts for the program's header, and the warnings.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// CL points solved.
    pub cl_points: usize,
    /// Points added by linearization.
    pub linearized_points: usize,
    /// IKT decisions (each also a comment block).
    pub decisions: usize,
    /// What the program had to decide that the user must hear about, in CL order.
    pub warnings: Vec<Warning>,
}

/// A whole motion program.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// How motion is written.
    pub mode: Mode,
    /// The part's name (`PARTNO`), when the CL file gives one.
    pub part: Option<String>,
    /// The work offset its coordinates are in.
    pub work_offset: postpro_machine::setup::WorkOffset,
    /// Where the shop sets it (`the part zero`, `the B/C intersection`).
    pub origin: String,
    /// The tools, in order of first use.
    pub tools: Vec<Tool>,
    /// The blocks in program order.
    pub blocks: Vec<Block>,
    /// Counts for the header.
    pub summary: Summary,
}

/// Why a tool path cannot become a motion program.
#[derive(Clone, Debug, PartialEq, thiserror::Error, miette::Diagnostic)]
pub enum MotionError {
    /// A feed move before any feed was programmed.
    #[error("a feed move with no feed programmed before it")]
    #[diagnostic(
        code(motion::no_feed),
        help(
            "program a FEDRAT before the first feed move or mark the move RAPID in the CL file, or set the machine's \
             policy `missing_feed: rapid`"
        )
    )]
    NoFeed {
        /// The move.
        #[label("this move")]
        span: Span,
    },
    /// A canned cycle the controller cannot run here, and that cannot be written as moves.
    #[error("{what}")]
    #[diagnostic(code(motion::cycle), help("{help}"))]
    Cycle {
        /// The cycle.
        #[label("this cycle")]
        span: Span,
        /// What is wrong.
        what: String,
        /// What can be done.
        help: String,
    },
    /// A tool's length is needed and unknown.
    #[error("the length of tool T{number} is unknown, and {machine} writes axis values that include it")]
    #[diagnostic(
        code(motion::tool_length),
        help(
            "its rotary axes turn the tool: give the length in a tool table (--tool-table) or in the CL file \
             (TLDATA, CUTTER), or write the program in TCP mode (--mode tcp)"
        )
    )]
    ToolLength {
        /// Where the tool is loaded.
        #[label("this tool")]
        span: Span,
        /// The tool.
        number: u32,
        /// The machine.
        machine: String,
    },
    /// An axis would leave its travel.
    #[error("{axis} would reach {value}, beyond its travel {travel}")]
    #[diagnostic(code(motion::travel), help("{help}"))]
    Travel {
        /// The move.
        #[label("this move")]
        span: Span,
        /// The axis.
        axis: String,
        /// Where it would be (machine coordinates, with the unit).
        value: String,
        /// Its travel.
        travel: String,
        /// What can be done.
        help: String,
    },
}

/// A number as a person writes it: at most six decimals, no trailing zeros, never `-0` nor
/// `6.095999999999999`.
pub fn number(value: f64) -> String {
    let text = format!("{:.6}", value + 0.0);
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" { "0".to_string() } else { text.to_string() }
}
