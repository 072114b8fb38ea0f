//! Every real CL file (`tests::real_cl_files`: the corpus, the peers' inputs, the hold-out
//! files) and every bundled example, on every built-in machine, in every output mode, with the
//! prediction: `postpro` either writes the program or stops with an error that says why, never
//! anything else. Most pairs do not fit (a 3-axis file on a nutating head, a side set-up on a
//! table that cannot tilt so far): what is pinned is how they end, not that they post.
//!
//! - Exit code 0 and a whole program (ending in its line break), or exit code 1, an error on
//!   standard error (`error: …`, or a diagnostic's `× …`) and no file at all (never a
//!   half-written program).
//! - Never a panic: the streamed look-ahead once indexed a piece it had forgotten on four real
//!   files, and only on one machine; the other tests post each file on the machine it fits.
//!
//! About 1 900 runs: too many for the unoptimised build, so the test is `#[ignore]`d there and
//! `.ci/run` runs it on the release build:
//! `cargo test --release -p postpro --test sweep -- --ignored`.

mod programs;

use std::path::{Path, PathBuf};

use programs::{on_two_threads, out_dir, postpro, stderr};

/// The output modes, `--mode` (auto is one of them on each file).
const MODES: &[&str] = &["g1", "tcp", "bspline", "inverse-time"];

/// The bundled examples (`examples/cl/`) beside the real files.
fn examples() -> Vec<PathBuf> {
    let dir = tests::repo_root().join("examples/cl");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "cl"))
        .collect();
    files.sort();
    files
}

/// The built-in machines' names.
fn machines() -> Vec<String> {
    let registry = postpro_machine::Registry::builtin().expect("the built-in machines load");
    registry.entries().iter().map(|e| e.machine.name.clone()).collect()
}

/// One run: what went wrong with how it ended, if anything.
fn run(file: &Path, machine: &str, mode: &str, out: &Path) -> Option<String> {
    let out_text = out.to_str().expect("a UTF-8 path");
    let file_text = file.to_str().expect("a UTF-8 path");
    let args = ["--machine", machine, "--mode", mode, file_text, "-o", out_text];
    let o = postpro(&args, Path::new("."));
    let said = stderr(&o);
    let what = format!("postpro {}", args.join(" "));
    if said.contains("panicked") {
        return Some(format!("{what}: a panic\n{said}"));
    }
    match o.status.code() {
        Some(0) => match std::fs::read(out) {
            Ok(text) if text.ends_with(b"\n") => None,
            Ok(_) => Some(format!("{what}: the program does not end in a line break")),
            Err(e) => Some(format!("{what}: exit code 0 but no program ({e})")),
        },
        Some(1) if out.exists() => Some(format!("{what}: an error, but a program was written\n{said}")),
        Some(1) if !(said.contains("error") || said.contains('×')) => {
            Some(format!("{what}: exit code 1 without an error\n{said}"))
        }
        Some(1) => None,
        _ => Some(format!("{what}: ended with {}\n{said}", o.status)),
    }
}

#[test]
#[ignore = "thousands of runs: run on the release build (`.ci/run` does)"]
fn every_file_on_every_machine_in_every_mode_posts_or_says_why() {
    let mut files: Vec<PathBuf> = tests::real_cl_files().into_iter().map(|(_, path)| path).collect();
    files.extend(examples());
    let machines = machines();
    assert!(files.len() >= 30 && machines.len() >= 10, "{} files, {} machines", files.len(), machines.len());
    let cases: Vec<(usize, &PathBuf, &String, &str)> = files
        .iter()
        .flat_map(|f| machines.iter().flat_map(move |m| MODES.iter().map(move |mode| (f, m, *mode))))
        .enumerate()
        .map(|(k, (f, m, mode))| (k, f, m, mode))
        .collect();
    let dir = out_dir("sweep");
    let failures: Vec<String> = on_two_threads(&cases, |&(k, file, machine, mode)| {
        let out = dir.join(format!("{k}.nc"));
        let failure = run(file, machine, mode, &out);
        let _ = std::fs::remove_file(&out);
        failure
    })
    .into_iter()
    .flatten()
    .collect();
    assert!(failures.is_empty(), "{} of {} runs ended badly:\n{}", failures.len(), cases.len(), failures.join("\n"));
}
