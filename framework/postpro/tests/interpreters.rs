//! Validation by real interpreters: every bundled example, post-processed by `postpro` on a
//! machine where it solves, is read by a real controller's interpreter, which must accept the
//! program and reach, block by block, exactly our joint targets (`postpro solve --csv`), to the
//! written precision.
//!
//! - The LinuxCNC dialect (modes `g1` and `inverse-time`) runs through LinuxCNC's standalone
//!   `rs274`, whose canonical calls `STRAIGHT_TRAVERSE(x, y, z, a, b, c)` and
//!   `STRAIGHT_FEED(x, y, z, a, b, c)` give the end point of every block (mm and degrees, four
//!   decimals). It stops at the first error with exit code 1 and the message and the offending
//!   line on standard error.
//! - The Siemens 840D dialect (same modes) is read by the PyPI package nc-gcode-interpreter
//!   (`tests/interpreters/siemens.py` prints its table: one row per program line, with the axis
//!   values, the motion and the feed type). It keeps numbers as 32-bit floats, so its values
//!   may differ from the written ones by half a unit of a float's last place as well.
//!
//! `.ci/run` installs both (`bash .ci/run interpreters` installs only them, to
//! `~/.cache/postpro-ci`, where these tests look; `POSTPRO_RS274` and `POSTPRO_NC_PYTHON` name
//! them elsewhere). Without them the tests pass with a "skipped" line, except under CI (the
//! variable `CI` set), where they fail: CI must validate.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use tests::ci_tools;

/// Each bundled example on a machine where it solves. The Manta (600 mm) exceeds the travels
/// of both built-ins; the nutating head-head example machine holds it.
const CASES: [(&str, &str); 6] = [
    ("examples/cl/hypar-5axis.cl", "maho600e"),
    ("examples/cl/hypar-5axis.cl", "mikron-ucp710"),
    ("examples/cl/bicubic-5axis.cl", "maho600e"),
    ("examples/cl/bicubic-5axis.cl", "mikron-ucp710"),
    ("examples/cl/manta-5axis.cl", "example-head-head-nutating"),
    ("examples/cl/hypar-3plus2.cl", "mikron-ucp710"),
];

const MODES: [&str; 2] = ["g1", "inverse-time"];

/// The order of the axis arguments of rs274's canonical motion calls.
const CANON_AXES: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/interpreters")
}

/// Where the programs are written (kept for a look after a failure).
fn out_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("interpreters");
    std::fs::create_dir_all(&dir).expect("the test's output folder");
    dir
}

fn under_ci() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty())
}

/// The interpreter named by `variable`, else the first candidate that `works`; when there is
/// none: a failure under CI, otherwise a "skipped" line (written past the test harness's output
/// capture, so that `cargo test` shows it) and `None`.
fn find_tool(what: &str, variable: &str, candidates: Vec<PathBuf>, works: impl Fn(&Path) -> bool) -> Option<PathBuf> {
    if let Some(path) = std::env::var_os(variable).filter(|v| !v.is_empty()) {
        let path = PathBuf::from(path);
        assert!(works(&path), "{variable}={} does not run {what}", path.display());
        return Some(path);
    }
    if let Some(path) = candidates.into_iter().find(|p| works(p)) {
        return Some(path);
    }
    let hint = format!("run `bash .ci/run interpreters`, which installs it in ~/.cache/postpro-ci, or set {variable}");
    assert!(!under_ci(), "{what} is not installed, and CI must validate the programs: {hint}");
    let _ = writeln!(std::io::stderr(), "skipped: {what} not installed ({hint})");
    None
}

fn rs274() -> Option<PathBuf> {
    let mut candidates: Vec<PathBuf> = ci_tools().map(|t| t.join("linuxcnc/rs274")).into_iter().collect();
    candidates.push(PathBuf::from("rs274"));
    find_tool("rs274", "POSTPRO_RS274", candidates, |p| {
        let program = out_dir().join("probe.ngc");
        std::fs::write(&program, "G0 X1\nM2\n").expect("probe program");
        Command::new(p)
            .arg("-g")
            .arg("-t")
            .arg(fixtures().join("tool.tbl"))
            .arg(&program)
            .stdin(Stdio::null())
            .output()
            .is_ok_and(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).contains("STRAIGHT_TRAVERSE"))
    })
}

fn nc_python() -> Option<PathBuf> {
    let mut candidates: Vec<PathBuf> = ci_tools().map(|t| t.join("venv/bin/python")).into_iter().collect();
    candidates.push(PathBuf::from("python3"));
    find_tool("nc-gcode-interpreter", "POSTPRO_NC_PYTHON", candidates, |p| {
        Command::new(p)
            .args(["-c", "import nc_gcode_interpreter"])
            .stdin(Stdio::null())
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// Runs `postpro` from the repository root.
fn postpro(args: &[&str]) -> Result<String, String> {
    let o = Command::new(env!("CARGO_BIN_EXE_postpro"))
        .args(args)
        .current_dir(repo())
        .stdin(Stdio::null())
        .output()
        .expect("postpro runs");
    if !o.status.success() {
        return Err(format!("postpro {} failed: {}", args.join(" "), String::from_utf8_lossy(&o.stderr)));
    }
    Ok(String::from_utf8(o.stdout).expect("postpro writes UTF-8"))
}

/// Our joint targets: `postpro solve FILE --machine NAME --csv`.
struct Targets {
    /// Axis letters in the machine's output order.
    axes: Vec<char>,
    rows: Vec<Target>,
}

struct Target {
    step: usize,
    /// The CL line of the position, and its kind (`cl`, `linearized`, `retract`…).
    cl_line: usize,
    kind: String,
    rapid: bool,
    values: Vec<f64>,
}

fn targets(file: &str, machine: &str) -> Targets {
    let csv = postpro(&["solve", file, "--machine", machine, "--csv"]).unwrap_or_else(|e| panic!("{e}"));
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a CSV header").split(',').collect();
    assert_eq!(header[..4], ["step", "line", "kind", "rapid"], "the CSV columns of postpro solve");
    let axes = header[4..].iter().map(|h| h.chars().next().expect("an axis column")).collect();
    let rows = lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            Target {
                step: f[0].parse().expect("step"),
                cl_line: f[1].parse().expect("line"),
                kind: f[2].to_string(),
                rapid: f[3] == "1",
                values: f[4..].iter().map(|v| v.parse().expect("an axis value")).collect(),
            }
        })
        .collect();
    Targets { axes, rows }
}

/// One emitted program.
struct Program {
    label: String,
    path: PathBuf,
    lines: Vec<String>,
    /// The decimals written for each axis (the most seen).
    decimals: Vec<u32>,
    /// The 1-based line numbers of the G0/G1 blocks, in order.
    motion_lines: Vec<usize>,
}

impl Program {
    fn line(&self, number: usize) -> &str {
        self.lines.get(number.wrapping_sub(1)).map_or("", |l| l.as_str())
    }
}

/// The code of a line: without its block number and its comments.
fn code(line: &str) -> &str {
    line.split(['(', ';']).next().unwrap_or("").trim()
}

fn emit(file: &str, machine: &str, dialect: &str, mode: &str, axes: &[char]) -> Result<Program, String> {
    let stem = Path::new(file).file_stem().and_then(|s| s.to_str()).unwrap_or("program");
    let extension = if dialect == "linuxcnc" { "ngc" } else { "mpf" };
    let path = out_dir().join(format!("{stem}__{machine}__{mode}.{extension}"));
    let out = path.to_str().expect("a UTF-8 path");
    postpro(&["--machine", machine, file, "--dialect", dialect, "--mode", mode, "-o", out])?;
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{out}: {e}"))?;
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut decimals = vec![0; axes.len()];
    let mut motion_lines = Vec::new();
    let mut negative_zero = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let mut tokens = code(line).split_whitespace().skip_while(|t| t.starts_with('N')).peekable();
        // A retract in machine coordinates (`G53 G0 Z…`) is a motion block too.
        if tokens.peek() == Some(&"G53") {
            tokens.next();
        }
        if !matches!(tokens.peek(), Some(&"G0" | &"G1")) {
            continue;
        }
        motion_lines.push(i + 1);
        for token in tokens {
            let mut chars = token.chars();
            let Some(letter) = chars.next() else { continue };
            let Some(k) = axes.iter().position(|&a| a == letter) else { continue };
            let number = chars.as_str();
            if number.starts_with('-') && number.trim_start_matches(['-', '0', '.']).is_empty() {
                negative_zero.push(format!("line {}: {token}", i + 1));
            }
            let d = number.split_once('.').map_or(0, |(_, f)| f.len() as u32);
            decimals[k] = decimals[k].max(d);
        }
    }
    if !negative_zero.is_empty() {
        return Err(format!("{out}: -0 written ({})", negative_zero.join(", ")));
    }
    let label = format!("{stem} on {machine}, {dialect} {mode} ({out})");
    Ok(Program { label, path, lines, decimals, motion_lines })
}

/// One motion block as an interpreter reports it.
struct Move {
    rapid: bool,
    /// The machine's axes, in the order of `Targets::axes`.
    values: Vec<f64>,
    /// The program line (1-based) of the block.
    line: usize,
}

/// The interpreter's block end points equal our targets, in order, to the written precision
/// (`slack(axis, value)` adds what the interpreter's own number handling may add). A target equal to the one
/// before it at the written precision may have no block: the program skips a move that changes
/// nothing. Between targets, a rapid may reach a position of its own: a move postpro adds at the
/// clearance (the retract, the rotary axes turned alone, the approach across then down); a feed
/// move never does. Returns the first mismatch.
fn compare(
    program: &Program,
    targets: &Targets,
    moves: &[Move],
    slack: impl Fn(usize, f64) -> f64,
) -> Result<usize, String> {
    let scale: Vec<f64> = program.decimals.iter().map(|&d| 10f64.powi(d as i32)).collect();
    let written =
        |values: &[f64]| -> Vec<i64> { values.iter().zip(&scale).map(|(v, s)| (v * s).round() as i64).collect() };
    let show = |values: &[f64]| -> String {
        targets.axes.iter().zip(values).map(|(a, v)| format!("{a}{v}")).collect::<Vec<_>>().join(" ")
    };
    let rows = &targets.rows;
    let mut i = 0;
    let mut previous: Option<Vec<i64>> = None;
    for m in moves {
        let equal = |t: &Target| {
            let close = |(k, (t, v)): (usize, (&f64, &f64))| (t - v).abs() <= 0.5 / scale[k] + slack(k, *t) + 1e-9;
            t.values.iter().zip(&m.values).enumerate().all(close)
        };
        while i < rows.len() && !equal(&rows[i]) && previous.as_ref() == Some(&written(&rows[i].values)) {
            i += 1;
        }
        let Some(t) = rows.get(i) else {
            if m.rapid {
                continue; // the retract and the rotary axes home at the end
            }
            return Err(format!(
                "line {} `{}`: a block after the last of our {} targets",
                m.line,
                program.line(m.line),
                rows.len()
            ));
        };
        if !equal(t) && m.rapid {
            continue; // a move at the clearance
        }
        if !equal(t) {
            return Err(format!(
                "line {} `{}`: the interpreter reached {}; our target (step {}, CL line {}, {}) is {}",
                m.line,
                program.line(m.line),
                show(&m.values),
                t.step,
                t.cl_line,
                t.kind,
                show(&t.values)
            ));
        }
        if m.rapid != t.rapid {
            let kind = |rapid| if rapid { "a rapid" } else { "a feed move" };
            return Err(format!(
                "line {} `{}`: {} where our target (step {}, CL line {}) is {}",
                m.line,
                program.line(m.line),
                kind(m.rapid),
                t.step,
                t.cl_line,
                kind(t.rapid)
            ));
        }
        previous = Some(written(&t.values));
        i += 1;
    }
    if let Some(t) = rows[i.min(rows.len())..].iter().find(|t| previous.as_ref() != Some(&written(&t.values))) {
        return Err(format!(
            "our target step {} (CL line {}) has no block: the interpreter stopped after {} blocks",
            t.step,
            t.cl_line,
            moves.len()
        ));
    }
    Ok(moves.len())
}

/// What rs274 made of a program.
struct Canon {
    moves: Vec<Move>,
    /// `(program line, feed mode)` of every feed move: the mode from the interpreter's last
    /// "feed mode set to …" comment.
    feed_modes: Vec<(usize, String)>,
    /// The feed mode at the program end.
    final_feed_mode: String,
    /// A few lines of the output, for the report.
    sample: String,
}

fn run_rs274(rs274: &Path, program: &Program, axes: &[char]) -> Result<Canon, String> {
    let o = Command::new(rs274)
        .arg("-g")
        .arg("-t")
        .arg(fixtures().join("tool.tbl"))
        .arg(&program.path)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("rs274 does not run: {e}"))?;
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let message: Vec<&str> = stderr.lines().filter(|l| l.trim() != "executing" && !l.trim().is_empty()).collect();
    let calls: Vec<&str> = stdout.lines().map(|l| l.trim_start().splitn(3, ' ').nth(2).unwrap_or("").trim()).collect();
    let moves_done = calls.iter().filter(|c| c.starts_with("STRAIGHT_")).count();
    if !o.status.success() || !message.is_empty() {
        // The message, then the offending block: find its line after the last block accepted.
        let after = program.motion_lines.get(moves_done.wrapping_sub(1)).copied().unwrap_or(0);
        let offending = message.last().map_or(0, |bad| {
            (after.max(1)..=program.lines.len()).find(|&n| program.line(n).trim() == bad.trim()).unwrap_or(0)
        });
        // rs274 repeats the offending block after its message: said once is enough.
        let message: Vec<&str> =
            message.into_iter().filter(|m| offending == 0 || m.trim() != program.line(offending).trim()).collect();
        return Err(format!(
            "rs274 rejected it ({}) at line {offending} `{}`: {}",
            o.status,
            program.line(offending),
            message.join(" / ")
        ));
    }
    if calls.last().copied() != Some("ON_RESET()") || !calls.contains(&"PROGRAM_END()") {
        return Err("rs274 did not reach the program end".to_string());
    }
    let index: Vec<usize> = axes
        .iter()
        .map(|a| CANON_AXES.iter().position(|c| c == a).unwrap_or_else(|| panic!("rs274 has no axis {a}")))
        .collect();
    let mut moves = Vec::new();
    let mut feed_modes = Vec::new();
    let mut feed_mode = "units per minute".to_string();
    let mut sample = String::new();
    for call in &calls {
        if let Some(mode) = call.strip_prefix("COMMENT(\"interpreter: feed mode set to ") {
            feed_mode = mode.trim_end_matches("\")").to_string();
        }
        if call.starts_with("ARC_FEED") || call.starts_with("NURBS") || call.starts_with("STRAIGHT_PROBE") {
            return Err(format!("rs274 made a move we never write: {call}"));
        }
        let (rapid, arguments) = if let Some(a) = call.strip_prefix("STRAIGHT_TRAVERSE(") {
            (true, a)
        } else if let Some(a) = call.strip_prefix("STRAIGHT_FEED(") {
            (false, a)
        } else {
            continue;
        };
        let numbers: Vec<f64> = arguments
            .trim_end_matches(')')
            .split(',')
            .map(|v| v.trim().parse().map_err(|_| format!("rs274 printed `{call}`")))
            .collect::<Result<_, _>>()?;
        if numbers.len() < CANON_AXES.len() {
            return Err(format!("rs274 printed `{call}`"));
        }
        let line = program.motion_lines.get(moves.len()).copied().unwrap_or(0);
        // The axes the machine lacks stay where the interpreter starts them: at 0.
        if let Some(k) = (0..CANON_AXES.len()).find(|k| !index.contains(k) && numbers[*k] != 0.0) {
            return Err(format!("line {line}: rs274 moved the axis {} the machine lacks: {call}", CANON_AXES[k]));
        }
        if !rapid {
            feed_modes.push((line, feed_mode.clone()));
        }
        if moves.len() < 3 {
            let _ = writeln!(sample, "{} → {call}", program.line(line));
        }
        moves.push(Move { rapid, values: index.iter().map(|&k| numbers[k]).collect(), line });
    }
    if moves.len() != program.motion_lines.len() {
        return Err(format!(
            "rs274 reported {} motion blocks for the program's {} G0/G1 lines",
            moves.len(),
            program.motion_lines.len()
        ));
    }
    Ok(Canon { moves, feed_modes, final_feed_mode: feed_mode, sample })
}

#[test]
fn the_cases_cover_every_bundled_example() {
    let mut examples: Vec<String> = std::fs::read_dir(repo().join("examples/cl"))
        .expect("examples/cl")
        .map(|e| format!("examples/cl/{}", e.expect("an entry").file_name().to_string_lossy()))
        .filter(|name| name.ends_with(".cl"))
        .collect();
    examples.sort();
    for example in examples {
        assert!(CASES.iter().any(|(file, _)| *file == example), "{example} is not validated: add it to CASES");
    }
}

/// The LinuxCNC program of every example, in both modes, passes rs274, and its
/// `STRAIGHT_TRAVERSE` / `STRAIGHT_FEED` end points are our joint targets; every feed move runs
/// in the mode asked for (G93 in inverse time), and G94 is back at the end.
#[test]
fn rs274_accepts_the_linuxcnc_programs_and_reaches_our_targets() {
    let Some(rs274) = rs274() else { return };
    let mut failures = Vec::new();
    let mut report = String::new();
    for (file, machine) in CASES {
        let targets = targets(file, machine);
        for mode in MODES {
            let result = emit(file, machine, "linuxcnc", mode, &targets.axes).and_then(|program| {
                let canon =
                    run_rs274(&rs274, &program, &targets.axes).map_err(|e| format!("{}: {e}", program.label))?;
                // rs274 prints four decimals: beyond those, its own rounding adds up to half a unit.
                let slack = |k: usize, _: f64| if program.decimals[k] > 4 { 0.5e-4 } else { 0.0 };
                let blocks =
                    compare(&program, &targets, &canon.moves, slack).map_err(|e| format!("{}: {e}", program.label))?;
                let wanted = if mode == "inverse-time" { "inverse time" } else { "units per minute" };
                if let Some((line, m)) = canon.feed_modes.iter().find(|(_, m)| m != wanted) {
                    return Err(format!("{}: line {line}: a feed move in {m} mode", program.label));
                }
                if canon.final_feed_mode != "units per minute" {
                    return Err(format!("{}: the program ends in {} mode", program.label, canon.final_feed_mode));
                }
                Ok((program.label, blocks, canon.sample))
            });
            tally(result, &mut report, &mut failures);
        }
    }
    let _ = writeln!(std::io::stderr(), "{report}");
    assert!(failures.is_empty(), "{} program(s) failed in rs274:\n{}", failures.len(), failures.join("\n"));
}

/// What nc-gcode-interpreter made of a program: `siemens.py`'s rows.
fn run_nc_gcode_interpreter(python: &Path, program: &Program, axes: &[char]) -> Result<Canon, String> {
    let letters: String = axes.iter().collect();
    let o = Command::new(python)
        .arg(fixtures().join("siemens.py"))
        .arg(&program.path)
        .arg(&letters)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{} does not run: {e}", python.display()))?;
    if !o.status.success() {
        return Err(format!("nc-gcode-interpreter rejected it: {}", String::from_utf8_lossy(&o.stderr).trim()));
    }
    let stdout = String::from_utf8_lossy(&o.stdout);
    let mut rows = stdout.lines();
    let header = rows.next().unwrap_or("");
    let columns: Vec<String> = axes.iter().map(char::to_string).collect();
    if header != format!("row,motion,feed_type,f,programmed,{}", columns.join(",")) {
        return Err(format!("siemens.py printed `{header}`"));
    }
    let mut moves = Vec::new();
    let mut feed_modes = Vec::new();
    let mut final_feed_mode = String::new();
    let mut sample = String::new();
    let mut skipped = Vec::new();
    let rows: Vec<&str> = rows.collect();
    if rows.len() != program.lines.len() {
        return Err(format!(
            "nc-gcode-interpreter made {} rows of the program's {} lines",
            rows.len(),
            program.lines.len()
        ));
    }
    for (i, row) in rows.iter().enumerate() {
        let line = i + 1;
        let f: Vec<&str> = row.split(',').collect();
        final_feed_mode = f[2].to_string();
        if f[4].is_empty() {
            continue;
        }
        let rapid = match f[1] {
            "G0" => true,
            "G1" => false,
            other => return Err(format!("line {line} `{}`: motion `{other}`", program.line(line))),
        };
        let values = f[5..]
            .iter()
            .zip(axes)
            .map(|(v, a)| v.parse().map_err(|_| format!("line {line} `{}`: no value for {a} yet", program.line(line))))
            .collect::<Result<Vec<f64>, _>>();
        let values = match values {
            Ok(values) => values,
            // Before every axis has a value: the retract and the rotation at the clearance that
            // start the program (rapids only).
            Err(_) if rapid => {
                skipped.push(line);
                continue;
            }
            Err(e) => return Err(e),
        };
        if !rapid {
            // In G93 every feed block carries its own F.
            let mode = if f[2] == "G93" && f[3].is_empty() { "G93 without F" } else { f[2] };
            feed_modes.push((line, mode.to_string()));
        }
        if moves.len() < 3 {
            let _ = writeln!(sample, "{} → {row}", program.line(line));
        }
        moves.push(Move { rapid, values, line });
    }
    let mut lines: Vec<usize> = moves.iter().map(|m| m.line).chain(skipped).collect();
    lines.sort_unstable();
    if lines != program.motion_lines {
        return Err("nc-gcode-interpreter's motion blocks are not the program's G0/G1 lines".to_string());
    }
    Ok(Canon { moves, feed_modes, final_feed_mode, sample })
}

/// The Siemens 840D program of every example, in both modes, reads with nc-gcode-interpreter,
/// and the axis values it holds after each block are our joint targets; every feed move is G93
/// with F in inverse time (G94 otherwise), and G94 is back at the end.
#[test]
fn nc_gcode_interpreter_reads_the_siemens_programs_with_our_targets() {
    let Some(python) = nc_python() else { return };
    let mut failures = Vec::new();
    let mut report = String::new();
    for (file, machine) in CASES {
        let targets = targets(file, machine);
        for mode in MODES {
            let result = emit(file, machine, "siemens-840d", mode, &targets.axes).and_then(|program| {
                let read = run_nc_gcode_interpreter(&python, &program, &targets.axes)
                    .map_err(|e| format!("{}: {e}", program.label))?;
                // Its numbers are 32-bit floats: half a unit of their last place more.
                let slack = |_: usize, v: f64| v.abs() * f64::from(f32::EPSILON) / 2.0;
                let blocks =
                    compare(&program, &targets, &read.moves, slack).map_err(|e| format!("{}: {e}", program.label))?;
                let wanted = if mode == "inverse-time" { "G93" } else { "G94" };
                if let Some((line, m)) = read.feed_modes.iter().find(|(_, m)| m != wanted) {
                    return Err(format!(
                        "{}: line {line} `{}`: a feed move in {m}",
                        program.label,
                        program.line(*line)
                    ));
                }
                if read.final_feed_mode != "G94" {
                    return Err(format!("{}: the program ends in {}", program.label, read.final_feed_mode));
                }
                Ok((program.label, blocks, read.sample))
            });
            tally(result, &mut report, &mut failures);
        }
    }
    let _ = writeln!(std::io::stderr(), "{report}");
    assert!(
        failures.is_empty(),
        "{} program(s) failed in nc-gcode-interpreter:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Adds one program's outcome to the report (with the first program's sample) or the failures.
fn tally(result: Result<(String, usize, String), String>, report: &mut String, failures: &mut Vec<String>) {
    match result {
        Ok((label, blocks, sample)) => {
            let _ = writeln!(report, "{label}: {blocks} blocks equal our targets");
            if report.lines().count() == 1 {
                let _ = writeln!(report, "{sample}");
            }
        }
        Err(e) => failures.push(e),
    }
}
