//! Command-line tests of plugins: `postpro machines --plugin FILE` and
//! `postpro solve FILE --machine NAME --plugin FILE`, with the example plugins and the fixtures
//! of `plugins/`, built by cargo within the test run into this test's target directory.
//!
//! What a user sees: plugin machines listed with their library; a bundled example solved through
//! the head-head plugin's own kinematics exactly as through its definition's chain (pinned by
//! insta), and post-processed into an NC program; a broken plugin is an error with exit code 1
//! while the other machines are still listed; plugins found through `POSTPRO_PLUGIN_PATH` and
//! the `plugins` folder beside the binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use postpro_plugins::library_file_name;

const EXAMPLE: &str = "examples/cl/hypar-5axis.cl";

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The library of a plugin package, as an argument.
fn library(package: &str) -> String {
    let path = tests::built_plugins().join(library_file_name(package));
    assert!(path.is_file(), "{} was built", path.display());
    path.to_str().expect("a UTF-8 path").to_string()
}

/// Runs a postpro binary from the repository root, without the user's machine and plugin paths.
fn run(binary: &Path, args: &[&str], plugin_path: Option<&Path>) -> Output {
    let mut c = Command::new(binary);
    c.args(args).current_dir(repo()).env_remove("POSTPRO_MACHINE_PATH").env_remove("POSTPRO_PLUGIN_PATH");
    if let Some(p) = plugin_path {
        c.env("POSTPRO_PLUGIN_PATH", p);
    }
    c.output().expect("postpro runs")
}

fn postpro(args: &[&str]) -> Output {
    run(Path::new(env!("CARGO_BIN_EXE_postpro")), args, None)
}

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).expect("stdout is UTF-8")
}

fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).expect("stderr is UTF-8")
}

/// The table row of a machine.
fn row(out: &str, name: &str) -> String {
    out.lines().find(|l| l.starts_with(&format!("{name} "))).unwrap_or_else(|| panic!("no row `{name}`:\n{out}")).into()
}

/// True when the rendered diagnostics hold `message`, whatever miette's line wrapping.
fn says(rendered: &str, message: &str) -> bool {
    let words = |s: &str| s.split_whitespace().filter(|w| *w != "│").collect::<Vec<_>>().join(" ");
    words(rendered).contains(&words(message))
}

/// A fresh folder for one test.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("postpro-cli-plugins-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

#[test]
fn machines_lists_plugin_machines_with_their_library() {
    let lib = library("plugin-head-head");
    let o = postpro(&["machines", "--plugin", &lib]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
    let out = stdout(&o);
    let r = row(&out, "fork-head-bc");
    for cell in ["fork-head", "5-axis head-head", "plugin", "heidenhain", &format!("plugin {lib}")] {
        assert!(r.contains(cell), "`{cell}` missing in `{r}`");
    }
    assert!(row(&out, "mikron-ucp710").ends_with("built in"));
    let o = postpro(&["machines", "--json", "--plugin", &lib]);
    let json: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    let m = json.as_array().expect("a list").iter().find(|m| m["name"] == "fork-head-bc").expect("the plugin machine");
    assert_eq!(m["solver"], "plugin");
    assert_eq!(m["origin"], format!("plugin {lib}"));
    assert_eq!(m["axes"], serde_json::json!(["X", "Y", "Z", "B", "C"]));
}

/// The summary of a solve, with the library path (which depends on the target directory)
/// replaced, and the CSV head and every 250th position.
fn compact(summary: &str, csv: &str, lib: &str) -> String {
    let mut out = summary.replace(lib, "<library>");
    out.push_str("--- csv: the first 10 positions and every 250th ---\n");
    for (k, line) in csv.lines().enumerate() {
        if k <= 10 || k % 250 == 0 {
            out.push_str(line);
            out.push('\n');
        }
    }
    out.push_str(&format!("({} lines)\n", csv.lines().count()));
    out
}

#[test]
fn a_bundled_example_solves_through_the_head_head_plugin() {
    let lib = library("plugin-head-head");
    let o = postpro(&["solve", EXAMPLE, "--machine", "fork-head-bc", "--plugin", &lib]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    // Notes about the CL file only (what it passes over), no warning.
    assert!(stderr(&o).lines().all(|l| l.starts_with("note: ")), "{}", stderr(&o));
    let summary = stdout(&o);
    assert!(summary.contains(&format!("kinematics  plugin {lib} (checked against the definition)")), "{summary}");
    let o = postpro(&["solve", EXAMPLE, "-m", "fork-head", "--plugin", &lib, "--csv"]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let csv = stdout(&o);
    insta::assert_snapshot!("head_head_solve", compact(&summary, &csv, &lib));
    // The same axis values as the generic chain of the plugin's definition (the YAML file read
    // on its own: `solver: plugin` outside a plugin is the chain, with a note).
    let yaml = "plugins/plugin-head-head/machines/fork-head-bc.yaml";
    let o = postpro(&["solve", EXAMPLE, "-m", yaml, "--csv"]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    assert!(stderr(&o).contains("does not come from a plugin: solving with the generic chain"), "{}", stderr(&o));
    assert_eq!(stdout(&o), csv, "the plugin's closed form and the chain give the same program");
}

/// `--tool-length` is the length of a tool the CL file gives none (`TLDATA` names the tool's own,
/// and the head then puts that tool's tip on the path whatever the definition's length): through
/// the plugin it gives the chain's axis values, which differ from the definition's length's.
#[test]
fn the_command_line_tool_length_reaches_the_plugin() {
    let lib = library("plugin-head-head");
    let yaml = "plugins/plugin-head-head/machines/fork-head-bc.yaml";
    let example = std::fs::read_to_string(repo().join(EXAMPLE)).expect("the example");
    let dir = temp_dir("tool-length");
    let cl = dir.join("without-length.cl");
    std::fs::write(&cl, example.lines().filter(|l| !l.starts_with("TLDATA")).collect::<Vec<_>>().join("\n"))
        .expect("written");
    let cl = cl.to_str().expect("UTF-8");
    let through_plugin =
        postpro(&["solve", cl, "-m", "fork-head-bc", "--plugin", &lib, "--csv", "--tool-length", "60"]);
    assert_eq!(through_plugin.status.code(), Some(0), "stderr:\n{}", stderr(&through_plugin));
    let through_chain = postpro(&["solve", cl, "-m", yaml, "--csv", "--tool-length", "60"]);
    assert_eq!(stdout(&through_plugin), stdout(&through_chain));
    let default = postpro(&["solve", cl, "-m", "fork-head-bc", "--plugin", &lib, "--csv"]);
    assert_ne!(stdout(&through_plugin), stdout(&default));
    // With the tool's own length declared, the definition's does not matter.
    let declared = |extra: &[&str]| {
        let mut args = vec!["solve", EXAMPLE, "-m", "fork-head-bc", "--plugin", &lib, "--csv"];
        args.extend_from_slice(extra);
        stdout(&postpro(&args))
    };
    assert_eq!(declared(&["--tool-length", "60"]), declared(&[]));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bundled_example_is_post_processed_on_the_plugin_machine() {
    let lib = library("plugin-head-head");
    let o = postpro(&["--machine", "fork-head-bc", "--plugin", &lib, EXAMPLE, "-o", "-"]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let program = stdout(&o);
    let lines: Vec<&str> = program.lines().collect();
    assert!(lines[0].starts_with("0 BEGIN PGM HYPAR-5AXIS MM"), "a Heidenhain program: {}", lines[0]);
    assert!(lines[1].contains("fork-head-bc"), "{}", lines[1]);
    assert_eq!(
        lines[3], "3 ; fork head B/C: check the B/C kinematics of the controller before running",
        "the plugin's template"
    );
    assert!(lines.len() > 2000, "{} lines", lines.len());
    assert!(lines.last().is_some_and(|l| l.ends_with("END PGM HYPAR-5AXIS MM")), "{:?}", lines.last());
}

#[test]
fn the_definitions_only_plugin_lists_and_solves_its_machines() {
    let lib = library("plugin-yaml-machines");
    let o = postpro(&["machines", "--plugin", &lib]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let out = stdout(&o);
    for (name, topology) in [("shop-trunnion-ac", "5-axis table-table"), ("shop-vmc-a4", "4-axis (table)")] {
        let r = row(&out, name);
        assert!(r.contains(topology) && r.contains("generic") && r.ends_with(&format!("plugin {lib}")), "{r}");
    }
    let o = postpro(&["solve", EXAMPLE, "--machine", "trunnion-ac", "--plugin", &lib]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    insta::assert_snapshot!("yaml_only_solve", stdout(&o));
}

#[test]
fn a_wrong_abi_or_a_missing_symbol_exits_1_and_the_others_are_listed() {
    for (package, message) in [
        ("fixture-plugin-wrong-abi", "ABI version 7, expected 1".to_string()),
        ("fixture-plugin-no-entry", "is not a postpro plugin: it exports no symbol `postpro_plugin_entry`".into()),
    ] {
        let bad = library(package);
        let good = library("plugin-head-head");
        let o = postpro(&["machines", "--plugin", &bad, "--plugin", &good]);
        assert_eq!(o.status.code(), Some(1), "{package}");
        let err = stderr(&o);
        assert!(says(&err, &message), "{package}: {err}");
        assert!(says(&err, &bad), "names the library: {err}");
        let out = stdout(&o);
        row(&out, "mikron-ucp710");
        row(&out, "fork-head-bc");
        // Solving with it: exit 1 and the reason, even for a machine of another origin.
        let o = postpro(&["solve", EXAMPLE, "-m", "mikron", "--plugin", &bad]);
        assert_eq!(o.status.code(), Some(1), "{package}");
        assert!(says(&stderr(&o), &message), "{}", stderr(&o));
        assert!(stderr(&o).contains("error: a plugin given with --plugin does not load"), "{}", stderr(&o));
    }
}

#[test]
fn misbehaving_machines_are_refused_one_by_one() {
    let lib = library("fixture-plugin-misbehaving");
    let o = postpro(&["machines", "--plugin", &lib]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    for message in [
        "panicked in `inverse` of machine `fixture-panics`: fixture-panics: a bug in the inverse kinematics (at ",
        "failed in `inverse` of machine `fixture-error`: fixture-error: the head is not referenced",
        "returned no solution for machine `fixture-no-solution` at tip (",
        "returned an invalid solution for machine `fixture-invalid-solution` at tip (",
        "the kinematics of machine `fixture-disagrees` disagree with its definition",
        "the inverse kinematics of machine `fixture-one-branch` misses a solution",
        "it has kinematics for machine `fixture-undefined` but no definition of it",
        "axes[2].vmax: `30 m/min` is a linear velocity on a rotary axis",
    ] {
        assert!(says(&err, message), "missing `{message}` in:\n{err}");
    }
    assert!(err.contains(&format!("[plugin {lib}: machines/fixture-broken.yaml:7:96]")), "located: {err}");
    let out = stdout(&o);
    assert!(row(&out, "fixture-good").contains("  plugin  "), "{out}");
    for name in [
        "fixture-panics",
        "fixture-error",
        "fixture-no-solution",
        "fixture-invalid-solution",
        "fixture-disagrees",
        "fixture-one-branch",
    ] {
        assert!(row(&out, name).contains("plugin (refused)"), "{out}");
    }
    row(&out, "maho600e");

    for (name, message) in [
        ("fixture-panics", "panicked in `inverse`"),
        ("fixture-error", "fixture-error: the head is not referenced"),
        ("fixture-no-solution", "returned no solution"),
        ("fixture-invalid-solution", "returned an invalid solution"),
        ("fixture-disagrees", "disagree with its definition"),
        ("fixture-one-branch", "misses a solution"),
    ] {
        let o = postpro(&["solve", EXAMPLE, "-m", name, "--plugin", &lib]);
        assert_eq!(o.status.code(), Some(1), "{name}");
        assert!(says(&stderr(&o), message), "{name}: {}", stderr(&o));
        assert!(stdout(&o).is_empty(), "nothing solved");
    }
    let o = postpro(&["solve", EXAMPLE, "-m", "fixture-good", "--plugin", &lib]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("machine     fixture-good (5-axis head-head)\nkinematics  plugin "),
        "{}",
        stdout(&o)
    );
}

#[test]
fn plugins_are_found_through_the_plugin_path() {
    let dir = temp_dir("path");
    let copy = dir.join(library_file_name("plugin-head-head"));
    std::fs::copy(library("plugin-head-head"), &copy).expect("copy");
    let binary = Path::new(env!("CARGO_BIN_EXE_postpro"));
    let o = run(binary, &["machines"], Some(&dir));
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    assert!(row(&stdout(&o), "fork-head-bc").ends_with(&format!("plugin {}", copy.display())), "{}", stdout(&o));
    let o = run(binary, &["solve", EXAMPLE, "-m", "fork-head-bc"], Some(&dir));
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    // A folder that does not exist is an error, the rest is listed.
    let o = run(binary, &["machines"], Some(&dir.join("missing")));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("missing"), "{}", stderr(&o));
    row(&stdout(&o), "mikron-ucp710");
    // Without the path the plugin is not there.
    let o = postpro(&["solve", EXAMPLE, "-m", "fork-head-bc"]);
    assert_eq!(o.status.code(), Some(2), "an unknown machine: {}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plugins_are_found_beside_the_binary() {
    let dir = temp_dir("beside");
    let binary = dir.join(Path::new(env!("CARGO_BIN_EXE_postpro")).file_name().expect("name"));
    std::fs::copy(env!("CARGO_BIN_EXE_postpro"), &binary).expect("copy the binary");
    std::fs::create_dir_all(dir.join("plugins")).expect("plugins folder");
    let copy = dir.join("plugins").join(library_file_name("plugin-yaml-machines"));
    std::fs::copy(library("plugin-yaml-machines"), &copy).expect("copy the plugin");
    let o = run(&binary, &["machines"], None);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let out = stdout(&o);
    assert!(row(&out, "shop-trunnion-ac").ends_with(&format!("plugin {}", copy.display())), "{out}");
    row(&out, "shop-vmc-a4");
    let _ = std::fs::remove_dir_all(&dir);
}
