//! # postpro-emit: NC programs
//!
//! From a solved tool path to the text of an NC program, in two steps:
//! 1. [`build`] makes the **template context** ([`Program`]): the header, the tools, and one
//!    [`Block`] per line in the order of the CL file, numbers already formatted for the dialect
//!    (fixed decimals per axis, never `-0`), only the words that change;
//! 2. [`render`] writes it with the dialect's minijinja template (`templates/<dialect>.j2`, or
//!    the user's), undefined names being errors.
//!
//! Modes: `g1` (axis values, programmed feed), `inverse-time` (G93, F = 1/Δt on every block,
//! Δt = part-space length / feed, blocks split to respect the controller's minimum F),
//! `tcp` (tool tip and vector; the controller solves the kinematics), `bspline` (Siemens
//! `BSPLINE SD=3` through the axis positions of each run of feed moves, within tolerance).
//!
//! The feed prediction, when there is one, reaches the program through [`Options`]: its summary
//! as `header.prediction`, its slowdowns as [`Annotation`]s, comments written before the motion
//! of the steps they concern.

pub use postpro_kin::bspline;
mod dialect;
mod format;
mod program;
mod render;

pub use dialect::{DIALECTS, Dialect, TcpOrientation, TcpStyle, WorkOffsets, dialect};
pub use format::{number, number_trimmed, push_number};
pub use program::{
    Annotation, AxisInfo, Block, BlockSink, CycleHole, Header, MarkedSlowdown, Mode, OperationPrediction, Options,
    PlaneOn, Prediction, Program, Tool, Word, WorkOffsetWord, build, build_blocks, check_mode, check_orientation,
    clean_comment, header, motion_options, tools,
};
pub use render::{
    Annotated, DeferredBody, Scratch, TEMPLATES, WriteError, builtin_template, render, write_program,
    write_program_deferred, write_program_with,
};

/// Why a program cannot be written.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum EmitError {
    /// The dialect has no such mode.
    #[error("the {dialect} dialect has no {mode} mode")]
    #[diagnostic(code(emit::unsupported), help("choose another --mode or --dialect"))]
    Unsupported {
        /// The dialect.
        dialect: &'static str,
        /// The mode.
        mode: &'static str,
    },
    /// The dialect's TCP takes no tool vector.
    #[error("the {dialect} dialect's tool-centre-point control takes the rotary axes' angles, not the tool vector")]
    #[diagnostic(code(emit::tcp_orientation), help("use --tcp-orientation angles"))]
    TcpOrientation {
        /// The dialect.
        dialect: &'static str,
    },
    /// The program could not be written.
    #[error("cannot write the program: {message}")]
    #[diagnostic(code(emit::io))]
    Io {
        /// The cause.
        message: String,
    },
    /// A line is longer than the controller accepts.
    #[error("a line is longer than the {max} characters the {dialect} dialect accepts: `{start}…`")]
    #[diagnostic(code(emit::line_length), help("shorten the template's output for this block"))]
    LineTooLong {
        /// The dialect.
        dialect: &'static str,
        /// Its limit.
        max: usize,
        /// The start of the line.
        start: String,
    },
    /// The dialect has no such work offset.
    #[error("the {dialect} dialect has no work offset `{offset}`: it selects {accepted}")]
    #[diagnostic(code(emit::work_offset), help("choose one with --work-offset (or `work_offset:` in the set-up file)"))]
    WorkOffset {
        /// The dialect.
        dialect: &'static str,
        /// The offset asked for.
        offset: String,
        /// What the dialect accepts.
        accepted: String,
    },
    /// The template does not compile or render.
    #[error("template {name}: {message}")]
    #[diagnostic(code(emit::template))]
    Template {
        /// The template.
        name: String,
        /// What went wrong, with the template line.
        message: String,
    },
}
