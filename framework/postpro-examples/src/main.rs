//! `postpro-examples`: writes the bundled example CL files and benchmark CL files.
//!
//! ```text
//! postpro-examples write [--dir DIR]        # the bundled examples (default: examples/cl)
//! postpro-examples big --size-mb N OUT      # a GOTO-dominated file of about N MiB
//! postpro-examples fine --passes N OUT      # finishing with 0.3 mm chords (1000: ~1 M points)
//! ```
//!
//! Files are written atomically: to a temporary file in the target directory, then
//! renamed over the destination.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Directory of the bundled examples, relative to this crate (resolved at compile time).
const DEFAULT_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/cl");

/// Generator of the bundled example CL files of postpro and of benchmark CL files.
#[derive(Debug, Parser)]
#[command(name = "postpro-examples", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Write the bundled examples (hypar-5axis.cl, manta-5axis.cl, bicubic-5axis.cl).
    Write {
        /// Target directory [default: examples/cl of the workspace].
        #[arg(long, value_name = "DIR")]
        dir: Option<PathBuf>,
    },
    /// Write a GOTO-dominated 5-axis NX CLSF file for throughput benchmarks.
    Big {
        /// Approximate size in MiB (1 MiB = 1,048,576 bytes); fractions are allowed.
        #[arg(long, value_name = "N")]
        size_mb: f64,
        /// Output file.
        #[arg(value_name = "OUT")]
        out: PathBuf,
    },
    /// Write a 5-axis finishing file of short blocks (a point every 0.3 mm on passes 0.3 mm
    /// apart, 3 m/min) for throughput benchmarks.
    Fine {
        /// Number of passes (1000: about a million CL points, 62 MB).
        #[arg(long, value_name = "N", default_value_t = postpro_examples::FINE_PASSES_1M)]
        passes: usize,
        /// Output file.
        #[arg(value_name = "OUT")]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { 1 } else { 0 };
            // Nothing better to do if even printing the usage fails.
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(1)
        }
    }
}

fn run(command: Command) -> Result<(), String> {
    match command {
        Command::Write { dir } => {
            let dir = dir.unwrap_or_else(|| PathBuf::from(DEFAULT_DIR));
            fs::create_dir_all(&dir).map_err(|e| format!("cannot create directory {}: {e}", dir.display()))?;
            for (name, text) in
                postpro_examples::bundled_examples().into_iter().chain(postpro_examples::extra_examples())
            {
                let path = dir.join(name);
                write_atomically(&path, |w| w.write_all(text.as_bytes()))
                    .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
                println!("wrote {} ({} bytes, {} lines)", display(&path), text.len(), text.lines().count());
            }
            Ok(())
        }
        Command::Big { size_mb, out } => {
            if !(size_mb.is_finite() && size_mb > 0.0 && size_mb <= 65_536.0) {
                return Err(format!("--size-mb must be a number > 0 and <= 65536, got {size_mb}"));
            }
            let target = (size_mb * 1_048_576.0).round() as usize;
            let mut written = 0;
            write_atomically(&out, |w| {
                written = postpro_examples::write_big_goto_file(w, target)?;
                Ok(())
            })
            .map_err(|e| format!("cannot write {}: {e}", out.display()))?;
            println!("wrote {} ({written} bytes)", display(&out));
            Ok(())
        }
        Command::Fine { passes, out } => {
            if !(1..=100_000).contains(&passes) {
                return Err(format!("--passes must be between 1 and 100000, got {passes}"));
            }
            let text = postpro_examples::fine_finishing_file(passes);
            write_atomically(&out, |w| w.write_all(text.as_bytes()))
                .map_err(|e| format!("cannot write {}: {e}", out.display()))?;
            println!("wrote {} ({} bytes)", display(&out), text.len());
            Ok(())
        }
    }
}

/// A tidy path for messages (`examples/cl/../..` resolved when possible).
fn display(path: &Path) -> String {
    fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()).display().to_string()
}

/// Writes `path` through `fill` into a temporary file in the same directory, then renames
/// it over `path`; the temporary file is removed on failure.
fn write_atomically(path: &Path, fill: impl FnOnce(&mut BufWriter<fs::File>) -> io::Result<()>) -> io::Result<()> {
    let name = path.file_name().ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "not a file name"))?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(".tmp-{}", std::process::id()));
    let temp = dir.join(temp_name);
    let result = (|| {
        let file = fs::File::create(&temp)?;
        let mut writer = BufWriter::with_capacity(1 << 20, file);
        fill(&mut writer)?;
        let file = writer.into_inner().map_err(io::IntoInnerError::into_error)?;
        file.sync_all()?;
        drop(file);
        fs::rename(&temp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&temp);
    }
    result
}
