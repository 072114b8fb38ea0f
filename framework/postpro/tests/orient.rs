//! Command-line tests of `postpro orient` (paper 004) on the bundled hyperbolic paraboloid and
//! the Mikron: the table of the 3+2 example (pinned) and what it must say (the polytope's best
//! jerk per path and for the whole part, the rulings as feed directions, the predicted cycle
//! times), the JSON agreeing with it, the programs `--apply` writes (every path at its set-up's
//! rotary angles, the ball centre kept), the 5-axis example left as programmed, and the error
//! cases (exit code and message pinned, nothing written).

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{files, number, postpro, repo, stderr, stdout};

use serde_json::Value;

/// The Mikron's interpolation period (s): the switching error of a predicted time.
const MIKRON_PERIOD: f64 = 0.003;
const EXAMPLE: &str = "examples/cl/hypar-3plus2.cl";
/// The example's file name, as it is called inside a scratch folder.
const CL: &str = "hypar-3plus2.cl";
const FIVE_AXIS: &str = "examples/cl/hypar-5axis.cl";
const FIVE_AXIS_CL: &str = "hypar-5axis.cl";
const MACHINE: &str = "mikron";
/// The example's rulings, one path each.
const PATHS: usize = 49;
/// The Mikron's A travel (degrees).
const A_TRAVEL: (f64, f64) = (-120.0, 30.0);
/// The ball's radius (BALL_D16).
const BALL_RADIUS: f64 = 8.0;

/// A fresh folder with a copy of the example(s).
fn scratch(name: &str) -> PathBuf {
    common::scratch("orient", name, &[(EXAMPLE, CL), (FIVE_AXIS, FIVE_AXIS_CL)])
}

fn read(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// `x` to `decimals` as printed, so that a JSON figure can be compared with a printed one.
fn printed(x: f64, decimals: usize) -> String {
    format!("{x:.decimals$}")
}

/// The polytope's best tangential jerk on the Mikron: 5·√3 m/s³ (every linear axis 5 m/s³).
fn vertex_jerk() -> f64 {
    5.0 * 3f64.sqrt()
}

// ----- The table ----------------------------------------------------------------------------------

/// A set-up and its reach as a row prints them: `A -26.281 C  -8.255    8.66    3.64  0.866`.
#[derive(Debug, Clone, PartialEq)]
struct Reach {
    a: f64,
    c: f64,
    /// m/s³, m/s², m/s.
    jerk: f64,
    acceleration: f64,
    velocity: f64,
}

/// One path row of the table.
#[derive(Debug)]
struct Row {
    path: usize,
    line: usize,
    length: f64,
    direction: [f64; 3],
    /// The path's predicted time in the original set-up and in its own (s).
    times: [f64; 2],
    original: Reach,
    best: Reach,
}

/// What the table says.
struct Table {
    /// The whole part's set-up, from `  set-up A -45.000 C  -9.736   jerk 8.66 m/s³, ...`.
    whole: Reach,
    /// The predicted cycle times: the original, the whole part, per path (s).
    original_time: f64,
    whole_time: f64,
    per_path_time: f64,
    rows: Vec<Row>,
}

/// The tokens of a set-up and reach: the rotary letters split from their values.
fn tokens(text: &str) -> Vec<String> {
    text.replace('A', " A ").replace('C', " C ").split_whitespace().map(str::to_string).collect()
}

fn reach(t: &[String]) -> Reach {
    assert_eq!((t[0].as_str(), t[2].as_str()), ("A", "C"), "A and C, in order: {t:?}");
    Reach {
        a: number(&t[1]),
        c: number(&t[3]),
        jerk: number(&t[4]),
        acceleration: number(&t[5]),
        velocity: number(&t[6]),
    }
}

/// The seconds at the start of what follows `label` on its line (`101.42 s (-3.9 %)`).
fn seconds(text: &str, label: &str) -> f64 {
    let line = text.lines().find(|l| l.starts_with(label)).unwrap_or_else(|| panic!("no `{label}` in:\n{text}"));
    let rest = line[label.len()..].trim_start();
    let value = rest.strip_suffix(" s").or_else(|| rest.split_once(" s (").map(|(v, _)| v));
    number(value.unwrap_or_else(|| panic!("seconds in `{line}`")))
}

fn table(text: &str) -> Table {
    let setup = text.lines().find(|l| l.starts_with("  set-up ")).unwrap_or_else(|| panic!("a set-up:\n{text}"));
    let (angles, rest) = setup["  set-up ".len()..].split_once("   jerk ").expect("the set-up's jerk");
    // `8.66 m/s³, acceleration 3.64 m/s², velocity 0.866 m/s; tool axis (…)`
    let words: Vec<&str> = rest.split_whitespace().collect();
    let after = |label: &str| words.iter().position(|w| *w == label).map(|i| words[i + 1]).expect(label);
    let mut t = tokens(angles);
    t.extend([words[0], after("acceleration"), after("velocity")].map(str::to_string));
    let whole = reach(&t);

    let rows = text
        .lines()
        .skip_while(|l| !l.starts_with(" path   line"))
        .skip(1)
        .take_while(|l| !l.is_empty() && !l.starts_with("note: "))
        .map(|row| {
            let (head, rest) = row.split_once('(').unwrap_or_else(|| panic!("a feed direction: `{row}`"));
            let (direction, rest) = rest.split_once(')').expect("the direction's end");
            let head: Vec<&str> = head.split_whitespace().collect();
            assert_eq!(head.len(), 3, "path, line, length: `{row}`");
            let direction: Vec<f64> = direction.split(", ").map(number).collect();
            // The path's time, original → with its own set-up, then the two set-ups.
            let (times, rest) = rest.trim_start().split_once("    A").expect("the times");
            let times: Vec<f64> = times.split(" → ").map(|t| number(t.trim())).collect();
            assert_eq!(times.len(), 2, "original and per-path time: `{row}`");
            let t = tokens(&format!("A{rest}"));
            assert_eq!(t.len(), 14, "the original and the best set-up: `{row}`");
            Row {
                path: number(head[0]) as usize,
                line: number(head[1]) as usize,
                length: number(head[2]),
                direction: [direction[0], direction[1], direction[2]],
                times: [times[0], times[1]],
                original: reach(&t[..7]),
                best: reach(&t[7..]),
            }
        })
        .collect();
    Table {
        whole,
        original_time: seconds(text, "  original set-up"),
        whole_time: seconds(text, "  one set-up, whole part"),
        per_path_time: seconds(text, "  one set-up per path"),
        rows,
    }
}

/// `postpro orient` on the example with the cone open to 90°: its table and its JSON.
struct Run {
    text: String,
    table: Table,
    json: Value,
}

fn run() -> &'static Run {
    static RUN: OnceLock<Run> = OnceLock::new();
    RUN.get_or_init(|| {
        let o = postpro(&["orient", EXAMPLE, "--machine", MACHINE, "--cone", "90"], &repo());
        assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
        assert!(stderr(&o).is_empty(), "nothing on stderr: {}", stderr(&o));
        let text = stdout(&o);
        let o = postpro(&["orient", EXAMPLE, "--machine", MACHINE, "--cone", "90", "--json"], &repo());
        assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
        assert!(stderr(&o).is_empty(), "nothing on stderr: {}", stderr(&o));
        let json = serde_json::from_str(&stdout(&o)).expect("--json prints JSON");
        Run { table: table(&text), text, json }
    })
}

#[test]
fn the_table_points_every_ruling_and_the_whole_part_at_a_jerk_vertex() {
    let Run { text, table: t, .. } = run();
    insta::assert_snapshot!("hypar_3plus2_mikron_cone_90", text);
    assert!(
        text.starts_with(&format!(
            "{EXAMPLE} on mikron-ucp710: {PATHS} paths, 3558.9 mm of feed; jerk vertices, tool axes within 90° of the program's\n"
        )),
        "{text}"
    );

    // The whole part: the rulings all run along ±(1, 1, ·), the polytope's best jerk is reached.
    assert!(text.contains("whole part: feed direction (0.707, 0.707, "), "{text}");
    assert_eq!(printed(t.whole.jerk, 2), printed(vertex_jerk(), 2), "the whole part at 5·√3 m/s³:\n{text}");
    assert!((A_TRAVEL.0..=A_TRAVEL.1).contains(&t.whole.a), "A within its travel: {:?}", t.whole);

    // Every ruling is a path, along the ruling, at the vertex's jerk; every original set-up below it.
    assert_eq!(t.rows.len(), PATHS, "{text}");
    for (i, r) in t.rows.iter().enumerate() {
        assert_eq!(r.path, i + 1, "paths numbered in order: {r:?}");
        assert!(r.length > 5.0 && r.length < 142.0, "a ruling of the 100 mm square: {r:?}");
        assert!((r.direction[0] - r.direction[1]).abs() <= 1e-3, "along a ruling y = x + c: {r:?}");
        assert!((r.direction.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-2, "a unit direction: {r:?}");
        assert_eq!(printed(r.best.jerk, 2), printed(vertex_jerk(), 2), "the best at the vertex: {r:?}");
        assert!(r.original.jerk < r.best.jerk, "the original below the best: {r:?}");
        assert!((7.0..=7.4).contains(&r.original.jerk), "the programmed set-up reaches 7.1–7.3 m/s³: {r:?}");
        assert_eq!((r.original.a, r.original.c), (0.0, 0.0), "programmed with the tool along +z: {r:?}");
        assert!((A_TRAVEL.0..=A_TRAVEL.1).contains(&r.best.a), "A within its travel: {r:?}");
        // A single jerk-limited pass is faster with more jerk: its own set-up beats the original,
        // up to the interpolator's switching error of one period (the Mikron's 3 ms; the
        // shortest rulings, 0.27 s, gain less than that).
        assert!(r.times[1] < r.times[0] + MIKRON_PERIOD, "the path is faster at its vertex: {r:?}");
    }
    assert!(t.rows.windows(2).all(|w| w[0].line < w[1].line), "the paths follow the CL file");
    // The zig-zag: the rulings alternate in sense; the longest is the diagonal, in the middle.
    assert!(t.rows.windows(2).all(|w| w[0].direction[0] * w[1].direction[0] < 0.0), "a zig-zag");
    assert!((t.rows[PATHS / 2].length - 100.0 * 2f64.sqrt()).abs() < 0.1, "{:?}", t.rows[PATHS / 2]);

    // The predicted cycle times: the re-oriented programs are faster than the original.
    assert!(text.contains("\npredicted cycle time (g1 mode)\n"), "{text}");
    assert!(t.original_time > 0.0 && t.whole_time > 0.0 && t.per_path_time > 0.0);
    assert!(
        t.whole_time < t.original_time,
        "one set-up at the vertex is faster than the original: {} s against {} s",
        t.whole_time,
        t.original_time
    );
    let percent = |time: f64| format!("({:+.1} %)", (time / t.original_time - 1.0) * 100.0);
    assert!(text.contains(&format!("whole part   {:.2} s {}", t.whole_time, percent(t.whole_time))), "{text}");
    assert!(text.contains(&format!("per path      {:.2} s {}", t.per_path_time, percent(t.per_path_time))), "{text}");
    assert!(!text.contains("note: "), "a ball-end mill with its shape: no note\n{text}");
}

#[test]
fn the_original_cycle_time_is_the_one_predict_gives() {
    let t = &run().table;
    let o = postpro(&["predict", EXAMPLE, "--machine", MACHINE, "--mode", "g1"], &repo());
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let predicted = seconds(&stdout(&o), "predicted cycle time");
    assert_eq!(printed(predicted, 2), printed(t.original_time, 2));
}

// ----- JSON -----------------------------------------------------------------------------------------

fn f(v: &Value, what: &str) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{what} is a number: {v}"))
}

/// The A and C of a set-up in the JSON (degrees), checking it names those two and no other.
fn angles(best: &Value, what: &str) -> (f64, f64) {
    let map = best["angles_deg"].as_object().unwrap_or_else(|| panic!("{what}: angles_deg: {best}"));
    let keys: Vec<&str> = map.keys().map(String::as_str).collect();
    assert_eq!(keys, ["A", "C"], "{what}: the Mikron's rotary axes");
    (f(&map["A"], "A"), f(&map["C"], "C"))
}

/// A JSON set-up as the table prints it.
fn as_printed(best: &Value, what: &str) -> Reach {
    let (a, c) = angles(best, what);
    Reach {
        a: number(&printed(a, 3)),
        c: number(&printed(c, 3)),
        jerk: number(&printed(f(&best["jerk_mm_s3"], "jerk") / 1000.0, 2)),
        acceleration: number(&printed(f(&best["acceleration_mm_s2"], "acceleration") / 1000.0, 2)),
        velocity: number(&printed(f(&best["velocity_mm_s"], "velocity") / 1000.0, 3)),
    }
}

#[test]
fn the_json_says_what_the_table_says() {
    let Run { table: t, json, .. } = run();
    assert_eq!(json["file"], EXAMPLE);
    assert_eq!(json["machine"], "mikron-ucp710");
    assert_eq!(json["level"], "jerk");
    assert_eq!(json["mode"], "g1");
    assert_eq!(f(&json["cone_deg"], "cone"), 90.0);
    assert_eq!(json["notes"], serde_json::json!([]));

    // The whole part: the vertex's jerk, the table's set-up, its tool axis a unit vector within
    // the cone (the program's is +z).
    let whole = &json["whole_part"]["best"];
    assert!((f(&whole["jerk_mm_s3"], "jerk") - 1000.0 * vertex_jerk()).abs() < 1e-6, "{whole}");
    let shown = as_printed(whole, "the whole part");
    assert_eq!((shown.a, shown.c, shown.jerk), (t.whole.a, t.whole.c, t.whole.jerk), "{whole}");
    let (a, _) = angles(whole, "the whole part");
    assert!(a >= A_TRAVEL.0 - 1e-9 && a <= A_TRAVEL.1 + 1e-9, "{whole}");
    let axis: Vec<f64> = whole["tool_axis"].as_array().expect("a tool axis").iter().map(|v| f(v, "axis")).collect();
    assert!((axis.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-9 && axis[2] >= -1e-9, "{axis:?}");
    assert!((f(&json["whole_part"]["length_mm"], "length") - 3558.9).abs() < 0.05);

    // The cycle times, as printed.
    let time = |v: &Value| printed(f(&v["cycle_time_s"], "a cycle time"), 2);
    assert_eq!(time(&json["original"]), printed(t.original_time, 2));
    assert_eq!(time(&json["whole_part"]["prediction"]), printed(t.whole_time, 2));
    assert_eq!(time(&json["per_path"]["prediction"]), printed(t.per_path_time, 2));

    // Every path: the table's row, its best set-up's A within the travel.
    let paths = json["per_path"]["paths"].as_array().expect("paths");
    assert_eq!(paths.len(), PATHS);
    for (p, row) in paths.iter().zip(&t.rows) {
        let what = format!("path {}", row.path);
        assert_eq!(p["path"].as_u64(), Some(row.path as u64), "{what}");
        assert_eq!(p["line"].as_u64(), Some(row.line as u64), "{what}");
        assert_eq!(p["moves"].as_u64(), Some(1), "{what}: a ruling is one move");
        assert_eq!(printed(f(&p["length_mm"], "length"), 1), printed(row.length, 1), "{what}");
        let direction: Vec<f64> = p["direction"].as_array().expect("a direction").iter().map(|v| f(v, "d")).collect();
        for (j, d) in direction.iter().zip(row.direction) {
            assert_eq!(number(&printed(*j, 3)), d, "{what}: {direction:?}");
        }
        assert!((direction[0] - direction[1]).abs() < 1e-9, "{what}: along the ruling: {direction:?}");
        assert_eq!(f(&p["tool_axis_spread_deg"], "spread"), 0.0, "{what}: a 3+2 path");
        assert_eq!(p["program_tool_axis"], serde_json::json!([0.0, 0.0, 1.0]), "{what}");
        assert_eq!(as_printed(&p["best"], &what), row.best, "{what}");
        assert_eq!(as_printed(&p["original"], &what), row.original, "{what}");
        let (a, c) = angles(&p["best"], &what);
        assert!(a >= A_TRAVEL.0 - 1e-9 && a <= A_TRAVEL.1 + 1e-9 && c.is_finite(), "{what}: A {a}°, C {c}°");
        assert!((f(&p["best"]["jerk_mm_s3"], "jerk") - 1000.0 * vertex_jerk()).abs() < 1e-6, "{what}");
    }
}

// ----- --apply --------------------------------------------------------------------------------------

/// A motion block of a Siemens program, with the modal axis values in force after it.
#[derive(Debug, Clone)]
struct Block {
    line: String,
    feed: bool,
    /// X, Y, Z, A, C as written (the last value written), with their decimals.
    axes: [(f64, usize); 5],
}

/// The motion blocks of a program that reach the CL file's positions, the modal words resolved:
/// the moves at the clearance postpro adds are left out (the retract in machine coordinates, the
/// rotary axes turned alone, the approach across the spindle that follows; the approach down
/// reaches the CL position and stays).
fn motion_blocks(program: &str) -> Vec<Block> {
    let mut modal: [Option<(f64, usize)>; 5] = [None; 5];
    let mut out = Vec::new();
    let mut after_rotation = false;
    for line in program.lines() {
        let feed = line.starts_with("G1 ");
        if !(feed || line.starts_with("G0 ")) {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().skip(1).collect();
        for word in &words {
            let Some(k) = "XYZAC".find(&word[..1]) else { continue };
            let value = &word[1..];
            let decimals = value.split_once('.').map_or(0, |(_, d)| d.len());
            modal[k] = Some((number(value), decimals));
        }
        let rotation = !feed && words.iter().all(|w| w.starts_with('A') || w.starts_with('C'));
        let skip = line.contains("SUPA") || rotation || (after_rotation && !words.iter().any(|w| w.starts_with('Z')));
        after_rotation = rotation || (after_rotation && skip);
        if skip {
            continue;
        }
        let axes = modal.map(|m| m.unwrap_or_else(|| panic!("every axis written by `{line}`")));
        out.push(Block { line: line.to_string(), feed, axes });
    }
    out
}

/// The rapids that turn the rotary axes alone (at the clearance), in order.
fn rotations(program: &str) -> Vec<&str> {
    program
        .lines()
        .filter(|l| {
            l.starts_with("G0 ") && l.split_whitespace().skip(1).all(|w| w.starts_with('A') || w.starts_with('C'))
        })
        .collect()
}

/// A written value equals `expected` to its decimals.
fn written(value: (f64, usize), expected: f64) -> bool {
    let decimals = i32::try_from(value.1).expect("few decimals");
    (value.0 - expected).abs() <= 0.5 * 10f64.powi(-decimals) + 1e-9
}

/// The CL lines of the example's GOTOs, in order: the program has one motion block for each.
fn goto_lines(cl: &str) -> Vec<usize> {
    cl.lines().enumerate().filter(|(_, l)| l.starts_with("GOTO/")).map(|(i, _)| i + 1).collect()
}

/// `orient --cone 90 --json --apply NAME` (and `extra`) in a fresh folder: the folder, the JSON,
/// the program.
fn apply(name: &str, extra: &[&str]) -> (PathBuf, Value, String) {
    let dir = scratch(name);
    let mut args = vec!["orient", CL, "--machine", MACHINE, "--cone", "90", "--json", "--apply", "out.mpf"];
    args.extend_from_slice(extra);
    let o = postpro(&args, &dir);
    assert_eq!(o.status.code(), Some(0), "postpro {args:?}:\n{}", stderr(&o));
    assert!(stderr(&o).starts_with("wrote out.mpf for mikron-ucp710 ("), "{}", stderr(&o));
    let json: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(files(&dir), [CL, FIVE_AXIS_CL, "out.mpf"], "the program and no temporary file");
    let program = read(&dir, "out.mpf");
    (dir, json, program)
}

/// What every program of the example holds: the Siemens frame, the prediction header, one
/// motion block per CL point.
fn check_program(program: &str, cycle_time: f64, cl: &str) -> Vec<Block> {
    let lines: Vec<&str> = program.lines().collect();
    assert_eq!(lines[0], "; HYPAR-3PLUS2: hypar-3plus2.cl on mikron-ucp710, mode g1", "{program}");
    assert!(lines.contains(&"; axes: X Y Z A C"), "{program}");
    assert!(lines.contains(&"G90 G17 G710 G94 G64"), "a Siemens program: {program}");
    assert_eq!(lines.last(), Some(&"M30"), "a Siemens program ends with M30");
    let predicted = lines.iter().find(|l| l.starts_with("; predicted cycle time: ")).expect("the prediction header");
    assert!(
        predicted.starts_with(&format!("; predicted cycle time: {cycle_time:.1} s, ")),
        "`{predicted}`: orient predicted {cycle_time} s"
    );
    assert!(lines.iter().any(|l| l.starts_with("; below 80.0 percent of the programmed feed")), "{program}");
    let blocks = motion_blocks(program);
    assert_eq!(blocks.len(), goto_lines(cl).len(), "one motion block per GOTO (nothing linearized)");
    blocks
}

#[test]
fn apply_writes_the_whole_part_at_its_set_up() {
    let (dir, json, program) = apply("apply-whole", &[]);
    let cl = read(&dir, CL);
    let (a, c) = angles(&json["whole_part"]["best"], "the whole part");
    let cycle = f(&json["whole_part"]["prediction"]["cycle_time_s"], "cycle time");
    let blocks = check_program(&program, cycle, &cl);

    // From the first path to the last, every block at the whole part's A and C: the rotary axes
    // are written once and never move.
    let gotos = goto_lines(&cl);
    let paths = json["per_path"]["paths"].as_array().expect("paths");
    let at = |line: u64| gotos.iter().position(|&l| l as u64 == line).expect("a path starts on a GOTO");
    let first = at(paths[0]["line"].as_u64().expect("a line"));
    let last = at(paths[PATHS - 1]["line"].as_u64().expect("a line"));
    assert!(first < last);
    for b in &blocks[first..=last] {
        assert!(written(b.axes[3], a) && written(b.axes[4], c), "`{}` at A {a}°, C {c}°", b.line);
    }
    assert!(blocks[first..=last].iter().filter(|b| b.feed).count() >= 3 * PATHS - 2, "plunge, ruling, retract");
    // The rotary axes turn twice, alone at the clearance: to the set-up before the first block,
    // home at the end; never in between.
    let rotary = |b: &&Block| b.line.split_whitespace().any(|w| w.starts_with('A') || w.starts_with('C'));
    assert_eq!(blocks.iter().filter(rotary).count(), 0, "no block of the paths turns A or C");
    let turning = rotations(&program);
    assert_eq!(turning.len(), 2, "to the set-up and home: {turning:?}");
    assert_eq!(turning[1], "G0 A0.0000 C0.0000", "home at the end");
}

#[test]
fn apply_per_path_writes_each_path_at_its_own_set_up() {
    let (dir, json, program) = apply("apply-per-path", &["--per-path"]);
    let cl = read(&dir, CL);
    let cycle = f(&json["per_path"]["prediction"]["cycle_time_s"], "cycle time");
    let blocks = check_program(&program, cycle, &cl);
    let gotos = goto_lines(&cl);
    let paths = json["per_path"]["paths"].as_array().expect("paths");
    let mut seen = Vec::new();
    for p in paths {
        let what = format!("path {}", p["path"]);
        let (a, c) = angles(&p["best"], &what);
        let line = p["line"].as_u64().expect("a line");
        let k = gotos.iter().position(|&l| l as u64 == line).expect("a path starts on a GOTO");
        // The ruling, the plunge before it (after the rapid, where the machine turns) and the
        // retract after it (which keeps the path's set-up).
        for b in &blocks[k - 1..=k + 1] {
            assert!(b.feed, "{what}: `{}` is a feed block", b.line);
            assert!(written(b.axes[3], a) && written(b.axes[4], c), "{what}: `{}` at A {a}°, C {c}°", b.line);
        }
        assert!(!blocks[k - 2].feed, "{what}: a rapid before the plunge: `{}`", blocks[k - 2].line);
        seen.push((blocks[k].axes[3].0, blocks[k].axes[4].0));
    }
    seen.dedup();
    assert_eq!(seen.len(), PATHS, "each ruling has a set-up of its own");
}

#[test]
fn apply_per_path_without_a_set_up_in_the_cone_writes_the_program_as_the_main_job_does() {
    let dir = scratch("apply-per-path-cone-0");
    let o =
        postpro(&["orient", CL, "--machine", MACHINE, "--cone", "0", "--apply", "oriented.mpf", "--per-path"], &dir);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let o = postpro(&["--machine", MACHINE, CL, "-o", "main.mpf"], &dir);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    // The same motion; the comments may name X or Y jerk for the rulings' tie (ΔX = ΔY).
    let motion =
        |text: String| -> Vec<String> { text.lines().filter(|l| !l.starts_with(';')).map(str::to_string).collect() };
    assert!(
        motion(read(&dir, "oriented.mpf")) == motion(read(&dir, "main.mpf")),
        "every path as programmed: the same motion"
    );
}

/// The ball's centre stays where the CAM system put it: the `--apply` program is the one
/// `postpro solve` gives for the example with every tip moved by `r (a − a')` and the tool axis
/// `a'` of the whole part's set-up.
#[test]
fn apply_keeps_the_ball_centre() {
    let (dir, json, program) = apply("ball-centre", &[]);
    let axis: Vec<f64> =
        json["whole_part"]["best"]["tool_axis"].as_array().expect("a tool axis").iter().map(|v| f(v, "axis")).collect();
    let cl = read(&dir, CL);
    let mut moved = String::new();
    for line in cl.lines() {
        match line.strip_prefix("GOTO/") {
            Some(values) => {
                let v: Vec<f64> = values.split(',').map(|s| number(s.trim())).collect();
                assert_eq!(v.len(), 6, "`{line}`");
                let tip: Vec<f64> = (0..3).map(|k| v[k] + BALL_RADIUS * (v[3 + k] - axis[k])).collect();
                moved.push_str(&format!(
                    "GOTO/{:.9},{:.9},{:.9},{:.15},{:.15},{:.15}\n",
                    tip[0], tip[1], tip[2], axis[0], axis[1], axis[2]
                ));
            }
            None => {
                moved.push_str(line);
                moved.push('\n');
            }
        }
    }
    std::fs::write(dir.join("centre.cl"), moved).expect("centre.cl");
    let o = postpro(&["solve", "centre.cl", "--machine", MACHINE, "--csv"], &dir);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let csv = stdout(&o);
    let mut rows = csv.lines();
    assert_eq!(rows.next(), Some("step,line,kind,rapid,X_mm,Y_mm,Z_mm,A_deg,C_deg"));
    let solved: Vec<Vec<f64>> = rows.map(|r| r.split(',').skip(4).map(number).collect()).collect();
    let blocks = motion_blocks(&program);
    assert_eq!(solved.len(), blocks.len(), "a position per block");
    for (b, s) in blocks.iter().zip(&solved) {
        // Both rounded to the same decimals from nearly the same value: one unit apart at most.
        for (w, t) in b.axes.iter().zip(s) {
            let unit = 10f64.powi(-i32::try_from(w.1).expect("few decimals"));
            assert!((w.0 - t).abs() <= unit + 1e-9, "`{}` against the solved {s:?}", b.line);
        }
    }
}

// ----- The 5-axis example ---------------------------------------------------------------------------------

#[test]
fn five_axis_paths_are_left_as_programmed_and_the_whole_part_is_not_applied() {
    let dir = scratch("five-axis");
    let o = postpro(&["orient", FIVE_AXIS_CL, "--machine", MACHINE], &dir);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let text = stdout(&o);
    let rows: Vec<&str> =
        text.lines().skip_while(|l| !l.starts_with(" path   line")).skip(1).take_while(|l| !l.is_empty()).collect();
    assert_eq!(rows.len(), 27, "{text}");
    for row in &rows {
        let (_, best) = row.split_once("5-axis (tool axis moves ").unwrap_or_else(|| panic!("5-axis: `{row}`"));
        let (angle, rest) = best.split_once("°)").expect("the angle");
        assert!(number(angle) > 1.0, "`{row}`");
        assert_eq!(rest, ": left as programmed", "`{row}`");
    }
    let whole = "  one set-up, whole part   — (27 paths are 5-axis (the tool axis moves): one set-up cannot hold them)";
    assert!(text.lines().any(|l| l == whole), "{text}");
    // Every path as programmed: the per-path program is the original.
    let original = seconds(&text, "  original set-up");
    assert!(text.contains(&format!("one set-up per path      {original:.2} s (+0.0 %)")), "{text}");

    // The JSON says so too.
    let o = postpro(&["orient", FIVE_AXIS_CL, "--machine", MACHINE, "--json"], &dir);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let json: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    let prediction = &json["whole_part"]["prediction"];
    assert!(prediction["cycle_time_s"].is_null(), "{prediction}");
    assert!(prediction["why"].as_str().is_some_and(|w| w.contains("5-axis")), "{prediction}");
    for p in json["per_path"]["paths"].as_array().expect("paths") {
        assert!(p["best"].is_null() && f(&p["tool_axis_spread_deg"], "spread") > 1.0, "{p}");
    }

    // `--apply` of the whole part: nothing written, and the message says why, whether or not a
    // set-up would point the part's feed at a vertex (with the cone open, one does).
    for cone in ["30", "90"] {
        let o = postpro(&["orient", FIVE_AXIS_CL, "--machine", MACHINE, "--cone", cone, "--apply", "out.mpf"], &dir);
        assert_eq!(o.status.code(), Some(1), "--cone {cone}: stderr:\n{}", stderr(&o));
        assert_eq!(files(&dir), [CL, FIVE_AXIS_CL], "--cone {cone}: nothing written");
        let report = format!("exit code: {:?}\n{}", o.status.code(), stderr(&o));
        insta::assert_snapshot!(format!("five_axis_apply_cone_{cone}"), report);
        assert!(report.contains("5-axis"), "--cone {cone}: the reason is the 5-axis paths: {report}");
    }
}

// ----- Errors -----------------------------------------------------------------------------------------

/// Runs `orient --apply out.mpf` in a scratch folder and gives the exit code and the standard
/// error for a snapshot; checks that nothing is written and, unless `table`, nothing printed.
fn failing(name: &str, args: &[&str], table: bool) -> String {
    let dir = scratch(name);
    std::fs::copy(repo().join("tests/cl/err_goto_arity.cl"), dir.join("err_goto_arity.cl")).expect("a copy");
    std::fs::write(dir.join("rapids.cl"), "MULTAX\nRAPID\nGOTO/0,0,10,0,0,1\nRAPID\nGOTO/10,0,10,0,0,1\nFINI\n")
        .expect("rapids.cl");
    let before = files(&dir);
    let mut all = vec!["orient"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--apply", "out.mpf"]);
    let o = postpro(&all, &dir);
    assert_eq!(stdout(&o).is_empty(), !table, "postpro {all:?}: a table or none:\n{}", stdout(&o));
    assert_eq!(files(&dir), before, "postpro {all:?} writes nothing");
    format!("exit code: {:?}\n{}", o.status.code(), stderr(&o))
}

#[test]
fn a_zero_cone_keeps_the_tool_axis_and_finds_the_best_rotation_about_it() {
    // No vertex within 0°: the best set-up with the program's own tool axis (paper 004 eq. 13),
    // here A 0 and C 0 (the rulings at 45° to X and Y already give the edge's 5·√2 m/s³).
    let o = postpro(&["orient", EXAMPLE, "--machine", MACHINE, "--cone", "0"], &repo());
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("A   0.000 C   0.000   jerk 7.07 m/s³"), "{text}");
    assert!(text.contains("(no vertex in the cone: the best within it)"), "{text}");
    assert_eq!(seconds(&text, "  one set-up, whole part"), seconds(&text, "  original set-up"), "{text}");
}

#[test]
fn a_cone_beyond_180_is_a_usage_error() {
    let report = failing("cone-200", &[CL, "--machine", MACHINE, "--cone", "200"], false);
    assert!(report.starts_with("exit code: Some(2)\n"), "{report}");
    insta::assert_snapshot!("cone_200", report);
    for bad in ["-1", "NaN", "abc"] {
        let report = failing("cone-bad", &[CL, "--machine", MACHINE, &format!("--cone={bad}")], false);
        assert!(report.starts_with("exit code: Some(2)\n"), "--cone={bad}: {report}");
    }
}

#[test]
fn an_unknown_machine_exits_2_with_the_nearest_names() {
    let report = failing("unknown-machine", &[CL, "--machine", "mikorn"], false);
    assert!(report.starts_with("exit code: Some(2)\n"), "{report}");
    insta::assert_snapshot!("unknown_machine", report);
}

#[test]
fn a_cl_file_that_does_not_read_exits_1_with_its_line_and_column() {
    let report = failing("syntax-error", &["err_goto_arity.cl", "--machine", MACHINE], false);
    assert!(report.starts_with("exit code: Some(1)\n"), "{report}");
    assert!(report.contains("[err_goto_arity.cl:2:6]"), "{report}");
    assert!(report.contains("nothing oriented"), "{report}");
    insta::assert_snapshot!("syntax_error", report);
}

#[test]
fn a_cl_file_without_a_feed_path_exits_1() {
    let report = failing("no-feed-path", &["rapids.cl", "--machine", MACHINE], false);
    assert!(report.starts_with("exit code: Some(1)\n"), "{report}");
    insta::assert_snapshot!("no_feed_path", report);
}

#[test]
fn help_lists_the_orient_options() {
    let o = postpro(&["orient", "--help"], &repo());
    assert_eq!(o.status.code(), Some(0));
    for flag in
        ["--machine", "--cone", "--level", "--mode", "--planner", "--threshold", "--json", "--apply", "--per-path"]
    {
        assert!(stdout(&o).contains(flag), "{flag} in:\n{}", stdout(&o));
    }
}
