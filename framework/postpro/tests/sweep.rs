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
//! Then the same files on the three real machines with the options that change how the program
//! is written (`N` words, other dialects, axis values for 3+2, linear arcs and expanded cycles,
//! inch, verbatim inserts, TCP vectors), and through `predict` and `solve`, which stream the file
//! as the main job does.
//!
//! About 3 000 runs, three minutes on 2 cores: the tests are `#[ignore]`d, out of the README's
//! test command, and `.ci/run` runs them after it, on the build it made (the tests' profile,
//! optimised, with overflow checks and debug assertions):
//! `cargo test -p postpro --test sweep -- --ignored`.

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

/// One run of the main job on `file` with `args`, the program to `out`: what went wrong with how
/// it ended, if anything.
fn run(file: &Path, args: &[&str], out: &Path) -> Option<String> {
    let out_text = out.to_str().expect("a UTF-8 path");
    let mut all = vec![file.to_str().expect("a UTF-8 path"), "-o", out_text];
    all.extend_from_slice(args);
    let o = postpro(&all, Path::new("."));
    let said = stderr(&o);
    let what = format!("postpro {}", all.join(" "));
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
#[ignore = "thousands of runs: `.ci/run` runs them (`-- --ignored`)"]
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
        let failure = run(file, &["--machine", machine, "--mode", mode], &out);
        let _ = std::fs::remove_file(&out);
        failure
    })
    .into_iter()
    .flatten()
    .collect();
    assert!(failures.is_empty(), "{} of {} runs ended badly:\n{}", failures.len(), cases.len(), failures.join("\n"));
}

/// The options that change how the program is written, and the commands that stream the file as
/// the main job does (`predict` and `solve` print to standard output and write no file).
const OPTIONS: &[&[&str]] = &[
    &["--block-numbers"],
    &["--dialect", "heidenhain"],
    &["--dialect", "linuxcnc", "--block-numbers"],
    &["--plane-mode", "joints", "--mode", "inverse-time"],
    &["--arcs", "linear", "--cycles", "expand", "--units", "inch"],
    &["--insert", "verbatim", "--block-numbers", "--mode", "tcp", "--tcp-orientation", "vectors"],
];

/// Every real file and example on the three real machines with the options of [`OPTIONS`], and
/// through `predict` and `solve`: a whole program or an error and no file, and never a panic.
#[test]
#[ignore = "thousands of runs: `.ci/run` runs them (`-- --ignored`)"]
fn every_file_posts_or_says_why_with_the_writing_options_and_through_predict_and_solve() {
    let mut files: Vec<PathBuf> = tests::real_cl_files().into_iter().map(|(_, path)| path).collect();
    files.extend(examples());
    let machines = ["maho600e", "mikron-ucp710", "haas-umc750"];
    let mut cases: Vec<(usize, &PathBuf, &str, Option<&[&str]>)> = Vec::new();
    for file in &files {
        for machine in machines {
            for options in OPTIONS {
                cases.push((cases.len(), file, machine, Some(*options)));
            }
            cases.push((cases.len(), file, machine, None));
        }
    }
    let dir = out_dir("sweep-options");
    let failures: Vec<String> = on_two_threads(&cases, |&(k, file, machine, options)| match options {
        Some(options) => {
            let out = dir.join(format!("{k}.nc"));
            let mut args = vec!["--machine", machine];
            args.extend_from_slice(options);
            let failure = run(file, &args, &out);
            let _ = std::fs::remove_file(&out);
            failure
        }
        None => ["predict", "solve"].into_iter().find_map(|command| {
            let file = file.to_str().expect("a UTF-8 path");
            let o = postpro(&[command, file, "--machine", machine], Path::new("."));
            let said = stderr(&o);
            let ended_well = match o.status.code() {
                Some(0) => !o.stdout.is_empty(),
                Some(1) => o.stdout.is_empty() && (said.contains("error") || said.contains('×')),
                _ => false,
            };
            (!ended_well || said.contains("panicked"))
                .then(|| format!("postpro {command} {file} --machine {machine}: ended with {}\n{said}", o.status))
        }),
    })
    .into_iter()
    .flatten()
    .collect();
    assert!(failures.is_empty(), "{} of {} cases ended badly:\n{}", failures.len(), cases.len(), failures.join("\n"));
}
