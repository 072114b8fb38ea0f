//! Peak memory does not grow with the file (issue 15): what `--timing` reports (the resident
//! set's high-water mark, Linux) for a program and for one twice as long, both several of the
//! passes' 4 MiB windows of text long, in every output mode, for `check`, and for `predict
//! --blocks` (a row per block) and `--csv` (a row per sample and per block). The passes keep a
//! few bits per CL point (the branch graph, the linearizer's decisions) and bounded windows;
//! a stage that kept anything per pose (50 bytes or more) would add tens of MB here.
//!
//! Runs of a few hundred thousand points, a minute on 2 cores: the tests are `#[ignore]`d, out of
//! the README's test command, and `.ci/run` runs them after it, on the build it made:
//! `cargo test -p postpro --test memory -- --ignored`.

#![cfg_attr(not(target_os = "linux"), allow(dead_code))] // the peak is said on Linux only

mod programs;

use std::path::Path;

use programs::{on_two_threads, out_dir, postpro, stderr};

/// The two programs: `postpro-examples big` (4 mm blocks, 5-axis) of 13 and 26 MiB, about
/// 220 k and 440 k CL points.
const SIZES_MIB: [usize; 2] = [13, 26];

/// Bytes a CL point may add to the peak: a few bits kept per point, the rest noise.
const PER_POINT: f64 = 4.0;
/// The allocator's noise between two runs.
const SLACK_MB: f64 = 1.0;

/// The CL points and the peak memory (MB) of a `--timing` line.
fn timing(said: &str) -> Option<(f64, f64)> {
    let line = said.lines().find(|l| ["timing: ", "read ", "predicted "].iter().any(|p| l.starts_with(p)))?;
    // `predict` says its blocks, about one per CL point here.
    let points = ["timing: ", "predicted "]
        .iter()
        .find_map(|p| line.strip_prefix(p)?.split(' ').next()?.parse().ok())
        .unwrap_or(0.0);
    let peak = line.split("; peak memory ").nth(1)?.strip_suffix(" MB")?.parse().ok()?;
    Some((points, peak))
}

/// Writes `text` as `name` in `dir`; its path.
fn written(dir: &Path, name: &str, text: String) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("the program is written");
    path.to_str().expect("a UTF-8 path").to_string()
}

/// Writes the two programs; their paths.
fn programs(dir: &Path) -> Vec<String> {
    SIZES_MIB
        .iter()
        .map(|mib| written(dir, &format!("big-{mib}.cl"), postpro_examples::big_goto_file(mib << 20)))
        .collect()
}

/// The CL points and the peak memory (MB) of the main job on `file` in `mode` on the Mikron (or
/// of `check`, for mode `check`; of `predict --blocks` and `--csv` for modes `blocks` and `csv`,
/// in mode `auto`).
fn measure(dir: &Path, mode: &str, file: &str) -> (f64, f64) {
    let out = format!("{file}.{mode}.mpf");
    let csv = format!("{file}.csv");
    let args: Vec<&str> = match mode {
        "check" => vec!["check", "--timing", file],
        "blocks" => vec!["predict", file, "--machine", "mikron", "--blocks", "--timing"],
        "csv" => vec!["predict", file, "--machine", "mikron", "--csv", &csv, "--timing"],
        _ => vec!["--machine", "mikron", file, "-o", &out, "--mode", mode, "--timing"],
    };
    let o = postpro(&args, dir);
    for written in [out.clone(), csv.clone(), format!("{file}.blocks.csv")] {
        let _ = std::fs::remove_file(written);
    }
    assert_eq!(o.status.code(), Some(0), "postpro {}:\n{}", args.join(" "), stderr(&o));
    timing(&stderr(&o)).unwrap_or_else(|| panic!("postpro {}: no peak memory said:\n{}", args.join(" "), stderr(&o)))
}

/// `postpro-examples fine` with its passes joined by feed moves: every `RAPID` record after the
/// first dropped, so that the motion never stops before the program's end.
fn without_stops(passes: usize) -> String {
    let mut rapids = 0;
    let mut text = String::new();
    for line in postpro_examples::fine_finishing_file(passes).lines() {
        if line.trim() == "RAPID" {
            rapids += 1;
            if rapids > 1 {
                continue;
            }
        }
        text.push_str(line);
        text.push('\n');
    }
    text
}

/// In B-spline mode a fine program peaks near the same program in g1, with its stops and without
/// them (its passes joined by feed moves). Two holds it had (docs/validation.md, "B-spline mode:
/// memory on long programs"): the prediction was forgotten every 256 motion blocks, each a whole
/// pass in B-spline mode (78 MB here, where g1 takes 16 MB); and without stops, the scan ahead
/// took a rotary linking move's tiny path acceleration for the braking from the feed before it
/// and held the program to its end (167.5 MB).
#[test]
#[cfg(target_os = "linux")]
#[ignore = "runs of a hundred thousand points: `.ci/run` runs them (`-- --ignored`)"]
fn a_bspline_program_peaks_near_the_same_in_g1_with_its_stops_or_without() {
    const PASSES: usize = 100;
    let dir = out_dir("memory-bspline");
    let with = written(&dir, "with-stops.cl", postpro_examples::fine_finishing_file(PASSES));
    let without = written(&dir, "without-stops.cl", without_stops(PASSES));
    let cases = [("g1", &with), ("bspline", &with), ("g1", &without), ("bspline", &without)];
    let measured = on_two_threads(&cases, |&(mode, file)| measure(&dir, mode, file));
    for (pair, stops) in measured.chunks(2).zip(["with its stops", "without stops"]) {
        let [(points, g1), (same_points, bspline)] = [pair[0], pair[1]];
        assert_eq!(points, same_points, "{stops}: the same CL points in both modes");
        let allowed = SLACK_MB + 0.25 * g1;
        assert!(
            bspline - g1 <= allowed,
            "{stops}, {points} points: bspline {bspline:.1} MB against g1 {g1:.1} MB, {allowed:.1} more allowed"
        );
    }
}

#[test]
#[cfg(target_os = "linux")]
#[ignore = "runs of hundreds of thousands of points: `.ci/run` runs them (`-- --ignored`)"]
fn peak_memory_does_not_grow_with_the_file() {
    let dir = out_dir("memory");
    let files = programs(&dir);
    let modes = ["g1", "inverse-time", "tcp", "bspline", "check", "blocks", "csv"];
    let cases: Vec<(&str, &String)> = modes.iter().flat_map(|m| files.iter().map(move |f| (*m, f))).collect();
    let measured = on_two_threads(&cases, |&(mode, file)| measure(&dir, mode, file));
    let mut report = Vec::new();
    for (k, pair) in measured.chunks(2).enumerate() {
        let [(points, small), (more_points, large)] = [pair[0], pair[1]];
        let mode = modes[k];
        report.push(format!("{mode}: {small:.1} MB ({points} points), {large:.1} MB ({more_points} points)"));
        // `check` says no points: it holds nothing per point at all.
        let allowed = SLACK_MB + PER_POINT * (more_points - points) / 1e6;
        assert!(large - small <= allowed, "{mode}: {large:.1} MB against {small:.1} MB, {allowed:.1} allowed");
        let size_mb = (SIZES_MIB[1] << 20) as f64 / 1e6;
        assert!(large <= 2.0 * size_mb, "{mode}: {large:.1} MB for a {size_mb:.1} MB file");
    }
    println!("{}", report.join("\n"));
}

#[test]
fn the_timing_line_says_the_points_and_the_peak() {
    let main = "timing: 25295 CL points (1.6 MB) in 0.194 s: 130 k CL points/s, 8.0 MB/s; 2 passes (survey 0.023 s, \
                prediction and program 0.163 s, writing 0.008 s); peak memory 15.7 MB";
    assert_eq!(timing(main), Some((25295.0, 15.7)));
    assert_eq!(timing("read 6.3 MB in 0.054 s: 117 MB/s; peak memory 11.6 MB"), Some((0.0, 11.6)));
    assert_eq!(timing("read 6.3 MB in 0.054 s: 117 MB/s"), None);
}
