//! Rows of output that wait in a scratch file until the command's figures are whole: an error
//! prints or writes none of them, and memory holds none (`postpro solve --csv`, `postpro predict
//! --blocks` and `--csv`, a row per step, block or sample of a file of millions of points).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::job::fail;

/// The scratch files this process made, for their names: a pass made again starts a new one
/// while the old one is still there.
static MADE: AtomicUsize = AtomicUsize::new(0);

/// Text written on to a scratch file, removed when dropped unless kept ([`Self::keep_as`]).
pub(crate) struct Scratch {
    file: std::io::BufWriter<std::fs::File>,
    /// Where it is (`None` once kept).
    path: Option<PathBuf>,
    /// The rows not yet written on ([`Self::flush_text`]).
    pub(crate) text: String,
}

impl Scratch {
    /// A new scratch file in the temporary folder; `what` ends its name.
    pub(crate) fn new(what: &str) -> std::io::Result<Scratch> {
        let n = MADE.fetch_add(1, Ordering::Relaxed);
        Scratch::at(std::env::temp_dir().join(format!("postpro-{}-{n}.{what}", std::process::id())))
    }

    /// A new scratch file beside `target`, to be renamed over it ([`Self::keep_as`]).
    pub(crate) fn beside(target: &Path) -> std::io::Result<Scratch> {
        let n = MADE.fetch_add(1, Ordering::Relaxed);
        Scratch::at(crate::emit::beside(target, &format!("{n}.tmp")))
    }

    fn at(path: PathBuf) -> std::io::Result<Scratch> {
        let file = std::io::BufWriter::new(crate::emit::create_scratch(&path)?);
        Ok(Scratch { file, path: Some(path), text: String::new() })
    }

    /// Writes the rest on and renames the file over `target`.
    pub(crate) fn keep_as(mut self, target: &Path) -> std::io::Result<()> {
        self.flush_text()?;
        self.file.flush()?;
        let path = self.path.take().unwrap_or_default();
        std::fs::rename(&path, target).inspect_err(|_| {
            let _ = std::fs::remove_file(&path);
        })
    }

    /// Writes [`Self::text`] on to the file, and empties it.
    pub(crate) fn flush_text(&mut self) -> std::io::Result<()> {
        self.file.write_all(self.text.as_bytes())?;
        self.text.clear();
        Ok(())
    }

    /// Copies what was written to standard output, after `before`; a closed pipe ends quietly.
    pub(crate) fn print_after(mut self, before: &str) -> ExitCode {
        let copied = self.flush_text().and_then(|()| self.file.flush()).and_then(|()| {
            let mut rows = std::fs::File::open(self.path.as_deref().unwrap_or(Path::new("")))?;
            let mut out = std::io::stdout().lock();
            out.write_all(before.as_bytes())?;
            std::io::copy(&mut rows, &mut out)?;
            out.flush()
        });
        match copied {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
            Err(e) => fail(&format!("error: cannot write to standard output: {e}\n"), 1),
        }
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if let Some(path) = &self.path {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// The lines and columns of offsets of a CL file asked for in increasing order, read on as they
/// come (the file opened again at the first).
#[derive(Default)]
pub(crate) struct LinesOf {
    lines: Option<postpro_cl::Lines>,
}

impl LinesOf {
    /// The line and column of byte `offset` of `file` (the same file at every call).
    pub(crate) fn line_col(&mut self, file: &postpro_cl::ClFile, offset: u32) -> std::io::Result<postpro_cl::LineCol> {
        let lines = match &mut self.lines {
            Some(lines) => lines,
            None => self.lines.insert(file.lines().map_err(std::io::Error::other)?),
        };
        lines.line_col(offset as usize)
    }
}
