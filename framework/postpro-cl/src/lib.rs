//! # postpro-cl: the APT/CL reader
//!
//! Reads the cutter-location text that CAM systems write (Siemens NX CLSF and listings,
//! CATIA V5, PTC Creo, SOLIDWORKS CAM, CAMWorks, Makino FFCAM, Autodesk Fusion) into a typed
//! [`ToolPath`] in the part frame, in three layers:
//!
//! 1. [`records`](crate::records): physical lines → logical records (`$` continuation, `$$`
//!    comments, quotes, NX listing lines), each with its byte span;
//! 2. [`syntax`](crate::syntax): a record → a statement (nom), with what was expected on error;
//! 3. [`read`]: statements → items, with the modal state (units, frame, tool axis, feed, rapid).
//!
//! A pre-scan finds the file's length unit and CAM system first, because the sense of every arc
//! depends on the CAM system ([`CamSystem::arc_sense`]); [`read_with`] and [`ReadOptions`]
//! override both (`--arc-sense`, `--cl-units`). Canned cycles come out typed ([`Cycle`]), hole
//! positions at the top of each hole.
//!
//! **The reader never panics and never stops at the first problem:** every problem becomes a
//! [`Diagnostic`] with a span, and reading goes on with the next statement.
//!
//! ```
//! use postpro_cl::{Source, read};
//! let src = Source::new("a.cl", "UNITS/INCHES\nFEDRAT/IPM,10\nGOTO/1,2,3,0,0,1\n");
//! let path = read(&src);
//! let (m, _) = path.moves().next().unwrap();
//! assert_eq!(m.to.x, 25.4);
//! ```

mod diagnostic;
mod file;
mod model;
mod read;
mod records;
mod span;
mod summary;
mod syntax;
mod words;

use std::path::Path;

pub use diagnostic::{Diagnostic, Excerpt, Severity};
pub use file::{ClFile, Lines};
pub use model::*;
pub use read::{ItemSink, ReadOptions, read, read_into, read_into_with, read_with};
pub use span::{LineCol, Locate, Source, Span};
pub use summary::{
    BoundingBox, FeedSummary, MoveCounts, PathLength, Range, Summary, ToolSummary, UnitsSummary, WarningSummary,
    summarize, summarize_file, summarize_tool_path, summarize_with,
};

/// Errors of this crate that are not about the content of a CL file (those are diagnostics).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The file is larger than the reader's spans can address.
    #[error("{path} is {size} bytes; the reader accepts at most {} bytes", Source::MAX_LEN)]
    TooLarge {
        /// The path.
        path: String,
        /// Its size.
        size: u64,
    },
    /// The file changed between two readings of it (each pass must read the same text).
    #[error("{path} changed while it was being read; run again once it is written")]
    Changed {
        /// The path.
        path: String,
    },
}

impl Source {
    /// Reads a file (UTF-8, or Latin-1 when not valid UTF-8).
    pub fn from_path(path: &Path) -> Result<Source, Error> {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| Error::Io { path: name.clone(), source })?;
        if bytes.len() > Source::MAX_LEN {
            return Err(Error::TooLarge { path: name, size: bytes.len() as u64 });
        }
        Ok(Source::from_bytes(name, bytes))
    }
}
