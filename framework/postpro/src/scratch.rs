//! Rows of output that wait in a scratch file until the command's figures are whole: an error
//! prints none of them, and memory holds none (`postpro solve --csv`, `postpro predict
//! --blocks`, a row per step or per block of a file of millions of points).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::job::fail;

/// The scratch files this process made, for their names: a pass made again starts a new one
/// while the old one is still there.
static MADE: AtomicUsize = AtomicUsize::new(0);

/// Text written on to a scratch file in the temporary folder, removed when dropped.
pub(crate) struct Scratch {
    file: std::io::BufWriter<std::fs::File>,
    path: PathBuf,
    /// The rows not yet written on ([`Self::flush_text`]).
    pub(crate) text: String,
}

impl Scratch {
    /// A new scratch file; `what` ends its name.
    pub(crate) fn new(what: &str) -> std::io::Result<Scratch> {
        let n = MADE.fetch_add(1, Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!("postpro-{}-{n}.{what}", std::process::id()));
        let file = std::io::BufWriter::new(crate::emit::create_scratch(&path)?);
        Ok(Scratch { file, path, text: String::new() })
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
            let mut rows = std::fs::File::open(&self.path)?;
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
        let _ = std::fs::remove_file(&self.path);
    }
}
