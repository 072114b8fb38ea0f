//! What the command-line tests share: running the built `postpro` in a folder, its output as
//! text, scratch folders with copies of the bundled examples, and their listing.

#![allow(dead_code)] // each test binary uses its part

pub(crate) mod backsim;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository's root.
pub(crate) fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `postpro` in `dir`, so that relative paths (and the messages naming them) read as a
/// user types them.
pub(crate) fn postpro(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postpro")).args(args).current_dir(dir).output().expect("postpro runs")
}

/// Standard output as text.
pub(crate) fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).expect("stdout is UTF-8")
}

/// Standard error as text.
pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).expect("stderr is UTF-8")
}

/// A fresh folder `group/name` under the test's target folder with a copy of each
/// `(repository path, name in the folder)` (kept after the test for a look after a failure).
pub(crate) fn scratch(group: &str, name: &str, copies: &[(&str, &str)]) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(group).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    for (from, to) in copies {
        std::fs::copy(repo().join(from), dir.join(to)).unwrap_or_else(|e| panic!("a copy of {from}: {e}"));
    }
    dir
}

/// The names in `dir`, sorted.
pub(crate) fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("an entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A number of the output.
pub(crate) fn number(field: &str) -> f64 {
    field.parse().unwrap_or_else(|_| panic!("`{field}` is a number"))
}

/// A CL file of two 3+2 set-ups: along Z, then tilted 30° about X with three corners at feed (a
/// slowdown worth a comment). With `wiggle`, the tool axis of a feed move in the first turns by
/// 6e-7: a set-up still for the rotary axes (which stand within half a unit of their last
/// decimal, 8.7e-7 rad and more), simultaneous motion for the tool axes, which are what the main
/// job guesses the set-ups from (within 5e-7): a guess the steps prove wrong.
pub(crate) fn two_set_ups(wiggle: bool) -> String {
    let i = if wiggle { "0.0000006" } else { "0.0000000" };
    [
        "LOAD/TOOL,1\nSPINDL/RPM,8000,CLW\nCOOLNT/ON\nRAPID\nGOTO/0.0000,0.0000,50.0000,0.0000000,0.0000000,1.0000000\n",
        "FEDRAT/MMPM,1000.0000\nGOTO/0.0000,0.0000,10.0000,0.0000000,0.0000000,1.0000000\n",
        &format!("GOTO/20.0000,0.0000,10.0000,{i},0.0000000,1.0000000\n"),
        "RAPID\nGOTO/30.0000,0.0000,50.0000,0.0000000,0.5000000,0.8660254\n",
        "GOTO/40.0000,10.0000,10.0000,0.0000000,0.5000000,0.8660254\n",
        "GOTO/40.0000,30.0000,10.0000,0.0000000,0.5000000,0.8660254\n",
        "GOTO/60.0000,30.0000,10.0000,0.0000000,0.5000000,0.8660254\n",
        "GOTO/60.0000,10.0000,10.0000,0.0000000,0.5000000,0.8660254\nEND-OF-PATH\n",
    ]
    .concat()
}
