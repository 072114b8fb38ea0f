//! Command-line tests of `postpro check` and `postpro solve`: what a user sees
//! and the exit codes (0 when the file reads, 1 for input errors, 2 for usage errors).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root (this crate sits in `<repo>/framework/postpro`).
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `postpro` from the repository root, so that relative paths read as a user types them.
fn postpro(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postpro")).args(args).current_dir(repo()).output().expect("postpro runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).expect("stdout is UTF-8")
}

fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).expect("stderr is UTF-8")
}

const EXAMPLE: &str = "examples/cl/hypar-5axis.cl";
const ERROR_CASE: &str = "tests/cl/err_goto_arity.cl";
const WARNING_CASE: &str = "tests/cl/warn_unknown_word.cl";

#[test]
fn check_prints_a_table_for_an_example() {
    let o = postpro(&["check", EXAMPLE]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let out = stdout(&o);
    for line in [
        format!("file            {EXAMPLE}"),
        "CAM system      postpro example generator".to_string(),
        "units           mm (feed word at 25:1); figures below in mm".to_string(),
        "axes            5-axis".to_string(),
        "tools           T1 BALL_D10 D10 R5".to_string(),
        "errors          0".to_string(),
    ] {
        assert!(out.lines().any(|l| l == line), "missing `{line}` in:\n{out}");
    }
    for label in ["moves", "statements", "feeds", "spindle", "bounding box", "path length", "warnings"] {
        assert!(out.lines().any(|l| l.starts_with(label)), "no `{label}` row in:\n{out}");
    }
    assert!(stderr(&o).is_empty(), "an example has no diagnostics:\n{}", stderr(&o));
}

#[test]
fn check_json_has_the_stable_keys() {
    let o = postpro(&["check", "--json", EXAMPLE]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("stdout is JSON");
    let keys =
        |v: &serde_json::Value| -> BTreeSet<String> { v.as_object().expect("an object").keys().cloned().collect() };
    let expected = |names: &[&str]| -> BTreeSet<String> { names.iter().map(|s| s.to_string()).collect() };
    assert_eq!(
        keys(&json),
        expected(&[
            "file",
            "cam_system",
            "part_name",
            "units",
            "axes",
            "statements",
            "moves",
            "arcs",
            "nurbs",
            "tools",
            "feeds",
            "spindle",
            "bounding_box",
            "path_length",
            "axis_changes",
            "operations",
            "frames",
            "uninterpreted_words",
            "unknown_words",
            "warnings",
            "errors",
            "listing_lines",
            "start_points",
        ])
    );
    assert_eq!(keys(&json["units"]), expected(&["file", "origin", "at"]));
    assert_eq!(keys(&json["moves"]), expected(&["total", "feed", "rapid", "holes"]));
    assert_eq!(keys(&json["feeds"]), expected(&["per_minute", "per_revolution", "distinct"]));
    assert_eq!(keys(&json["bounding_box"]), expected(&["min", "max"]));
    assert_eq!(keys(&json["path_length"]), expected(&["feed", "rapid"]));
    assert_eq!(keys(&json["warnings"]), expected(&["total", "by_word"]));
    assert_eq!(keys(&json["tools"][0]), expected(&["number", "name", "diameter", "corner_radius", "loads"]));
    assert_eq!(json["file"], EXAMPLE);
    assert_eq!(json["axes"], "5-axis");
    assert_eq!(json["errors"], 0);
    assert_eq!(json["units"]["file"], "mm");
}

#[test]
fn an_error_exits_1_and_names_file_line_column() {
    let o = postpro(&["check", ERROR_CASE]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    // Rendered with the source line and a caret under the arguments.
    assert!(err.contains(&format!("[{ERROR_CASE}:2:6]")), "{err}");
    assert!(err.contains("GOTO has 4 values"), "{err}");
    assert!(err.contains("expected 3 values (x,y,z) or 6 (x,y,z,i,j,k)"), "{err}");
    assert!(err.contains("GOTO/1,2,3,4"), "the source line is shown:\n{err}");
    // The summary is still printed, and counts the error.
    assert!(stdout(&o).lines().any(|l| l == "errors          1"), "{}", stdout(&o));
}

#[test]
fn brief_prints_one_line_per_diagnostic() {
    let o = postpro(&["check", "--brief", ERROR_CASE]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        stderr(&o),
        format!(
            "{ERROR_CASE}:2:6: error[cl::statement]: GOTO has 4 values: \
             expected 3 values (x,y,z) or 6 (x,y,z,i,j,k)\n"
        )
    );
    // Warnings alone do not fail the check.
    let o = postpro(&["check", "--brief", WARNING_CASE]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let lines: Vec<String> = stderr(&o).lines().map(str::to_string).collect();
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert!(lines.iter().all(|l| l.starts_with(&format!("{WARNING_CASE}:")) && l.contains(": warning[")), "{lines:?}");
}

#[test]
fn errors_are_listed_before_warnings() {
    let dir = std::env::temp_dir().join(format!("postpro-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    let file = dir.join("mixed.cl");
    std::fs::write(&file, "COOLNT/\nGOTO/1,2,3,4\n").expect("a temporary file");
    let o = postpro(&["check", "--brief", file.to_str().expect("a UTF-8 path")]);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(lines[0].contains("mixed.cl:2:6: error["), "{err}");
    assert!(lines[1].contains("mixed.cl:1:1: warning["), "{err}");
}

#[test]
fn a_missing_file_exits_1_with_a_clear_message() {
    let o = postpro(&["check", "no/such/file.cl"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.starts_with("error: cannot read no/such/file.cl: "), "{err}");
    assert!(err.contains("No such file") || err.contains("cannot find"), "the OS reason is given: {err}");
    assert!(stdout(&o).is_empty(), "no summary for a file that does not read");
}

#[test]
fn usage_errors_exit_2() {
    for args in [
        &["check", "--bogus", EXAMPLE][..], // unknown flag
        &["check"],                         // missing FILE
        &["check", EXAMPLE, "extra.cl"],    // one FILE only
        &["frobnicate", EXAMPLE],           // unknown command
        &[],                                // no command
    ] {
        let o = postpro(args);
        assert_eq!(o.status.code(), Some(2), "postpro {args:?}:\n{}", stderr(&o));
        assert!(stderr(&o).contains("Usage:"), "postpro {args:?} explains the usage:\n{}", stderr(&o));
        assert!(stdout(&o).is_empty(), "postpro {args:?}");
    }
    let err = stderr(&postpro(&["check"]));
    assert!(err.contains("<FILE>"), "names the missing argument: {err}");
}

#[test]
fn help_and_version_exit_0() {
    let o = postpro(&["check", "--help"]);
    assert_eq!(o.status.code(), Some(0));
    for flag in ["--json", "--brief", "--timing"] {
        assert!(stdout(&o).contains(flag), "{}", stdout(&o));
    }
    let o = postpro(&["--version"]);
    assert_eq!(o.status.code(), Some(0));
    assert!(stdout(&o).starts_with("postpro "), "{}", stdout(&o));
}

#[test]
fn timing_goes_to_stderr() {
    let o = postpro(&["check", "--timing", "--json", EXAMPLE]);
    assert_eq!(o.status.code(), Some(0));
    assert!(stderr(&o).contains("MB/s"), "{}", stderr(&o));
    if cfg!(target_os = "linux") {
        assert!(stderr(&o).contains("MB/s; peak memory "), "{}", stderr(&o));
    }
    // stdout stays machine-readable.
    serde_json::from_str::<serde_json::Value>(&stdout(&o)).expect("stdout is JSON");
}

// ----- postpro solve --------------------------------------------------------------------------

const FORCED_SWITCH: &str = "tests/kin/forced-branch-switch.cl";

#[test]
fn solve_prints_the_positions_and_decisions_of_an_example() {
    let o = postpro(&["solve", EXAMPLE, "--machine", "maho"]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("machine     maho600e (5-axis table-table)"), "{out}");
    assert!(out.contains("positions   "), "{out}");
    assert!(out.contains("axis B"), "{out}");
    assert!(out.contains(&format!("  {EXAMPLE}:")), "decisions name file:line:column:\n{out}");
}

#[test]
fn solve_csv_has_one_column_per_axis() {
    let o = postpro(&["solve", EXAMPLE, "-m", "mikron", "--csv"]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let out = stdout(&o);
    let mut lines = out.lines();
    assert_eq!(lines.next(), Some("step,line,kind,rapid,X_mm,Y_mm,Z_mm,A_deg,C_deg"));
    let first = lines.next().expect("a first position");
    assert_eq!(first.split(',').count(), 9, "{first}");
}

/// A tilt through the pole from one branch's side to the other is motion: the table turns at the
/// pole, in large steps that are said, not refused.
#[test]
fn a_pass_through_the_pole_turns_the_table_there() {
    let o = postpro(&["solve", FORCED_SWITCH, "-m", "mikron"]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains(&format!("{FORCED_SWITCH}:56:1: large rotary step: C 0.000° → -90.000°")), "{out}");
    assert!(out.contains("axis C      -180.0000 … 0.0000°"), "{out}");
}

/// A rotary axis at the end of its travel during a feed move is a discontinuity: an error naming
/// the CL line, or, by policy, a retract.
#[test]
fn a_discontinuity_is_an_error_naming_the_line_or_a_retract() {
    const TRAVEL_LIMIT: &str = "tests/kin/travel-limit.cl";
    let o = postpro(&["solve", TRAVEL_LIMIT, "-m", "nutating", "--on-discontinuity", "error"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains("no continuous solution (a rotary axis reaches the end of its travel)"), "{err}");
    assert!(err.contains(&format!("[{TRAVEL_LIMIT}:82:1]")), "{err}");
    let o = postpro(&["solve", TRAVEL_LIMIT, "-m", "nutating", "--on-discontinuity", "retract:20"]);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    assert!(stdout(&o).contains(&format!("{TRAVEL_LIMIT}:82:1: retract 20 mm, reorient, re-engage")), "{}", stdout(&o));
}

#[test]
fn solve_usage_errors_exit_2() {
    let o = postpro(&["solve", EXAMPLE, "-m", "mikorn"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("mikron"), "suggests the nearest name: {}", stderr(&o));
    for bad in [["--branch", "sideways"], ["--on-discontinuity", "ignore"], ["--tolerance", "-1"], ["--branch", "+Q"]] {
        let o = postpro(&["solve", EXAMPLE, "-m", "mikron", bad[0], bad[1]]);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", stderr(&o));
    }
}

#[test]
fn a_broken_machine_file_exits_1_with_its_location() {
    let dir = std::env::temp_dir().join(format!("postpro-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("broken.yaml");
    let text = std::fs::read_to_string(repo().join("machine-defs/mikron-ucp710.yaml")).expect("mikron");
    std::fs::write(&file, text.replace("vmax: 0.5 m/s", "vmax: 0.5 m/s^2")).expect("write");
    let o = postpro(&["solve", EXAMPLE, "-m", file.to_str().expect("utf-8 path")]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("broken.yaml:"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn no_progress_bar_is_drawn_when_standard_error_is_not_a_terminal() {
    let out = std::env::temp_dir().join(format!("postpro-cli-progress-{}.nc", std::process::id()));
    let o = postpro(&["--machine", "maho600e", "examples/cl/manta-5axis.cl", "-o", &out.to_string_lossy()]);
    let _ = std::fs::remove_file(&out);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("wrote "), "{err}");
    assert!(!err.contains('\r') && !err.contains('\u{1b}') && !err.contains("[=="), "{err:?}");
}

#[test]
fn a_span_beyond_the_travel_in_an_inch_file_asks_whether_its_values_are_millimetres() {
    // Creo writes `UNITS / INCHES` over millimetre values: a 250 mm part read as 250 inches.
    let dir = std::env::temp_dir().join(format!("postpro-cli-inches-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let cl = dir.join("creo.ncl");
    let moves: String = (0..=10).map(|i| format!("GOTO / {}.0, 20.0, 5.0\n", 25 * i)).collect();
    let text = format!("UNITS / INCHES\nLOADTL / 2\nSPINDL / RPM, 8000, CLW\nCOOLNT / ON\nFEDRAT / 1000, IPM\n{moves}");
    std::fs::write(&cl, text).expect("write");
    let out = dir.join("creo.nc");
    let (cl, out) = (cl.to_string_lossy(), out.to_string_lossy());
    let o = postpro(&["--machine", "mikron", &cl, "-o", &out]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("the program spans 6350 mm in X but its travel is 710 mm"), "{err}");
    assert!(
        err.contains(
            "read as inches, as its UNITS statement says: if they are millimetres, post it with `--cl-units mm`"
        ),
        "{err}"
    );
    // Read as millimetres, the part fits: no span warning.
    let o = postpro(&["--machine", "mikron", &cl, "-o", &out, "--cl-units", "mm"]);
    let err = stderr(&o);
    assert!(o.status.success() && !err.contains("spans"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
