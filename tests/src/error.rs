//! The one error of the validation harness: an NC program that does not read, an interpreter
//! that rejects a program, or a file that cannot be read.

use std::path::PathBuf;

/// What went wrong while reading or back-simulating an NC program.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum Error {
    /// A parser met something it cannot read: the file, the 1-based line and column, what it
    /// found and what it expected.
    #[error("{file}:{line}:{column}: {message}")]
    Parse {
        /// The program's name (its path as given).
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (characters).
        column: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// LinuxCNC's `rs274` rejected the program (or stopped before its end).
    #[error("{file}:{}: rs274: {message}{}", line.map_or_else(|| "?".to_string(), |l| l.to_string()), text.as_ref().map_or_else(String::new, |t| format!(" (`{t}`)")))]
    Rs274 {
        /// The program's name.
        file: String,
        /// The 1-based line of the block rs274 stopped at, when it says.
        line: Option<usize>,
        /// That line's text in the program.
        text: Option<String>,
        /// rs274's message (its standard error, without its own echo of the block).
        message: String,
    },
    /// rs274 printed a canonical call the harness does not model (a probe, a NURBS feed, a
    /// rigid tap…), or one it cannot read.
    #[error("{file}:{line}: rs274 printed `{call}`: {message}")]
    Canon {
        /// The program's name.
        file: String,
        /// The 1-based line of the block that made the call (0: none).
        line: usize,
        /// The call as printed.
        call: String,
        /// Why it is not read.
        message: String,
    },
    /// A file or a process could not be read, written or started.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or program.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl Error {
    /// The `Io` error of `path`.
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Error {
        let path = path.into();
        move |source| Error::Io { path, source }
    }
}
