//! Command-line tests of `postpro predict` and of the prediction in the main job, on the bundled
//! hyperbolic paraboloid and the Mikron: the table (pinned), the exports (samples and per-block
//! CSV, JSON, SVG) agreeing with it and with each other, the error cases (exit code and message
//! pinned, no file written), and the slowdown comments and predicted cycle time of the NC program.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{files, number, postpro, repo, stderr, stdout};

const EXAMPLE: &str = "examples/cl/hypar-5axis.cl";
/// The example's file name, as it is called inside a scratch folder.
const CL: &str = "hypar-5axis.cl";
const MACHINE: &str = "mikron";

/// A fresh folder with a copy of the example(s).
fn scratch(name: &str) -> PathBuf {
    common::scratch("predict", name, &[(EXAMPLE, CL)])
}

// ----- The table --------------------------------------------------------------------------------

/// What the table of `postpro predict` says.
struct Table {
    /// The number of blocks of the header line.
    blocks: usize,
    cycle_time: f64,
    programmed_time: f64,
    lost: f64,
}

/// The number after `label` on the line that starts with it, without its unit.
fn figure(text: &str, label: &str) -> f64 {
    let line = text.lines().find(|l| l.starts_with(label)).unwrap_or_else(|| panic!("no `{label}` in:\n{text}"));
    let value = line[label.len()..].split_whitespace().next().expect("a value");
    value.parse().unwrap_or_else(|_| panic!("`{line}`"))
}

fn table(text: &str) -> Table {
    let header = text.lines().next().expect("a header line");
    let blocks = header
        .strip_suffix(" blocks)")
        .and_then(|h| h.rsplit(", ").next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("the header line ends with the number of blocks: `{header}`"));
    Table {
        blocks,
        cycle_time: figure(text, "predicted cycle time"),
        programmed_time: figure(text, "at the programmed feed"),
        lost: figure(text, "lost to slowdowns"),
    }
}

/// The rows under the line that starts with `header`, up to the first empty line.
fn section<'a>(text: &'a str, header: &str) -> Vec<&'a str> {
    text.lines().skip_while(|l| !l.starts_with(header)).skip(1).take_while(|l| !l.is_empty()).collect()
}

/// The block rows of `--blocks`.
fn rows(text: &str) -> Vec<&str> {
    section(text, "  block    line  kind")
}

/// The columns of a block row: block, line, kind, length, F, min, mean, time, lost, limit (which
/// may hold a space).
fn columns(row: &str) -> Vec<String> {
    let mut fields: Vec<String> = row.split_whitespace().map(str::to_string).collect();
    let limit = fields.split_off(9.min(fields.len())).join(" ");
    fields.push(limit);
    assert_eq!(fields.len(), 10, "a block row has 10 columns: `{row}`");
    fields
}

/// The rows of the time lost by cause: (cause, seconds, blocks), and the total.
fn causes(text: &str) -> (Vec<(String, f64, usize)>, f64) {
    let mut rows = Vec::new();
    let mut total = None;
    for row in section(text, "time lost by cause") {
        let (name, rest) = row.trim_start().split_at(24);
        let fields: Vec<&str> = rest.split_whitespace().collect();
        match name.trim() {
            "total" => total = Some(number(fields[0])),
            cause => rows.push((cause.to_string(), number(fields[0]), number(fields[2]) as usize)),
        }
    }
    (rows, total.unwrap_or_else(|| panic!("a total row:\n{text}")))
}

/// The marks the table lists: (number, CL line, blocks, lowest percent, seconds lost, cause).
fn marks(text: &str) -> Vec<(usize, usize, usize, f64, f64, String)> {
    section(text, "   mark     line  blocks")
        .iter()
        .map(|row| {
            let f: Vec<&str> = row.split_whitespace().collect();
            let mark: usize = f[0].strip_prefix('#').and_then(|n| n.parse().ok()).unwrap_or_else(|| panic!("`{row}`"));
            let cause = row[43..].split("  ").next().unwrap_or("").trim().to_string();
            (mark, number_of(f[1]), number_of(f[2]), number(f[3].trim_end_matches('%')), number(f[4]), cause)
        })
        .collect()
}

fn number_of(field: &str) -> usize {
    number(field) as usize
}

#[test]
fn predict_prints_the_totals_and_the_worst_slowdowns() {
    let o = postpro(&["predict", EXAMPLE, "--machine", MACHINE], &repo());
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    assert!(stderr(&o).is_empty(), "nothing on stderr: {}", stderr(&o));
    let out = stdout(&o);
    insta::assert_snapshot!("hypar_mikron_table", out);

    let t = table(&out);
    assert!(out.starts_with(&format!("{EXAMPLE} on mikron-ucp710 (inverse-time planner, tcp mode, ")), "{out}");
    assert!(
        t.cycle_time >= t.programmed_time,
        "the machine never runs faster than programmed: {} s predicted, {} s programmed",
        t.cycle_time,
        t.programmed_time
    );
    assert!((t.cycle_time - t.programmed_time - t.lost).abs() <= 0.011, "lost = predicted - programmed:\n{out}");

    // The causes add up to the time lost (each printed to 5 ms), the total row says so.
    let (by_cause, total) = causes(&out);
    let sum: f64 = by_cause.iter().map(|r| r.1).sum();
    assert!((total - t.lost).abs() <= 0.005, "total {total} s, lost {} s:\n{out}", t.lost);
    assert!((sum - t.lost).abs() <= 0.005 * (by_cause.len() as f64 + 1.0), "the causes add up to {sum} s:\n{out}");
    for cause in ["corner", "exact stop", "plunge or retract"] {
        assert!(by_cause.iter().any(|r| r.0 == cause), "{cause} among the causes:\n{out}");
    }
    // In TCP mode F is the tip's feed; in G1 it is the axes', which slows the hypar down.
    assert!(!by_cause.iter().any(|r| r.0 == "G1 feed on the axes"), "{out}");
    let o = postpro(&["predict", EXAMPLE, "--machine", MACHINE, "--mode", "g1"], &repo());
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let g1 = stdout(&o);
    let (by_cause, _) = causes(&g1);
    assert!(by_cause.iter().any(|r| r.0 == "G1 feed on the axes" && r.1 > 10.0), "{g1}");
    assert!(table(&g1).cycle_time > t.cycle_time, "G1 is slower than TCP on the hypar:\n{g1}");

    // One operation, all of the program.
    let operations = section(&out, "  operation ");
    assert_eq!(operations.len(), 1, "{out}");
    let op: Vec<&str> = operations[0].split_whitespace().collect();
    assert_eq!(op[0], "VARIABLE_CONTOUR");
    assert_eq!((number(op[1]), number(op[3])), (t.cycle_time, t.lost), "{out}");

    // The marks: the worst first, at most 10, below the threshold, never a stop's.
    let summary = out.lines().find(|l| l.contains(" slowdowns marked (below 80% of F")).expect("a marks line");
    let count = number_of(summary.split_whitespace().next().expect("a count"));
    let listed = marks(&out);
    assert!(!listed.is_empty(), "the hypar slows down on the Mikron:\n{out}");
    assert_eq!(listed.len(), count.min(10), "{out}");
    assert!(listed.windows(2).all(|w| w[0].4 >= w[1].4), "the worst first:\n{out}");
    for (number, _, blocks, lowest, lost, cause) in &listed {
        assert!(*number >= 1 && *number <= count && *blocks >= 1, "{out}");
        assert!(*lowest < 80.0 && *lost >= 0.05, "#{number}: {lowest}% and {lost} s:\n{out}");
        assert!(!["exact stop", "plunge or retract", ""].contains(&cause.as_str()), "#{number}: `{cause}`");
    }

    // `--blocks`: the same totals, then every block, their time lost adding up to the total.
    let o = postpro(&["predict", EXAMPLE, "--machine", MACHINE, "--blocks"], &repo());
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let all = stdout(&o);
    let head = |text: &str| -> String {
        let lines = text.lines().take_while(|l| !l.starts_with("  block    line") && !l.contains("slowdowns marked"));
        lines.collect::<Vec<_>>().join("\n").trim_end().to_string()
    };
    assert_eq!(head(&all), head(&out), "--blocks prints the same totals");
    let every = rows(&all);
    assert_eq!(every.len(), t.blocks, "one row per block of the header line");
    let mut lost = 0.0;
    for (i, row) in every.iter().enumerate() {
        let c = columns(row);
        assert_eq!(c[0], (i + 1).to_string(), "blocks numbered in order: `{row}`");
        assert!(["feed", "rapid", "reorientation"].contains(&c[2].as_str()), "`{row}`");
        assert!(number(&c[7]) >= 0.0, "`{row}`");
        if c[2] != "feed" {
            assert_eq!(number(&c[8]), 0.0, "only feed blocks lose time: `{row}`");
        }
        lost += number(&c[8]);
    }
    assert!((lost - t.lost).abs() <= 0.01, "the blocks lose {lost} s, the table says {} s", t.lost);
    let lines: Vec<usize> = every.iter().map(|r| number(&columns(r)[1]) as usize).collect();
    assert!(lines.windows(2).all(|w| w[0] <= w[1]), "blocks follow the CL file");
}

#[test]
fn timing_goes_to_stderr_and_leaves_the_table_alone() {
    let plain = postpro(&["predict", EXAMPLE, "--machine", MACHINE], &repo());
    let timed = postpro(&["predict", EXAMPLE, "--machine", MACHINE, "--timing"], &repo());
    assert_eq!(timed.status.code(), Some(0), "stderr:\n{}", stderr(&timed));
    assert_eq!(stdout(&timed), stdout(&plain));
    let err = stderr(&timed);
    assert!(err.starts_with(&format!("predicted {} blocks, ", table(&stdout(&plain)).blocks)), "{err}");
    assert!(err.contains("M samples/s"), "{err}");
}

/// The machine's interpolation period is what the CNC samples at, not what its planner is
/// bound to: the prediction stepped at the MAHO's 8 ms is within 0.3 % of the same stepped at
/// 0.5 ms, where the stepped motion has converged, on the bundled 5-axis examples in g1 (the
/// slow inverse-time blocks: 1.0 to 1.4 % over until 3 December, the brakings of a period
/// carried into pieces whose rotary axis's jerk could not end them; docs/validation.md).
#[test]
fn the_prediction_at_the_machines_period_is_near_the_converged_one() {
    for example in ["examples/cl/hypar-5axis.cl", "examples/cl/manta-5axis.cl"] {
        let cycle = |extra: &[&str]| {
            let args = [&["predict", example, "--machine", "maho600e", "--mode", "g1"], extra].concat();
            let out = postpro(&args, &repo());
            assert_eq!(out.status.code(), Some(0), "stderr:\n{}", stderr(&out));
            table(&stdout(&out)).cycle_time
        };
        let (at_period, converged) = (cycle(&[]), cycle(&["--period", "0.5"]));
        let off = at_period / converged - 1.0;
        assert!(off.abs() <= 3e-3, "{example}: {at_period} s at 8 ms, {converged} s at 0.5 ms");
    }
}

/// Without an export that needs every block or sample, `predict` streams the file as the main
/// job does (two passes, a window at a time; a third where the 3+2 set-ups stand in working
/// planes) and holds nothing proportional to it; `--blocks` too, its rows in a scratch file.
/// What it prints and says is what the whole-path prediction behind `--json` prints and says, to
/// the last digit, every other case with `--blocks` (every block's row, its CL line that of its
/// own CL item): 5-axis in every mode, B-spline, the VPOp planner, 3+2 programs in working planes
/// (where the figures depend on them) and one written as axis values, a 3-axis program, and a
/// file that does not fit the machine.
#[test]
fn the_streamed_prediction_prints_what_the_whole_one_prints() {
    let dir = common::scratch(
        "predict",
        "streamed",
        &[
            (EXAMPLE, CL),
            ("examples/cl/hypar-3plus2.cl", "hypar-3plus2.cl"),
            ("examples/cl/manta-5axis.cl", "manta-5axis.cl"),
        ],
    );
    let real = |name: &str| tests::shared_cl_dir().join(name).to_str().expect("a UTF-8 path").to_string();
    // Set-ups the tool axes guess wrong: predicted in the planes, then again without them.
    std::fs::write(dir.join("wiggle.cl"), common::two_set_ups(true)).expect("write");
    let (vmc_file, side, nurbs) = (
        real("steptools__STEPNode__Plane_1.cldata"),
        real("aamorim1913__AptPostProcessor__Teste-Metrologia.apt"),
        real("HumMan__CLSFProcessor__nurbs.clsf"),
    );
    let cases: &[(&str, &str, &[&str])] = &[
        (CL, MACHINE, &[]),
        (CL, MACHINE, &["--mode", "g1"]),
        (CL, MACHINE, &["--mode", "bspline"]),
        (CL, MACHINE, &["--mode", "tcp", "--planner", "vpop"]),
        ("manta-5axis.cl", "maho600e", &["--threshold", "90", "--max-marks", "3"]),
        ("hypar-3plus2.cl", MACHINE, &[]),
        ("hypar-3plus2.cl", MACHINE, &["--plane-mode", "joints"]),
        ("hypar-3plus2.cl", "maho600e", &[]),
        // In working planes the blocks (and which of them are written) differ: the figures too.
        (&side, "haas-umc750", &[]),
        ("wiggle.cl", "haas-umc750", &[]),
        ("wiggle.cl", MACHINE, &[]),
        (&nurbs, "maho600e", &[]),
        (&vmc_file, "example-3axis-vmc", &[]),
        (CL, "example-3axis-vmc", &[]),
    ];
    for (k, &(file, machine, args)) in cases.iter().enumerate() {
        let mut streamed = vec!["predict", file, "--machine", machine];
        streamed.extend_from_slice(args);
        if k % 2 == 1 {
            streamed.push("--blocks");
        }
        let case = format!("{file} on {machine} {}", streamed[4..].join(" "));
        let mut whole = streamed.clone();
        whole.extend_from_slice(&["--json", "whole.json"]);
        let (streamed, whole) = (postpro(&streamed, &dir), postpro(&whole, &dir));
        assert_eq!(streamed.status.code(), whole.status.code(), "{case}: {}", stderr(&streamed));
        assert_eq!(stdout(&streamed), stdout(&whole), "{case}");
        assert_eq!(stderr(&streamed), stderr(&whole), "{case}");
        if streamed.status.success() {
            assert!(stdout(&streamed).contains("predicted cycle time"), "{case}");
            let rows = if k % 2 == 1 { table(&stdout(&streamed)).blocks } else { 0 };
            assert_eq!(self::rows(&stdout(&streamed)).len(), rows, "{case}: a row per block with --blocks");
        }
    }
}

/// `--csv` streams too, its rows written beside the files and renamed over them at the end: the
/// samples' and the blocks' CSV are those of the whole-path prediction, byte for byte (5-axis in
/// g1, inverse time, TCP with VPOp and B-spline, whose samples count their path length from
/// their spline's first block, 3+2 in working planes, a 3-axis program); a file that does not
/// fit the machine leaves neither, nor anything beside them.
#[test]
fn the_streamed_csv_files_are_the_whole_ones() {
    let dir = common::scratch(
        "predict",
        "streamed-csv",
        &[
            (EXAMPLE, CL),
            ("examples/cl/hypar-3plus2.cl", "hypar-3plus2.cl"),
            ("examples/cl/manta-5axis.cl", "manta-5axis.cl"),
        ],
    );
    let vmc_file = tests::shared_cl_dir().join("steptools__STEPNode__Plane_1.cldata");
    let vmc_file = vmc_file.to_str().expect("a UTF-8 path");
    let cases: &[(&str, &str, &[&str])] = &[
        (CL, MACHINE, &["--mode", "g1"]),
        (CL, MACHINE, &["--mode", "inverse-time"]),
        (CL, MACHINE, &["--mode", "tcp", "--planner", "vpop"]),
        ("manta-5axis.cl", "maho600e", &["--mode", "bspline"]),
        ("hypar-3plus2.cl", "haas-umc750", &[]),
        (vmc_file, "example-3axis-vmc", &[]),
    ];
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    for &(file, machine, args) in cases {
        let case = format!("{file} on {machine} {}", args.join(" "));
        let run = |extra: &[&str]| {
            let o = postpro(&[&["predict", file, "--machine", machine], args, extra].concat(), &dir);
            assert_eq!(o.status.code(), Some(0), "{case}: {}", stderr(&o));
            stdout(&o)
        };
        let streamed = run(&["--csv", "streamed.csv"]);
        let whole = run(&["--csv", "whole.csv", "--json", "whole.json"]);
        assert_eq!(streamed, whole, "{case}");
        assert!(read("streamed.csv") == read("whole.csv"), "{case}: the samples differ");
        assert!(read("streamed.blocks.csv") == read("whole.blocks.csv"), "{case}: the blocks differ");
        let blocks = String::from_utf8(read("streamed.blocks.csv")).expect("UTF-8");
        assert_eq!(blocks.lines().count(), table(&streamed).blocks + 1, "{case}: a row per block");
    }
    let before: Vec<_> =
        std::fs::read_dir(&dir).expect("the folder").map(|e| e.expect("an entry").file_name()).collect();
    let o = postpro(&["predict", CL, "--machine", "example-3axis-vmc", "--csv", "failed.csv"], &dir);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let after: Vec<_> =
        std::fs::read_dir(&dir).expect("the folder").map(|e| e.expect("an entry").file_name()).collect();
    assert_eq!(before, after, "a failed prediction leaves nothing");
}

#[test]
fn help_lists_the_prediction_options() {
    let o = postpro(&["predict", "--help"], &repo());
    assert_eq!(o.status.code(), Some(0));
    for flag in [
        "--machine",
        "--mode",
        "--planner",
        "--threshold",
        "--blocks",
        "--csv",
        "--json",
        "--plot",
        "--period",
        "--timing",
    ] {
        assert!(stdout(&o).contains(flag), "{flag} in:\n{}", stdout(&o));
    }
    let o = postpro(&["--help"], &repo());
    for flag in ["--no-predict", "--planner", "--threshold"] {
        assert!(stdout(&o).contains(flag), "{flag} in:\n{}", stdout(&o));
    }
}

// ----- The exports --------------------------------------------------------------------------------

/// One run of `predict --csv --json --plot` on the example, shared by the export tests.
struct Exports {
    dir: PathBuf,
    /// Its table.
    text: String,
    table: Table,
}

fn exports() -> &'static Exports {
    static RUN: OnceLock<Exports> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = scratch("exports");
        let args = [
            "predict",
            CL,
            "--machine",
            MACHINE,
            "--csv",
            "samples.csv",
            "--json",
            "prediction.json",
            "--plot",
            "feed.svg",
        ];
        let o = postpro(&args, &dir);
        assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
        assert!(stderr(&o).is_empty(), "{}", stderr(&o));
        let text = stdout(&o);
        Exports { table: table(&text), text, dir }
    })
}

fn read(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A CSV file as its header and rows (no field holds a comma).
fn csv(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines.next().expect("a header").split(',').map(str::to_string).collect::<Vec<_>>();
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(str::to_string).collect()).collect();
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), header.len(), "row {} has as many fields as the header", i + 1);
    }
    (header, rows)
}

/// `postpro solve --csv` of the example: the line and the axis values of every position.
fn solved() -> Vec<(usize, Vec<String>)> {
    let o = postpro(&["solve", EXAMPLE, "--machine", MACHINE, "--csv"], &repo());
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let (header, rows) = csv(&stdout(&o));
    assert_eq!(header, ["step", "line", "kind", "rapid", "X_mm", "Y_mm", "Z_mm", "A_deg", "C_deg"]);
    rows.into_iter().map(|r| (r[1].parse().expect("a line"), r[4..].to_vec())).collect()
}

/// The axis values of a sample equal the solved ones, to their written precision.
fn at_position(sample: &[String], solved: &[String], what: &str) {
    for (s, t) in sample.iter().zip(solved) {
        let decimals = t.split_once('.').map_or(0, |(_, f)| f.len() as i32);
        let tolerance = 0.5 * 10f64.powi(-decimals) + 1e-9;
        assert!((number(s) - number(t)).abs() <= tolerance, "{what}: sample {sample:?}, solved {solved:?}");
    }
}

#[test]
fn csv_exports_samples_and_blocks_that_add_up_to_the_cycle_time() {
    let e = exports();
    let names = files(&e.dir);
    for name in ["samples.csv", "samples.blocks.csv"] {
        assert!(names.contains(&name.to_string()), "{name} written: {names:?}");
    }
    assert!(!names.iter().any(|n| n.contains(".tmp")), "no temporary file left: {names:?}");

    // The samples: every axis's position, velocity, acceleration and jerk, with its unit.
    let (header, samples) = csv(&read(&e.dir, "samples.csv"));
    let mut expected: Vec<String> =
        ["time_s", "path_mm", "block", "programmed_mm_min", "feed_mm_min", "relative_feed_mm_min", "limit"]
            .iter()
            .map(|s| s.to_string())
            .collect();
    for (what, suffix) in [("pos", ""), ("vel", "_per_s"), ("acc", "_per_s2"), ("jerk", "_per_s3")] {
        for (axis, unit) in [("X", "mm"), ("Y", "mm"), ("Z", "mm"), ("A", "deg"), ("C", "deg")] {
            expected.push(format!("{axis}_{what}_{unit}{suffix}"));
        }
    }
    assert_eq!(header, expected);
    assert!(samples.len() > 1000, "{} samples", samples.len());
    let time: Vec<f64> = samples.iter().map(|r| number(&r[0])).collect();
    assert_eq!(time[0], 0.0);
    if let Some(w) = time.windows(2).find(|w| w[1] <= w[0]) {
        panic!("the time increases strictly: {} then {}", w[0], w[1]);
    }
    let last = time[time.len() - 1];
    assert!(
        (last - e.table.cycle_time).abs() <= 0.005,
        "the last sample ({last} s) ends the cycle ({} s)",
        e.table.cycle_time
    );
    let path: Vec<f64> = samples.iter().map(|r| number(&r[1])).collect();
    assert!(path.windows(2).all(|w| w[0] <= w[1]), "the path length never decreases");
    let block: Vec<usize> = samples.iter().map(|r| number(&r[2]) as usize).collect();
    assert!(block.windows(2).all(|w| w[0] <= w[1]), "the blocks follow each other");
    assert_eq!((block[0], block[block.len() - 1]), (1, e.table.blocks));
    for r in &samples {
        assert!(r[3..6].iter().all(|v| number(v) >= 0.0), "feeds are not negative: {r:?}");
        assert!(r[7..].iter().all(|v| number(v).is_finite()), "{r:?}");
    }
    // The motion passes the first and the last solved positions (the program starts and ends at
    // the clearance: the retract, the rotation and the approach around them).
    let solved = solved();
    let close = |sample: &[String], target: &[String]| {
        sample.iter().zip(target).all(|(s, t)| {
            let decimals = t.split_once('.').map_or(0, |(_, f)| f.len() as i32);
            (number(s) - number(t)).abs() <= 0.5 * 10f64.powi(-decimals) + 1e-9
        })
    };
    let first = samples.iter().position(|r| close(&r[7..12], &solved[0].1)).expect("the first solved position");
    let last_solved = samples.iter().rposition(|r| close(&r[7..12], &solved[solved.len() - 1].1));
    assert!(last_solved.is_some_and(|l| l > first), "the last solved position, after the first");
    at_position(&samples[first][7..12], &solved[0].1, "the first solved position");

    // The blocks: one row each, on the CL line of its end position, their times adding up to
    // the cycle time (the hypar has no dwell).
    let (header, blocks) = csv(&read(&e.dir, "samples.blocks.csv"));
    assert_eq!(
        header,
        [
            "block",
            "line",
            "kind",
            "length_mm",
            "programmed_mm_min",
            "min_feed_mm_min",
            "mean_feed_mm_min",
            "time_s",
            "limit",
            "time_lost_s",
            "stop_lost_s",
            "cause",
            "operation"
        ]
    );
    assert_eq!(blocks.len(), e.table.blocks, "one row per block");
    for (i, row) in blocks.iter().enumerate() {
        assert_eq!(row[0], (i + 1).to_string());
    }
    // The blocks follow the CL file, and every solved position ends one, in order (the moves at
    // the clearance are blocks of their own, on the CL line of the position they lead from or to).
    let lines: Vec<usize> = blocks.iter().map(|r| number(&r[1]) as usize).collect();
    assert!(lines.windows(2).all(|w| w[0] <= w[1]), "the blocks follow the CL file");
    let mut at = 0;
    for (line, _) in &solved[1..] {
        at += lines[at..].iter().position(|l| l == line).unwrap_or_else(|| panic!("no block on CL line {line}"));
    }
    let sum: f64 = blocks.iter().map(|r| number(&r[7])).sum();
    let json: serde_json::Value = serde_json::from_str(&read(&e.dir, "prediction.json")).expect("JSON");
    // The blocks' time lost adds up to the program's, and so does their time at the feed.
    let lost: f64 = blocks.iter().map(|r| number(&r[9])).sum();
    let total = json["totals"]["time_lost_s"].as_f64().expect("time_lost_s");
    assert!((lost - total).abs() <= 1e-3, "the blocks lose {lost} s, the program {total} s");
    for r in &blocks {
        if r[2] != "feed" {
            assert_eq!((number(&r[9]), number(&r[10])), (0.0, 0.0), "only feed blocks lose time: {r:?}");
        }
        assert_eq!(r[12], "1", "one operation: {r:?}");
    }
    let cycle = json["totals"]["cycle_time_s"].as_f64().expect("cycle_time_s");
    assert!((sum - cycle).abs() <= 1e-3, "the block times add up to {sum} s, the cycle time is {cycle} s");
    assert!((sum - e.table.cycle_time).abs() <= 0.005 + 1e-3, "{sum} s against the table's {} s", e.table.cycle_time);
    assert!((last - cycle).abs() <= 1e-5, "the last sample at {last} s, the cycle time {cycle} s");

    // Asking for the exports does not change the prediction.
    let plain = postpro(&["predict", CL, "--machine", MACHINE], &e.dir);
    assert_eq!(stdout(&plain), e.text);
}

#[test]
fn json_has_the_totals_blocks_and_samples_of_the_table() {
    let e = exports();
    let json: serde_json::Value = serde_json::from_str(&read(&e.dir, "prediction.json")).expect("the file is JSON");
    let keys =
        |v: &serde_json::Value| -> BTreeSet<String> { v.as_object().expect("an object").keys().cloned().collect() };
    let set = |names: &[&str]| -> BTreeSet<String> { names.iter().map(|s| s.to_string()).collect() };
    assert_eq!(
        keys(&json),
        set(&["file", "machine", "planner", "totals", "operations", "marks", "notes", "blocks", "samples"])
    );
    assert_eq!(json["notes"], serde_json::json!([]), "the example needs no assumption");
    assert_eq!(
        (json["file"].as_str(), json["machine"].as_str(), json["planner"].as_str()),
        (Some(CL), Some("mikron-ucp710"), Some("inverse-time"))
    );
    let totals = &json["totals"];
    let cycle = totals["cycle_time_s"].as_f64().expect("cycle_time_s");
    assert!((cycle - e.table.cycle_time).abs() <= 0.005, "{cycle} s, the table says {} s", e.table.cycle_time);
    let programmed = totals["programmed_time_s"].as_f64().expect("programmed_time_s");
    assert!((programmed - e.table.programmed_time).abs() <= 0.005);
    let lost = totals["time_lost_s"].as_f64().expect("time_lost_s");
    assert!((cycle - programmed - lost).abs() <= 1e-9);
    // The causes partition the time lost, to one interpolation period (the Mikron's 3 ms).
    let causes = totals["causes"].as_array().expect("causes");
    let sum: f64 = causes.iter().map(|c| c["time_lost_s"].as_f64().expect("seconds")).sum();
    assert!((sum - lost).abs() <= 0.003, "the causes add up to {sum} s, the time lost is {lost} s");
    // One operation, the program's figures; every mark with its text.
    let operations = json["operations"].as_array().expect("operations");
    assert_eq!(operations.len(), 1);
    assert_eq!(operations[0]["name"], "VARIABLE_CONTOUR");
    assert!((operations[0]["time_lost_s"].as_f64().expect("lost") - lost).abs() <= 1e-9);
    let marks = json["marks"].as_array().expect("marks");
    assert!(!marks.is_empty());
    for (i, m) in marks.iter().enumerate() {
        assert_eq!(m["number"].as_u64(), Some(i as u64 + 1), "numbered in program order: {m}");
        let text = m["text"].as_str().expect("text");
        assert!(text.starts_with(&format!("slowdown #{}: ", i + 1)) && text.ends_with(" s lost"), "{text}");
    }
    assert_eq!(totals["threshold"].as_f64(), Some(0.8));
    let share = totals["share_below"].as_f64().expect("share_below");
    let (below, length) =
        (totals["length_below_mm"].as_f64().expect("mm"), totals["feed_length_mm"].as_f64().expect("mm"));
    assert!((0.0..=1.0).contains(&share) && (share - below / length).abs() <= 1e-12, "{totals}");

    // The blocks are those of the CSV.
    let (_, rows) = csv(&read(&e.dir, "samples.blocks.csv"));
    let blocks = json["blocks"].as_array().expect("blocks");
    assert_eq!(blocks.len(), rows.len(), "as many blocks as in the CSV");
    for (b, row) in blocks.iter().zip(&rows) {
        assert_eq!(b["block"].to_string(), row[0]);
        assert_eq!(b["line"].to_string(), row[1]);
        assert_eq!(b["kind"].as_str(), Some(row[2].as_str()));
        assert_eq!(b["limit"].as_str(), Some(row[8].as_str()));
        let time = b["time_s"].as_f64().expect("time_s");
        assert!((time - number(&row[7])).abs() <= 5e-7, "block {}: {time} s, {} in the CSV", row[0], row[7]);
    }

    // The samples: every column as long as the others, as many as the CSV's rows.
    let samples = &json["samples"];
    let (_, csv_samples) = csv(&read(&e.dir, "samples.csv"));
    let mut lengths = Vec::new();
    for column in ["time_s", "path_mm", "block", "programmed_mm_min", "feed_mm_min", "relative_feed_mm_min", "limit"] {
        lengths.push((column.to_string(), samples[column].as_array().map(Vec::len)));
    }
    let axes = samples["axes"].as_array().expect("axes");
    let letters: Vec<(&str, &str)> =
        axes.iter().map(|a| (a["letter"].as_str().expect("letter"), a["unit"].as_str().expect("unit"))).collect();
    assert_eq!(letters, [("X", "mm"), ("Y", "mm"), ("Z", "mm"), ("A", "deg"), ("C", "deg")]);
    for a in axes {
        for column in ["position", "velocity", "acceleration", "jerk"] {
            lengths.push((format!("{} {column}", a["letter"]), a[column].as_array().map(Vec::len)));
        }
    }
    for (column, length) in &lengths {
        assert_eq!(*length, Some(csv_samples.len()), "samples.{column}");
    }
    let last = samples["time_s"].as_array().and_then(|t| t.last()).and_then(serde_json::Value::as_f64).expect("a time");
    assert!((last - cycle).abs() <= 1e-9, "the last sample at {last} s ends the cycle ({cycle} s)");
}

/// The legend's limiter entries of the SVG: each name with the colour of the line sample drawn
/// just before it, up to the first text without one.
fn limiter_legend(svg: &str) -> Vec<(String, String)> {
    let start = svg.find(">\nPredicted, limited by\n<").expect("the limiter legend");
    let mut entries = Vec::new();
    let mut colour = None;
    for element in svg[start..].split('<').skip(1) {
        if element.starts_with("polyline") || element.starts_with("path") {
            colour = element.split("stroke=\"").nth(1).and_then(|s| s.split('"').next()).map(str::to_string);
        } else if let Some(text) = element.strip_prefix("text") {
            let Some(c) = colour.take() else { break };
            entries.push((text.split_once('>').map_or("", |(_, t)| t.trim()).to_string(), c));
        } else if !element.starts_with('/') {
            colour = None;
        }
    }
    entries
}

#[test]
fn the_plot_is_a_small_svg_with_the_title_and_the_velocities() {
    let e = exports();
    let size = std::fs::metadata(e.dir.join("feed.svg")).expect("feed.svg written").len();
    assert!(size < 2_000_000, "{size} bytes");
    let svg = read(&e.dir, "feed.svg");
    assert!(svg.starts_with("<svg") || svg.starts_with("<?xml"), "{}", &svg[..100.min(svg.len())]);
    assert!(svg.trim_end().ends_with("</svg>"), "the SVG is whole");
    assert!(svg.contains(&format!("{CL} on mikron-ucp710")), "the title");
    assert!(svg.contains(&format!("predicted cycle time {:.2} s", e.table.cycle_time)), "the table's cycle time");
    assert!(svg.contains("velocity"));
    // What holds the feed back, each in a colour of its own: the legend reads one way.
    let legend = limiter_legend(&svg);
    assert!(legend.len() >= 5, "{legend:?}");
    for name in ["programmed", "corner", "X jerk", "Y jerk"] {
        assert!(legend.iter().any(|(n, _)| n == name), "{name} in {legend:?}");
    }
    let colours: BTreeSet<&str> = legend.iter().map(|(_, c)| c.as_str()).collect();
    assert_eq!(colours.len(), legend.len(), "one colour per limiter: {legend:?}");
}

// ----- The HTML report ---------------------------------------------------------------------------

/// An element of the report: name, attributes, children.
#[derive(Debug, Default)]
struct Element {
    name: String,
    attributes: Vec<(String, String)>,
    children: Vec<Node>,
}

#[derive(Debug)]
enum Node {
    Element(Element),
    Text(String),
}

impl Element {
    fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
    }

    /// Every element below this one named `name`, in document order.
    fn all<'a>(&'a self, name: &str, out: &mut Vec<&'a Element>) {
        for child in &self.children {
            if let Node::Element(e) = child {
                if e.name == name {
                    out.push(e);
                }
                e.all(name, out);
            }
        }
    }

    fn find(&self, name: &str) -> Vec<&Element> {
        let mut out = Vec::new();
        self.all(name, &mut out);
        out
    }

    /// The text inside, entities decoded.
    fn text(&self) -> String {
        let mut out = String::new();
        for child in &self.children {
            match child {
                Node::Text(t) => out.push_str(t),
                Node::Element(e) => out.push_str(&e.text()),
            }
        }
        out.replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&#39;", "'")
            .replace("&amp;", "&")
    }
}

/// Reads the report back: every element closed (`<meta …/>` and SVG's `<… />` close themselves),
/// every attribute quoted; panics on anything else.
fn parse_html(text: &str) -> Element {
    let body = text.strip_prefix("<!DOCTYPE html>").expect("the doctype first");
    let mut stack = vec![Element { name: "#document".into(), ..Element::default() }];
    let mut rest = body;
    while let Some(open) = rest.find('<') {
        if open > 0 {
            stack.last_mut().expect("open").children.push(Node::Text(rest[..open].to_string()));
        }
        let close = rest[open..].find('>').expect("a tag ends") + open;
        let tag = &rest[open + 1..close];
        rest = &rest[close + 1..];
        if tag.starts_with('!') || tag.starts_with('?') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            let done = stack.pop().expect("an open element");
            assert_eq!(done.name, name.trim(), "</{name}> closes <{}>", done.name);
            stack.last_mut().expect("a parent").children.push(Node::Element(done));
            continue;
        }
        let closed = tag.ends_with('/');
        let tag = tag.trim_end_matches('/');
        let (name, mut attrs) = tag.split_once(char::is_whitespace).unwrap_or((tag, ""));
        let mut element = Element { name: name.to_string(), ..Element::default() };
        loop {
            attrs = attrs.trim_start();
            let Some((key, after)) = attrs.split_once('=') else {
                assert!(attrs.is_empty(), "`{attrs}` in <{name}>: attributes are quoted");
                break;
            };
            let after = after.strip_prefix('"').unwrap_or_else(|| panic!("<{name} {key}=…> quoted"));
            let (value, more) = after.split_once('"').expect("a closing quote");
            element.attributes.push((key.trim().to_string(), value.to_string()));
            attrs = more;
        }
        if closed {
            stack.last_mut().expect("a parent").children.push(Node::Element(element));
        } else {
            stack.push(element);
        }
    }
    assert!(rest.trim().is_empty(), "nothing after the last tag");
    assert_eq!(stack.len(), 1, "unclosed: {:?}", stack.iter().map(|e| &e.name).collect::<Vec<_>>());
    stack.pop().expect("the document")
}

/// Two NX operations of zig-zags with sharp turns at 8 m/min, the second one's name in need of
/// escaping.
fn two_operations() -> String {
    let mut text = String::new();
    for (name, y0) in [("ROUGH", 0.0), ("FINISH<&>", 60.0)] {
        text.push_str(&format!("TOOL PATH/{name},TOOL,MILL\nLOAD/TOOL,1\nSPINDL/RPM,10000,CLW\n"));
        text.push_str(&format!("RAPID\nGOTO/0,{y0},5,0,0,1\nRAPID\nGOTO/0,{y0},0\nFEDRAT/MMPM,8000\n"));
        for k in 0..8 {
            let y = y0 + 5.0 * f64::from(k);
            let (from, to) = if k % 2 == 0 { (0.0, 40.0) } else { (40.0, 0.0) };
            text.push_str(&format!("GOTO/{from},{y},0\nGOTO/{to},{y},0\n"));
        }
        text.push_str(&format!("RAPID\nGOTO/0,{},5\nEND-OF-PATH\n", y0 + 35.0));
    }
    text
}

#[test]
fn the_html_report_has_its_sections_a_row_per_operation_and_every_mark() {
    let dir = scratch("report");
    std::fs::write(dir.join("two.cl"), two_operations()).expect("write");
    let args = ["predict", "two.cl", "--machine", MACHINE, "--report", "report.html", "--json", "p.json"];
    let o = postpro(&args, &dir);
    assert_eq!(o.status.code(), Some(0), "stderr:\n{}", stderr(&o));
    let html = read(&dir, "report.html");
    let json: serde_json::Value = serde_json::from_str(&read(&dir, "p.json")).expect("JSON");
    // Self-contained: no script, no link, nothing fetched.
    for outside in ["<script", "<link", "src=", "href=", "url(", "@import"] {
        assert!(!html.contains(outside), "`{outside}` in the report");
    }
    let doc = parse_html(&html);
    let sections: Vec<&str> = doc.find("section").iter().filter_map(|s| s.attribute("id")).collect();
    assert_eq!(sections, ["totals", "plot", "operations", "causes", "marks"]);
    let section = |id: &str| doc.find("section").into_iter().find(|s| s.attribute("id") == Some(id)).expect(id);
    assert_eq!(doc.find("title")[0].text(), "two.cl on mikron-ucp710: predicted feed");

    // The totals are the JSON's.
    let totals = section("totals").text();
    let cycle = json["totals"]["cycle_time_s"].as_f64().expect("cycle");
    assert!(totals.contains(&format!("predicted cycle time{:.2} s", cycle)), "{totals}");

    // The plot, inline: the SVG of --plot with the operations named on it.
    let svg = section("plot").find("svg");
    assert_eq!(svg.len(), 1, "one plot");
    let drawn = svg[0].text();
    for text in ["ROUGH", "FINISH<&>", "rapid (left out)"] {
        assert!(drawn.contains(text), "`{text}` on the plot");
    }

    // A row per operation, in order, with the JSON's figures.
    let rows = section("operations").find("tbody")[0].find("tr");
    let operations = json["operations"].as_array().expect("operations");
    assert_eq!(rows.len(), 2);
    assert_eq!(operations.len(), 2);
    for (row, op) in rows.iter().zip(operations) {
        let cells: Vec<String> = row.find("td").iter().map(|c| c.text()).collect();
        assert_eq!(cells[0], op["name"].as_str().expect("name"));
        assert_eq!(cells[3], format!("{:.2}", op["time_lost_s"].as_f64().expect("lost")));
    }

    // Every mark, worst first, with its number and CL line as the JSON has them.
    let marks = json["marks"].as_array().expect("marks");
    assert!(marks.len() >= 2, "the turns at 8 m/min are marked: {marks:?}");
    let rows = section("marks").find("tbody")[0].find("tr");
    assert_eq!(rows.len(), marks.len(), "every mark listed");
    let mut previous = f64::INFINITY;
    for row in &rows {
        let cells: Vec<String> = row.find("td").iter().map(|c| c.text()).collect();
        let n: u64 = cells[0].trim_start_matches('#').parse().expect("a mark number");
        let mark = marks.iter().find(|m| m["number"].as_u64() == Some(n)).expect("a mark of the JSON");
        assert_eq!(cells[1], mark["line"].to_string());
        let text = mark["text"].as_str().expect("text");
        assert_eq!(format!("slowdown #{n}: {}", cells[4]), text);
        let lost = number(&cells[3]);
        assert!(lost <= previous, "the worst first");
        previous = lost;
    }
}

// ----- Errors -----------------------------------------------------------------------------------------

/// Runs `predict` in a scratch folder asking for every export, and gives the exit code and the
/// standard error for a snapshot; checks that nothing is printed nor written.
fn failing(name: &str, args: &[&str]) -> String {
    let dir = scratch(name);
    std::fs::copy(repo().join("tests/cl/err_goto_arity.cl"), dir.join("err_goto_arity.cl")).expect("a copy");
    let before = files(&dir);
    let mut all = vec!["predict"];
    all.extend_from_slice(args);
    all.extend_from_slice(&[
        "--csv",
        "samples.csv",
        "--json",
        "prediction.json",
        "--plot",
        "feed.svg",
        "--report",
        "report.html",
    ]);
    let o = postpro(&all, &dir);
    assert!(stdout(&o).is_empty(), "postpro {all:?} prints no table:\n{}", stdout(&o));
    assert_eq!(files(&dir), before, "postpro {all:?} writes nothing");
    format!("exit code: {:?}\n{}", o.status.code(), stderr(&o))
}

#[test]
fn an_unknown_machine_exits_2_with_the_nearest_names() {
    let report = failing("unknown-machine", &[CL, "--machine", "mikorn"]);
    assert!(report.starts_with("exit code: Some(2)\n"), "{report}");
    insta::assert_snapshot!("unknown_machine", report);
}

#[test]
fn a_cl_file_that_does_not_read_exits_1_with_its_line_and_column() {
    let report = failing("syntax-error", &["err_goto_arity.cl", "--machine", MACHINE]);
    assert!(report.starts_with("exit code: Some(1)\n"), "{report}");
    assert!(report.contains("[err_goto_arity.cl:2:6]"), "{report}");
    assert!(report.contains("nothing predicted"), "{report}");
    insta::assert_snapshot!("syntax_error", report);
}

#[test]
fn a_threshold_above_100_is_a_usage_error() {
    let report = failing("threshold", &[CL, "--machine", MACHINE, "--threshold", "150"]);
    assert!(report.starts_with("exit code: Some(2)\n"), "{report}");
    insta::assert_snapshot!("threshold_150", report);
    for bad in ["-5", "abc", "NaN"] {
        let report = failing("threshold", &[CL, "--machine", MACHINE, &format!("--threshold={bad}")]);
        assert!(report.starts_with("exit code: Some(2)\n"), "--threshold={bad}: {report}");
    }
}

#[test]
fn a_period_of_zero_is_a_usage_error() {
    let report = failing("period", &[CL, "--machine", MACHINE, "--period", "0"]);
    assert!(report.starts_with("exit code: Some(2)\n"), "{report}");
    insta::assert_snapshot!("period_0", report);
    for bad in ["-1", "NaN", "inf"] {
        let report = failing("period", &[CL, "--machine", MACHINE, &format!("--period={bad}")]);
        assert!(report.starts_with("exit code: Some(2)\n"), "--period={bad}: {report}");
    }
}

/// The operating system's reason at the end of a message, for a snapshot that holds anywhere.
fn without_os_reason(report: &str) -> String {
    assert!(report.contains("No such file") || report.contains("cannot find"), "the OS reason is given: {report}");
    report
        .lines()
        .map(|l| {
            if l.starts_with("error: ") {
                l.rsplit_once(": ").map_or(l.to_string(), |(m, _)| format!("{m}: <the OS's reason>"))
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn an_output_in_a_missing_folder_exits_1_without_a_partial_file() {
    for (name, flag, file) in [
        ("missing-csv", "--csv", "missing/samples.csv"),
        ("missing-json", "--json", "missing/prediction.json"),
        ("missing-plot", "--plot", "missing/feed.svg"),
        ("missing-report", "--report", "missing/report.html"),
    ] {
        let dir = scratch(name);
        let o = postpro(&["predict", CL, "--machine", MACHINE, flag, file], &dir);
        let report = format!("exit code: {:?}\n{}", o.status.code(), stderr(&o));
        assert!(report.starts_with("exit code: Some(1)\n"), "{flag}: {report}");
        assert!(report.contains(&format!("error: cannot write {file}: ")), "{flag} names the file: {report}");
        assert!(!report.contains("program"), "{flag} writes no program: {report}");
        assert_eq!(files(&dir), [CL], "{flag}: nothing written, no temporary file left");
        assert!(stdout(&o).is_empty(), "{flag}: no table after an error");
        if flag == "--csv" {
            insta::assert_snapshot!("missing_folder_csv", without_os_reason(&report));
        }
    }
}

// ----- The main job -------------------------------------------------------------------------------------

/// An NC program of the main job, in its parts.
struct Program {
    lines: Vec<String>,
    /// The slowdown comments: (the motion block it stands before, counted from 0; its text).
    slowdowns: Vec<(usize, String)>,
}

const PREDICTED: &str = "; predicted cycle time: ";
const BELOW: &str = "; below ";
const SLOWDOWN: &str = "; slowdown ";
const OPERATION: &str = "; operation ";
const WORST: &str = "; worst slowdown ";

fn is_motion(line: &str) -> bool {
    line.starts_with("G0 ") || line.starts_with("G1 ")
}

impl Program {
    fn read(dir: &Path, name: &str) -> Program {
        let lines: Vec<String> = read(dir, name).lines().map(str::to_string).collect();
        let mut slowdowns = Vec::new();
        let mut motion = 0;
        for (i, line) in lines.iter().enumerate() {
            if let Some(text) = line.strip_prefix(SLOWDOWN) {
                let next = lines[i + 1..].iter().find(|l| !l.starts_with(SLOWDOWN)).map_or("", |l| l.as_str());
                assert!(next.starts_with("G1 "), "`{line}` stands before a feed block, not `{next}`");
                slowdowns.push((motion, format!("slowdown {text}")));
            }
            if is_motion(line) {
                motion += 1;
            }
        }
        Program { lines, slowdowns }
    }

    /// The header line that starts with `start`.
    fn header(&self, start: &str) -> Option<&str> {
        let first_motion = self.lines.iter().position(|l| is_motion(l)).unwrap_or(self.lines.len());
        self.lines[..first_motion].iter().find(|l| l.starts_with(start)).map(String::as_str)
    }

    /// The program without what the prediction adds.
    fn without_prediction(&self) -> Vec<&str> {
        self.lines
            .iter()
            .map(String::as_str)
            .filter(|l| ![SLOWDOWN, PREDICTED, BELOW, OPERATION, WORST].iter().any(|p| l.starts_with(p)))
            .collect()
    }

    /// The motion blocks.
    fn motion(&self) -> Vec<&str> {
        self.lines.iter().map(String::as_str).filter(|l| is_motion(l)).collect()
    }
}

/// A slowdown comment: `slowdown #3: 45% of F over 3 blocks, C jerk, 0.42 s lost`, as (number,
/// percent, blocks, cause, seconds lost).
fn slowdown(text: &str) -> (usize, u32, usize, String, f64) {
    let rest = text.strip_prefix("slowdown #").unwrap_or_else(|| panic!("`{text}`"));
    let (mark, rest) = rest.split_once(": ").unwrap_or_else(|| panic!("`{text}`"));
    let (percent, rest) = rest.split_once("% of F").unwrap_or_else(|| panic!("`{text}`"));
    let (over, rest) = rest.split_once(", ").unwrap_or_else(|| panic!("`{text}`"));
    let (cause, lost) = rest.rsplit_once(", ").unwrap_or_else(|| panic!("`{text}`"));
    let lost = lost.strip_suffix(" s lost").unwrap_or_else(|| panic!("`{text}`"));
    let blocks = match over.strip_prefix(" over ").and_then(|o| o.strip_suffix(" blocks")) {
        Some(n) => {
            let n: usize = n.parse().unwrap_or_else(|_| panic!("`{text}`"));
            assert!(n >= 2, "one block is said without `over`: `{text}`");
            n
        }
        None => {
            assert!(over.is_empty(), "`{text}`");
            1
        }
    };
    (
        mark.parse().unwrap_or_else(|_| panic!("`{text}`")),
        percent.parse().unwrap_or_else(|_| panic!("a whole percentage: `{text}`")),
        blocks,
        cause.to_string(),
        number(lost),
    )
}

/// What the comments may name as the cause: never a stop, a plunge or a rapid.
fn known_limit(limit: &str) -> bool {
    let axis = |kind: &str| ["X", "Y", "Z", "A", "C"].iter().any(|a| limit == format!("{a} {kind}"));
    axis("velocity")
        || axis("acceleration")
        || axis("jerk")
        || ["corner", "look-ahead", "cycle time", "path acceleration", "path jerk", "G1 feed on the axes"]
            .contains(&limit)
}

/// The main job on the example with `extra` options, written to `name`; its stderr.
fn main_job(dir: &Path, name: &str, extra: &[&str]) -> (Program, String) {
    let mut args = vec!["--machine", MACHINE, CL, "-o", name];
    args.extend_from_slice(extra);
    let o = postpro(&args, dir);
    assert_eq!(o.status.code(), Some(0), "postpro {args:?}:\n{}", stderr(&o));
    (Program::read(dir, name), stderr(&o))
}

/// The percentage of the feed path below the threshold, from the header.
fn share_below(program: &Program) -> f64 {
    let line = program.header(BELOW).expect("the share below the threshold");
    let share = line.split(" on ").nth(1).and_then(|s| s.split(" percent").next()).unwrap_or("");
    number(share)
}

/// The slowdown comments of `program` with their checks: numbered in order, below the
/// threshold, at least the minimum lost, a known cause, runs in order and apart, never across a
/// rapid; the header's count is theirs, its worst five are among them, the worst first.
fn check_slowdowns(program: &Program, threshold: u32, label: &str) {
    let motion = program.motion();
    let mut end = 0;
    for (i, (at, text)) in program.slowdowns.iter().enumerate() {
        let (number, percent, blocks, limit, lost) = slowdown(text);
        assert_eq!(number, i + 1, "{label}: `{text}` numbered in order");
        assert!(percent < threshold, "{label}: `{text}` is below {threshold}%");
        assert!(lost >= 0.05, "{label}: `{text}` loses at least --min-loss");
        assert!(known_limit(&limit), "{label}: `{text}` names what holds the feed");
        assert!(*at >= end, "{label}: `{text}` starts after the run before it");
        end = at + blocks;
        assert!(end <= motion.len(), "{label}: `{text}` ends within the program");
        assert!(motion[*at..end].iter().all(|l| l.starts_with("G1 ")), "{label}: `{text}` runs over feed blocks only");
    }
    let marked = program.header(BELOW).expect("the header's slowdown line");
    assert!(
        marked.ends_with(&format!(", {} slowdowns marked", program.slowdowns.len())),
        "{label}: `{marked}` counts the comments ({})",
        program.slowdowns.len()
    );
    let worst: Vec<&str> = program.lines.iter().filter_map(|l| l.strip_prefix(WORST)).collect();
    assert_eq!(worst.len(), program.slowdowns.len().min(5), "{label}: the worst five in the header");
    let mut previous = f64::INFINITY;
    for line in worst {
        // `#3 at line 1830, CL line 120: 38% of F …`: the comment `slowdown #3: 38% of F …` is
        // on line 1830 of the program.
        let (head, text) = line.split_once(": ").unwrap_or_else(|| panic!("`{line}`"));
        let number = head.split_whitespace().next().unwrap_or("");
        let comment = format!("slowdown {number}: {text}");
        assert!(program.slowdowns.iter().any(|(_, t)| *t == comment), "{label}: `{comment}` is in the program");
        let nc_line: usize = head
            .split_once(" at line ")
            .and_then(|(_, l)| l.split_once(", CL line "))
            .and_then(|(l, _)| l.parse().ok())
            .unwrap_or_else(|| panic!("{label}: `{line}` names its NC line"));
        assert_eq!(
            program.lines.get(nc_line - 1).map(String::as_str),
            Some(format!("; {comment}").as_str()),
            "{label}: the header's `{line}` points at its comment"
        );
        let lost = slowdown(&comment).4;
        assert!(lost <= previous, "{label}: the worst first");
        previous = lost;
    }
}

/// The main job with and without prediction, at several thresholds, for one planner.
fn main_job_marks_the_slowdowns(planner: &str) {
    let dir = scratch(&format!("main-{planner}"));
    let planner_args = ["--planner", planner];

    let (program, err) = main_job(&dir, "default.mpf", &planner_args);
    let predicted = program.header(PREDICTED).expect("the predicted cycle time in the header");
    assert!(predicted.ends_with(&format!(", planner: {planner}")), "{predicted}");
    assert!(program.header(BELOW).is_some_and(|l| l.starts_with("; below 80.0 percent of the programmed feed")));
    assert!(!program.slowdowns.is_empty(), "the hypar slows down on the Mikron ({planner})");
    assert!(program.slowdowns.len() <= 10, "at most --max-marks (10) in its one operation ({planner})");
    check_slowdowns(&program, 80, planner);
    let operation = program.header(OPERATION).expect("the operation's line");
    assert!(operation.starts_with("; operation VARIABLE_CONTOUR: predicted "), "{operation}");

    // The cycle time is the one `postpro predict` gives for the same mode (for both, by default,
    // TCP on this simultaneous program), and stderr says it too.
    let o = postpro(&["predict", CL, "--machine", MACHINE, "--planner", planner], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let t = table(&stdout(&o));
    // The header rounds to 0.1 s and the table to 0.01 s: rounding the table's figure again
    // could land on the other side of a half (24.749 → 24.75 → 24.8, not 24.7).
    let header_figure = |after: &str| -> f64 {
        let at = predicted.find(after).unwrap_or_else(|| panic!("`{predicted}` has no `{after}`")) + after.len();
        let number = predicted[at..].split(' ').next().unwrap_or_default();
        number.parse().unwrap_or_else(|_| panic!("`{predicted}`: not a number after `{after}`"))
    };
    let within_roundings = |header: f64, table: f64| (header - table).abs() <= 0.05 + 0.005 + 1e-9;
    let cycle = header_figure(PREDICTED);
    assert!(within_roundings(cycle, t.cycle_time), "`{predicted}`: predict says {} s", t.cycle_time);
    let lost = header_figure("lost to slowdowns: ");
    assert!(within_roundings(lost, t.lost), "`{predicted}`: predict says {} s", t.lost);
    let below = figure(&stdout(&o), "feed path below 80%");
    assert_eq!(format!("{:.1}", share_below(&program)), format!("{below:.1}"), "the share below 80% of predict");
    let told = err.lines().find(|l| l.starts_with("predicted cycle time ")).expect("stderr tells the cycle time");
    assert!(told.starts_with(&format!("predicted cycle time {cycle} s, ")), "{told}");
    assert!(told.ends_with(&format!(", {} slowdowns marked", program.slowdowns.len())), "{told}");

    // A higher threshold marks every block marked at 80% (runs may merge; every run kept), a zero
    // one none.
    let high_args = [&planner_args[..], &["--threshold", "95", "--max-marks", "1000"]].concat();
    let (high, _) = main_job(&dir, "high.mpf", &high_args);
    check_slowdowns(&high, 95, &format!("{planner} at 95%"));
    for (at, text) in &program.slowdowns {
        let blocks = slowdown(text).2;
        let within = high.slowdowns.iter().any(|(start, run)| *start <= *at && at + blocks <= start + slowdown(run).2);
        assert!(within, "{planner}: `{text}` at block {at} is within a slowdown at 95%: {:?}", high.slowdowns);
    }
    let (none, _) = main_job(&dir, "zero.mpf", &[&planner_args[..], &["--threshold", "0"]].concat());
    assert!(none.slowdowns.is_empty(), "{planner}: nothing is below 0%: {:?}", none.slowdowns);
    check_slowdowns(&none, 1, &format!("{planner} at 0%"));
    assert!(
        share_below(&none) == 0.0 && share_below(&program) <= share_below(&high),
        "{planner}: the share below grows with the threshold"
    );

    // Without prediction: no comment, no predicted line, and otherwise the same program.
    let (plain, err) = main_job(&dir, "plain.mpf", &[&planner_args[..], &["--no-predict"]].concat());
    assert!(plain.slowdowns.is_empty());
    assert!(plain.lines.iter().all(|l| !l.contains("slowdown") && !l.contains("predicted")), "{planner}: --no-predict");
    assert!(!err.contains("predicted"), "{err}");
    let expected = plain.without_prediction();
    assert_eq!(expected.len(), plain.lines.len());
    for (label, other) in [("80%", &program), ("95%", &high), ("0%", &none)] {
        assert!(
            other.without_prediction() == expected,
            "{planner} at {label}: the same program as with --no-predict, comments aside"
        );
    }
    assert!(files(&dir).iter().all(|n| !n.contains(".tmp")), "no temporary file left");
}

#[test]
fn the_main_job_marks_the_slowdowns_of_the_inverse_time_planner() {
    main_job_marks_the_slowdowns("inverse-time");
}

#[test]
fn the_main_job_marks_the_slowdowns_of_the_vpop_planner() {
    main_job_marks_the_slowdowns("vpop");
}

/// A feed move before any feed is programmed is never written nor predicted as if it had one:
/// an error naming its line (file:line:column) and what to set, with nothing written.
#[test]
fn a_move_without_a_feed_is_an_error_naming_its_line() {
    let dir = scratch("no-feed");
    std::fs::write(dir.join("nofeed.cl"), "GOTO/0,0,0\nGOTO/10,0,0\nFEDRAT/MMPM,1000\nGOTO/20,0,0\n").expect("write");
    for args in [
        &["predict", "nofeed.cl", "--machine", MACHINE, "--json", "p.json"][..],
        &["--machine", MACHINE, "nofeed.cl", "-o", "nofeed.mpf"][..],
    ] {
        let o = postpro(args, &dir);
        assert_eq!(o.status.code(), Some(1), "{args:?}: stderr:\n{}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains("a feed move with no feed programmed before it"), "{err}");
        assert!(err.contains("[nofeed.cl:1:1]"), "{err}");
        assert!(err.contains("program a FEDRAT before the first feed move"), "{err}");
    }
    let written: Vec<String> =
        files(&dir).into_iter().filter(|f| f.starts_with("p.") || f.starts_with("nofeed.")).collect();
    assert_eq!(written, ["nofeed.cl"], "nothing written");
}
