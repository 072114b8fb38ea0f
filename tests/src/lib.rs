//! # tests: the workspace-level test package
//!
//! The top-level `tests/` folder is a workspace package of its own. It holds the data-driven
//! tests that span the product rather than one crate:
//!
//! - `reader.rs`: the APT/CL reader (`postpro-cl`) against every real CL file in
//!   `../shared/data/cl`, the bundled examples in `examples/cl`, and the hand-written cases in
//!   `tests/cl` (one input per diagnostic class: `err_*.cl`, `warn_*.cl`, and tricky valid
//!   syntax in `ok_*.cl`), pinned with insta snapshots in `tests/snapshots/`; and every real CL
//!   file under `../shared/data` (corpus, peer inputs, hold-out: [`real_cl_files`]) for its arc
//!   sense, operations and cycles.
//! - `harness.rs`: the validation harness below against the peers' programs and CL files.
//!
//! This library holds the helpers those tests share: where the data lives. The plugin tests of
//! `postpro-plugins` and `postpro` use it too (as a dev-dependency) to build the plugins of
//! `plugins/` once per test binary. And it is the validation harness of the golden and
//! back-simulation tests (`docs/validation-harness.md`):
//!
//! - [`nc`]: an NC program as the machine runs it (motions with exact geometry, events);
//! - [`rs274`]: LinuxCNC's `rs274` run on a program, its canonical calls read into an [`nc::Program`];
//! - [`golden`]: readers of the Fanuc/Haas and Heidenhain programs other posts wrote (and ours,
//!   TCP and working planes included; Siemens from nc-gcode-interpreter's table), and the pairs
//!   of CL file and program in `../shared/data/peers`;
//! - [`compare`]: comparators (motions in order, arcs, feed path length, points off a path).
//!
//! Run with `cargo test -p tests`; after an intended change of the reader's output, review the
//! snapshots with `cargo insta review` (or `INSTA_UPDATE=always cargo test -p tests`, then
//! read the diff).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

pub mod compare;
mod error;
pub mod golden;
pub mod nc;
pub mod rs274;
#[cfg(test)]
mod testing;

pub use error::Error;

/// The repository root (the workspace root).
pub fn repo_root() -> PathBuf {
    // This package sits in `<repo>/tests`. Canonical, so that paths found by walking a folder
    // (which insta's `glob!` canonicalises) strip cleanly.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().map_or_else(|| PathBuf::from(".."), Path::to_path_buf);
    root.canonicalize().unwrap_or(root)
}

/// The real CL corpus, `../shared/data/cl` seen from the repository root.
///
/// # Panics
///
/// When the folder is missing: `../shared` must sit beside the repository.
pub fn shared_cl_dir() -> PathBuf {
    let dir = repo_root().join("../shared/data/cl");
    assert!(
        dir.is_dir(),
        "{} is missing: ../shared must sit beside the repository (the real CL files live in ../shared/data/cl)",
        dir.display()
    );
    dir
}

/// The bundled example programs, `examples/cl`.
pub fn examples_cl_dir() -> PathBuf {
    repo_root().join("examples/cl")
}

/// The hand-written reader cases, `tests/cl`.
pub fn cases_dir() -> PathBuf {
    repo_root().join("tests/cl")
}

/// The path of `path` relative to the repository root, with `/` separators, for names in
/// snapshots that do not depend on the machine (`tests/cl/err_goto_arity.cl`).
pub fn repo_relative(path: &Path) -> String {
    let root = repo_root();
    let path = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    let rel = path.strip_prefix(&root).unwrap_or(&path);
    rel.components().map(|c| c.as_os_str().to_string_lossy()).collect::<Vec<_>>().join("/")
}

/// The plugin packages of `plugins/`: the two examples and the broken fixtures.
pub const PLUGIN_PACKAGES: [&str; 5] = [
    "plugin-head-head",
    "plugin-yaml-machines",
    "fixture-plugin-wrong-abi",
    "fixture-plugin-no-entry",
    "fixture-plugin-misbehaving",
];

/// Builds every plugin package once, with the cargo running the tests, into the calling test's
/// target directory and profile; returns that `target/<profile>` folder, which holds the
/// libraries (and the `postpro` binary of the same build).
///
/// # Panics
/// When the build fails (with cargo's output).
pub fn built_plugins() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        // A test binary runs from `target/<profile>/deps/`.
        let exe = std::env::current_exe().expect("the test's path");
        let dir = exe.parent().and_then(Path::parent).expect("target/<profile>/deps/<test>").to_path_buf();
        let mut cargo = Command::new(env!("CARGO"));
        cargo.arg("build").arg("--target-dir").arg(dir.parent().expect("the target directory"));
        match dir.file_name().and_then(|n| n.to_str()) {
            Some("debug") | None => {}
            Some(profile) => {
                cargo.args(["--profile", profile]);
            }
        }
        for p in PLUGIN_PACKAGES {
            cargo.args(["-p", p]);
        }
        let out = cargo.current_dir(repo_root()).output().expect("cargo runs");
        assert!(out.status.success(), "cargo build of the plugins failed:\n{}", String::from_utf8_lossy(&out.stderr));
        dir
    })
}

/// Where `.ci/run interpreters` installs the real NC interpreters: `$POSTPRO_CI_TOOLS`, else
/// `$XDG_CACHE_HOME/postpro-ci` or `~/.cache/postpro-ci` (`None` without a home).
pub fn ci_tools() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("POSTPRO_CI_TOOLS").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(dir));
    }
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
    Some(cache.join("postpro-ci"))
}

/// The peer post-processor data, `../shared/data/peers` seen from the repository root.
///
/// # Panics
///
/// When the folder is missing: `../shared` must sit beside the repository.
pub fn shared_peers_dir() -> PathBuf {
    let dir = repo_root().join("../shared/data/peers");
    assert!(dir.is_dir(), "{} is missing: ../shared must sit beside the repository", dir.display());
    dir
}

/// Every real CL file under `../shared/data`: the corpus (`cl/`), the inputs of the peer pairs
/// (`peers/<repo>/[<case>/]input/`) and the hold-out files (`peers/holdout/`), each with a name
/// relative to `../shared/data`, sorted. Files that are not CL data are left out: notes
/// (`*.md`), clsplit's measured datum file `FN15RUN.A`, a CATIA PP table and its log.
pub fn real_cl_files() -> Vec<(String, PathBuf)> {
    let data = shared_cl_dir().parent().map_or_else(|| PathBuf::from("../shared/data"), Path::to_path_buf);
    let mut files = Vec::new();
    let mut walk = vec![data.join("cl"), data.join("peers")];
    while let Some(dir) = walk.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                // Expected outputs are NC programs, not CL.
                if path.file_name().is_some_and(|n| n != "expected") {
                    walk.push(path);
                }
                continue;
            }
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let rel = path.strip_prefix(&data).unwrap_or(&path);
            let rel: String = rel.components().map(|c| c.as_os_str().to_string_lossy()).collect::<Vec<_>>().join("/");
            let in_peers = rel.starts_with("peers/");
            let cl_place = !in_peers || rel.contains("/input/") || rel.starts_with("peers/holdout/");
            let not_cl =
                name.ends_with(".md") || name == "FN15RUN.A" || name.ends_with(".LOG") || name.ends_with(".pptable");
            if cl_place && !not_cl {
                files.push((rel, path));
            }
        }
    }
    files.sort();
    files
}
