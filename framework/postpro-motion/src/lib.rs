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

mod block;
mod build;

pub use block::{Block, BlockKind, FeedWord, Linear, Mode, Position, Spline, ToolCall};
pub use build::{Options, build, collect};

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

/// Counts for the program's header.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// CL points solved.
    pub cl_points: usize,
    /// Points added by linearization.
    pub linearized_points: usize,
    /// IKT decisions (each also a comment block).
    pub decisions: usize,
}

/// A whole motion program.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// How motion is written.
    pub mode: Mode,
    /// The part's name (`PARTNO`), when the CL file gives one.
    pub part: Option<String>,
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
        help("program a FEDRAT before the first feed move, or mark the move RAPID in the CL file")
    )]
    NoFeed {
        /// The move.
        #[label("this move")]
        span: Span,
    },
}
