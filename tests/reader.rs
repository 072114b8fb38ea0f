//! Data-driven tests of the APT/CL reader (`postpro-cl`), pinned with insta snapshots in
//! `tests/snapshots/`:
//!
//! 1. every real CL file in `../shared/data/cl` reads without errors; its `check` summary and
//!    its diagnostics are pinned (`reader__real_file@<file>.snap`);
//! 2. the bundled examples in `examples/cl` read without errors and are 5-axis
//!    (`reader__example@<file>.snap`);
//! 3. the hand-written cases in `tests/cl`: `err_*.cl` (one error class each), `warn_*.cl` (one
//!    warning class each, no error) and `ok_*.cl` (tricky valid syntax, no diagnostic), with
//!    their rendered diagnostics (`reader__case@<file>.snap`);
//!
//! 4. every real CL file under `../shared/data` (corpus, peer inputs, hold-out): the sense of its
//!    arcs and how many agree with their tangent moves, its operation names, its typed canned
//!    cycles (`reader__arc_sense_of_real_files.snap`, `…operations…`, `…cycles…`);
//!
//! plus focused assertions on the tool path where a snapshot would not show what a user relies
//! on: one-shot RAPID, inch conversion, the arc sense of each CAM system and the options, arc
//! sweeps, typed cycles of every vendor form, operation markers, frame changes, NURBS ends.

use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt::Write as _;
use std::ops::Index;
use std::path::Path;

use postpro_cl::{
    Arc, ArcSense, ArcSenseOrigin, CamSystem, Cycle, CycleKind, Delay, Diagnostic, Feed, FeedPer, FrameSource,
    ItemKind, LengthUnit, Motion, Move, MoveKind, Nurbs, Peck, ReadOptions, Record, Source, Summary, TextKind,
    ToolPath, UnitsOrigin, read, read_with, summarize,
};
use serde_json::Value;

// ----- helpers ------------------------------------------------------------------------------

/// The file name of a path, as UTF-8.
fn file_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// The summary as JSON, with `file` reduced to `name` so that the snapshot does not depend on
/// the machine, plus the diagnostics in their one-line form with the directory stripped.
fn summary_snapshot(summary: &Summary, diagnostics: &[Diagnostic], source: &Source, name: &str) -> Value {
    let mut json = serde_json::to_value(summary).expect("the summary serialises");
    json["file"] = Value::from(name);
    let lines: Vec<Value> = diagnostics
        .iter()
        .map(|d| {
            let line = d.one_line(source);
            let rest = line.strip_prefix(source.name()).expect("one_line starts with the source name");
            Value::from(format!("{name}{rest}"))
        })
        .collect();
    json["diagnostics"] = Value::from(lines);
    json
}

fn count_errors(diagnostics: &[Diagnostic]) -> usize {
    diagnostics.iter().filter(|d| d.is_error()).count()
}

/// The real files that are CATIA lathe programs: each reads with one error, `cl::turning`.
const TURNING_PROGRAMS: [&str; 3] =
    ["karlo-c277__CATIAV5-Post-Processor-__DEMO3.txt", "karlo-c277__CATIAV5-Post-Processor-__DEMO5.txt", "DEMO1.txt"];

/// The errors of a real file other than the one that says a lathe program is one.
fn errors_but_turning(name: &str, diagnostics: &[Diagnostic]) -> usize {
    let turning = diagnostics.iter().filter(|d| d.code == "cl::turning").count();
    let lathe = TURNING_PROGRAMS.iter().any(|t| name.ends_with(t));
    assert_eq!(turning, usize::from(lathe), "{name}: a lathe program is said once, and only of a lathe program");
    count_errors(diagnostics) - turning
}

fn count_warnings(diagnostics: &[Diagnostic]) -> usize {
    diagnostics.iter().filter(|d| !d.is_error()).count()
}

fn listing(source: &Source, diagnostics: &[Diagnostic]) -> String {
    diagnostics.iter().map(|d| d.one_line(source) + "\n").collect()
}

/// A case of `tests/cl`, named relative to the repository (`tests/cl/ok_inch.cl`).
fn case_source(name: &str) -> Source {
    let path = tests::cases_dir().join(name);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    Source::from_bytes(tests::repo_relative(&path), bytes)
}

/// Reads a case into a tool path and checks that it has no diagnostic at all.
fn read_clean(name: &str) -> ToolPath {
    let source = case_source(name);
    let path = read(&source);
    assert!(path.diagnostics.is_empty(), "{name} should read cleanly:\n{}", listing(&source, &path.diagnostics));
    path
}

/// x, y, z of a point or vector (anything indexable by 0..3), without naming nalgebra here.
fn xyz(v: &impl Index<usize, Output = f64>) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

#[track_caller]
fn assert_near(actual: [f64; 3], expected: [f64; 3], tol: f64) {
    let d = (0..3).map(|k| (actual[k] - expected[k]).abs()).fold(0.0, f64::max);
    assert!(d <= tol, "{actual:?}, expected {expected:?} (±{tol})");
}

#[track_caller]
fn assert_close(actual: f64, expected: f64, tol: f64) {
    assert!((actual - expected).abs() <= tol, "{actual}, expected {expected} (±{tol})");
}

fn moves(path: &ToolPath) -> Vec<Move> {
    path.moves().map(|(m, _)| *m).collect()
}

fn frame_sources(path: &ToolPath) -> Vec<&FrameSource> {
    path.items.iter().filter_map(|i| if let ItemKind::Frame(f) = &i.kind { Some(&f.source) } else { None }).collect()
}

fn arcs(path: &ToolPath) -> Vec<&Arc> {
    path.items.iter().filter_map(|i| if let ItemKind::Arc(a) = &i.kind { Some(&**a) } else { None }).collect()
}

fn nurbs(path: &ToolPath) -> Vec<&Nurbs> {
    path.items.iter().filter_map(|i| if let ItemKind::Nurbs(n) = &i.kind { Some(&**n) } else { None }).collect()
}

fn feed(value: f64) -> Motion {
    Motion::Feed(Feed { value, per: FeedPer::Minute })
}

// ----- 1. the real CL files ------------------------------------------------------------------

/// Every real CL file reads without errors; the summary counts and the diagnostics are pinned.
#[test]
fn real_file() {
    let dir = tests::shared_cl_dir();
    let mut read_files = Vec::new();
    // The base is relative to this file: `<repo>/tests/../../shared/data/cl`.
    insta::glob!("../../shared/data/cl", "?*", |path| {
        let name = file_name(path);
        if name.ends_with(".md") {
            return;
        }
        let source = Source::from_path(path).expect("the file reads");
        let (summary, diagnostics) = summarize(&source);
        assert_eq!(
            errors_but_turning(&name, &diagnostics),
            0,
            "{name} should read without errors:\n{}",
            listing(&source, &diagnostics)
        );
        assert_eq!(summary.errors, count_errors(&diagnostics));
        if name == "smooker__aptos-apt360__multax.apt" {
            // The hand-written APT source: its symbolic motion is carried as records, with one
            // warning that says so.
            assert!(diagnostics.iter().any(|d| d.code == "cl::apt-source"), "{name} is reported as APT source");
        } else {
            assert_ne!(summary.axes, "none", "{name} has motion");
        }
        insta::assert_json_snapshot!(summary_snapshot(&summary, &diagnostics, &source, &name));
        read_files.push(name);
    });
    assert_eq!(read_files.len(), 18, "the 18 real CL files of {}: {read_files:?}", dir.display());
}

// ----- 2. the bundled examples ---------------------------------------------------------------

/// The example programs read without errors or warnings; the `*-5axis.cl` ones are simultaneous
/// 5-axis, the 3+2 one (tool along +z, `orient`'s example) reads as 3-axis.
#[test]
fn example() {
    let mut seen = 0;
    insta::glob!("../examples/cl", "*.cl", |path| {
        let name = file_name(path);
        let source = Source::from_path(path).expect("the example reads");
        let (summary, diagnostics) = summarize(&source);
        assert!(diagnostics.is_empty(), "{name}:\n{}", listing(&source, &diagnostics));
        let expected = if name.contains("3plus2") { "3-axis" } else { "5-axis" };
        assert_eq!(summary.axes, expected, "{name}");
        assert_eq!(summary.cam_system, Some("postpro example generator"), "{name}");
        insta::assert_json_snapshot!(summary_snapshot(&summary, &diagnostics, &source, &name));
        seen += 1;
    });
    assert!(seen >= 3, "the examples in {}", tests::examples_cl_dir().display());
}

// ----- 3. the cases ---------------------------------------------------------------------------

/// A compact summary of a case: what the reader made of it.
fn compact_summary(s: &Summary) -> String {
    let mut t = String::new();
    let words = |m: &std::collections::BTreeMap<String, usize>| {
        if m.is_empty() {
            "-".to_string()
        } else {
            m.iter().map(|(w, n)| format!("{w} ×{n}")).collect::<Vec<_>>().join(", ")
        }
    };
    let at = s.units.at.as_ref().map(|a| format!(" at {a}")).unwrap_or_default();
    let _ = writeln!(t, "cam system: {}", s.cam_system.unwrap_or("-"));
    let _ = writeln!(t, "units: {} ({}{at})", s.units.file.name(), s.units.origin);
    let _ = writeln!(t, "axes: {}", s.axes);
    let _ = writeln!(t, "statements: {}, listing lines: {}", s.statements, s.listing_lines);
    let m = &s.moves;
    let _ = writeln!(
        t,
        "moves: {} ({} feed, {} rapid, {} holes), arcs: {}, nurbs: {}",
        m.total, m.feed, m.rapid, m.holes, s.arcs, s.nurbs
    );
    let _ = writeln!(t, "path length: {} feed, {} rapid", s.path_length.feed, s.path_length.rapid);
    if let Some(b) = s.bounding_box {
        let _ = writeln!(t, "bounding box: {:?} … {:?}", b.min, b.max);
    }
    let r = |r: Option<postpro_cl::Range>| r.map_or("-".to_string(), |r| format!("{}–{}", r.min, r.max));
    let _ = writeln!(t, "feeds: {} mm/min, {} mm/rev", r(s.feeds.per_minute), r(s.feeds.per_revolution));
    let _ = writeln!(t, "operations: {}, frames: {}, axis changes: {}", s.operations, s.frames, s.axis_changes);
    let _ = writeln!(t, "passed through: {}", words(&s.uninterpreted_words));
    let _ = writeln!(t, "unknown words: {}", words(&s.unknown_words));
    let _ = writeln!(t, "warnings: {} ({}), errors: {}", s.warnings.total, words(&s.warnings.by_word), s.errors);
    t
}

/// Each case exercises one diagnostic class (or none, for `ok_*`); the rendered diagnostics
/// (file:line:column, the source line, a caret, what was expected) are pinned.
#[test]
fn case() {
    let mut kinds = [0usize; 3];
    insta::glob!("cl", "*.cl", |path| {
        let name = file_name(path);
        let source = case_source(&name);
        assert_eq!(source.name(), format!("tests/cl/{name}"), "names relative to the repository");
        let (summary, diagnostics) = summarize(&source);
        let (errors, warnings) = (count_errors(&diagnostics), count_warnings(&diagnostics));
        let shown = listing(&source, &diagnostics);
        if name.starts_with("err_") {
            assert!(errors >= 1, "{name} should have an error:\n{shown}");
            kinds[0] += 1;
        } else if name.starts_with("warn_") {
            assert!(warnings >= 1 && errors == 0, "{name} should have warnings only:\n{shown}");
            kinds[1] += 1;
        } else if name.starts_with("ok_") {
            assert!(diagnostics.is_empty(), "{name} should read cleanly:\n{shown}");
            kinds[2] += 1;
        } else {
            panic!("{name}: a case is named err_*.cl, warn_*.cl or ok_*.cl");
        }
        assert_eq!(summary.errors, errors);
        assert_eq!(summary.warnings.total, warnings);
        let mut text = compact_summary(&summary);
        for d in &diagnostics {
            text.push('\n');
            text.push_str(&d.render(&source));
        }
        insta::assert_snapshot!(text);
    });
    let [err, warn, ok] = kinds;
    assert!(err >= 22 && warn >= 12 && ok >= 15, "cases: {err} err_, {warn} warn_, {ok} ok_");
}

/// Every error case reads with exactly one error and nothing else, so that each input
/// exercises exactly one class.
#[test]
fn each_error_case_has_exactly_one_diagnostic() {
    for entry in std::fs::read_dir(tests::cases_dir()).expect("tests/cl") {
        let name = file_name(&entry.expect("an entry").path());
        if !(name.starts_with("err_") || name.starts_with("warn_")) {
            continue;
        }
        let source = case_source(&name);
        let (_, diagnostics) = summarize(&source);
        let codes: std::collections::BTreeSet<_> = diagnostics.iter().map(|d| (d.code, d.severity)).collect();
        assert_eq!(codes.len(), 1, "{name} should exercise one class:\n{}", listing(&source, &diagnostics));
        if name.starts_with("err_") {
            assert_eq!(diagnostics.len(), 1, "{name}:\n{}", listing(&source, &diagnostics));
        }
    }
}

// ----- focused assertions on the tool path ---------------------------------------------------

/// RAPID applies to the next motion only; the programmed feed resumes after it.
#[test]
fn rapid_is_one_shot() {
    let path = read_clean("ok_rapid_one_shot.cl");
    let motions: Vec<Motion> = moves(&path).iter().map(|m| m.motion).collect();
    assert_eq!(motions, [feed(500.0), Motion::Rapid, feed(500.0), feed(500.0), Motion::Rapid]);
}

/// An inch file is read in millimetres: coordinates and feeds.
#[test]
fn inches_are_converted_to_mm() {
    let path = read_clean("ok_inch.cl");
    assert_eq!(path.info.units.unit, LengthUnit::Inch);
    assert!(matches!(path.info.units.origin, UnitsOrigin::Declared(_)));
    let m = moves(&path);
    assert_eq!(m.len(), 2);
    assert_near(xyz(&m[0].to), [25.4, 50.8, 76.2], 1e-9);
    assert_near(xyz(&m[1].to), [25.4, 50.8, 76.2], 1e-9);
    assert_near(xyz(&*m[1].axis), [0.0, 0.0, 1.0], 1e-12);
    assert_eq!(m[0].motion, feed(254.0));
}

/// NX writes no UNITS: an IPM feed makes the file an inch file, header lines are skipped.
#[test]
fn nx_listing_units_from_the_feed_word() {
    let path = read_clean("ok_nx_listing.cl");
    assert_eq!(path.info.units.unit, LengthUnit::Inch);
    assert!(matches!(path.info.units.origin, UnitsOrigin::FeedWord(_)));
    assert_eq!(path.info.listing_lines, 5);
    let m = moves(&path);
    assert_near(xyz(&m[1].to), [1.9949 * 25.4, 0.1148 * 25.4, 1.4399 * 25.4], 1e-9);
    // The 3-value GOTO keeps the tool axis of the 6-value one.
    assert_near(xyz(&*m[1].axis), [0.0, 0.9922779, 0.1240347], 1e-6);
}

/// `FEDRAT/MMPM,f` and `FEDRAT/f,MMPM` are the same feed.
#[test]
fn feed_value_and_unit_in_either_order() {
    let path = read_clean("ok_fedrat_order.cl");
    let motions: Vec<Motion> = moves(&path).iter().map(|m| m.motion).collect();
    assert_eq!(motions, [feed(250.0); 3]);
}

/// Each arc as (normal the motion is counter-clockwise about, sweep, end point).
#[track_caller]
fn assert_arcs(path: &ToolPath, expected: &[([f64; 3], f64, [f64; 3])]) {
    let a = arcs(path);
    assert_eq!(a.len(), expected.len(), "{a:?}");
    for (arc, (normal, sweep, end)) in a.iter().zip(expected) {
        assert_near(xyz(&*arc.normal), *normal, 1e-12);
        assert_close(arc.sweep, *sweep, 1e-9);
        assert_near(xyz(&arc.end), *end, 1e-9);
    }
}

/// The sense info of a path: (sense, origin, arcs, checkable, agree, contradict).
fn sense_of(path: &ToolPath) -> (Option<ArcSense>, ArcSenseOrigin, [usize; 4]) {
    let i = path.info.arc_sense;
    (i.sense, i.origin, [i.checks.arcs, i.checks.checkable, i.checks.agree, i.checks.contradict])
}

const PLUS_Z: [f64; 3] = [0.0, 0.0, 1.0];
const MINUS_Z: [f64; 3] = [0.0, 0.0, -1.0];

/// NX: clockwise about the axis written (11 values, TIMES,n turns in all); the lead-in and the
/// lead-out tangent to the arcs agree.
#[test]
fn arc_sense_nx() {
    let path = read_clean("ok_arcs_nx.cl");
    assert_eq!(path.info.cam_system, Some(CamSystem::SiemensNx));
    assert_eq!(sense_of(&path), (Some(ArcSense::Cw), ArcSenseOrigin::CamSystem(CamSystem::SiemensNx), [3, 2, 2, 0]));
    assert_arcs(
        &path,
        &[
            (MINUS_Z, FRAC_PI_2, [0.0, -10.0, 0.0]),
            (PLUS_Z, FRAC_PI_2, [10.0, 0.0, 0.0]),
            (PLUS_Z, 4.0 * PI + FRAC_PI_2, [0.0, 10.0, -5.0]),
        ],
    );
    let a = arcs(&path);
    // Clockwise seen from +Z from (10,0) to (0,-10): through x > 0, y < 0.
    let p = a[0].point_at(0.5);
    assert!(p.x > 0.0 && p.y < 0.0, "{p:?}");
    // The helix: 2.25 turns of radius 10, 5 mm down; half way round it is half way down.
    assert_close(a[2].length(), (10.0 * a[2].sweep).hypot(5.0), 1e-9);
    assert_close(a[2].point_at(0.5).z, -2.5, 1e-9);
}

/// Makino FFCAM: clockwise about the axis written, as NX.
#[test]
fn arc_sense_makino() {
    let path = read_clean("ok_arcs_makino.cl");
    assert_eq!(sense_of(&path), (Some(ArcSense::Cw), ArcSenseOrigin::CamSystem(CamSystem::MakinoFfcam), [1, 1, 1, 0]));
    assert_arcs(&path, &[(MINUS_Z, FRAC_PI_2, [0.0, -10.0, 0.0])]);
}

/// SOLIDWORKS CAM: counter-clockwise about the axis written; 6 values, the radius from the
/// start point.
#[test]
fn arc_sense_solidworks() {
    let path = read_clean("ok_arcs_solidworks.cl");
    assert_eq!(
        sense_of(&path),
        (Some(ArcSense::Ccw), ArcSenseOrigin::CamSystem(CamSystem::SolidworksCam), [2, 2, 2, 0])
    );
    assert_arcs(&path, &[(PLUS_Z, FRAC_PI_2, [0.0, 10.0, 0.0]), (MINUS_Z, FRAC_PI_2, [10.0, 0.0, 0.0])]);
    assert_close(arcs(&path)[0].radius, 10.0, 1e-12);
}

/// PTC Creo: counter-clockwise about the axis written; 7 values over two lines.
#[test]
fn arc_sense_creo() {
    let path = read_clean("ok_arcs_creo.cl");
    assert_eq!(sense_of(&path), (Some(ArcSense::Ccw), ArcSenseOrigin::CamSystem(CamSystem::Creo), [1, 1, 1, 0]));
    assert_arcs(&path, &[(PLUS_Z, PI, [-10.0, 0.0, 0.0])]);
    // Counter-clockwise from (10,0) to (-10,0) passes above.
    assert!(arcs(&path)[0].point_at(0.5).y > 0.0);
}

/// CAMWorks spells the sense out: the words decide, the CAM system has no convention.
#[test]
fn arc_sense_camworks() {
    let path = read_clean("ok_arcs_camworks.cl");
    assert_eq!(sense_of(&path), (None, ArcSenseOrigin::None, [2, 2, 2, 0]));
    assert_arcs(&path, &[(MINUS_Z, FRAC_PI_2, [0.0, -10.0, 0.0]), (PLUS_Z, FRAC_PI_2, [10.0, 0.0, 0.0])]);
}

/// No CAM system: the tangent lead-in of one arc decides the sense of the file's arcs, also of
/// the arc without a tangent neighbour.
#[test]
fn arc_sense_from_tangency() {
    let path = read_clean("ok_arcs_tangency.cl");
    assert_eq!(path.info.cam_system, None);
    assert_eq!(sense_of(&path), (Some(ArcSense::Cw), ArcSenseOrigin::Tangency { ccw: 0, cw: 1 }, [2, 1, 1, 0]));
    assert_arcs(&path, &[(MINUS_Z, FRAC_PI_2, [0.0, -10.0, 0.0]), (MINUS_Z, FRAC_PI_2, [10.0, -30.0, 5.0])]);
}

/// `--arc-sense` replaces the CAM system's convention (the tangent neighbours now contradict,
/// with a warning per arc), and decides where nothing else does.
#[test]
fn arc_sense_option() {
    let ccw = ReadOptions { arc_sense: Some(ArcSense::Ccw), ..ReadOptions::default() };
    let source = case_source("ok_arcs_nx.cl");
    let path = read_with(&source, &ccw);
    assert_eq!(sense_of(&path), (Some(ArcSense::Ccw), ArcSenseOrigin::Option, [3, 2, 0, 2]));
    assert_eq!(path.diagnostics.iter().filter(|d| d.code == "cl::arc-sense" && !d.is_error()).count(), 2);
    assert_near(xyz(&*arcs(&path)[0].normal), PLUS_Z, 1e-12);
    assert_close(arcs(&path)[0].sweep, 3.0 * FRAC_PI_2, 1e-9);
    // The file whose arcs nothing decides reads with the option.
    let source = case_source("err_arc_sense_unknown.cl");
    assert!(read(&source).has_errors());
    let path = read_with(&source, &ccw);
    assert!(path.diagnostics.is_empty(), "{}", listing(&source, &path.diagnostics));
    assert_arcs(&path, &[(PLUS_Z, FRAC_PI_2, [0.0, 10.0, 0.0])]);
}

/// MOVARC: the sweep is the ANGLE in degrees, the direction the sign of the axis.
#[test]
fn movarc_sweep_from_angle() {
    let path = read_clean("ok_movarc.cl");
    let a = arcs(&path);
    let sweeps: Vec<f64> = a.iter().map(|a| a.sweep).collect();
    assert_eq!(sweeps.len(), 3);
    assert_close(sweeps[0], FRAC_PI_2, 1e-9);
    assert_close(sweeps[1], 3.0 * FRAC_PI_2, 1e-9);
    assert_close(sweeps[2], FRAC_PI_2, 1e-9);
    assert_near(xyz(&*a[2].normal), [0.0, 0.0, -1.0], 1e-12);
    assert_close(a[1].length(), 10.0 * 3.0 * FRAC_PI_2, 1e-9);
    // Fusion: counter-clockwise about the axis written (a negative ANGLE would reverse it).
    assert_eq!(sense_of(&path).0, Some(ArcSense::Ccw));
    assert_eq!(sense_of(&path).1, ArcSenseOrigin::CamSystem(CamSystem::Fusion));
}

/// CATIA V5 writes arcs as APT motion (`TLON,GOFWD`), evaluated from INDIRV: geometric, no
/// convention needed, nothing checked.
#[test]
fn arc_sense_catia_gofwd() {
    let source = Source::from_path(&tests::shared_cl_dir().join("karlo-c277__CATIAV5-Post-Processor-__DEMO5.txt"))
        .expect("the file reads");
    let path = read(&source);
    // A lathe program (the one error says so), whose arcs read all the same.
    assert_eq!(
        errors_but_turning("karlo-c277__CATIAV5-Post-Processor-__DEMO5.txt", &path.diagnostics),
        0,
        "{}",
        listing(&source, &path.diagnostics)
    );
    assert_eq!(path.info.cam_system, Some(CamSystem::CatiaV5));
    assert!(!arcs(&path).is_empty());
    assert_eq!(sense_of(&path), (None, ArcSenseOrigin::None, [0, 0, 0, 0]));
}

/// NX NURBS: the curve starts at the current point and ends at the last CNTRL point; the
/// degree follows from the counts; the knots span several KNOT records.
#[test]
fn nurbs_start_end_and_degree() {
    let path = read_clean("ok_nurbs.cl");
    let n = nurbs(&path);
    assert_eq!(n.len(), 2);
    // A cubic Bezier: B(1/2) = (P0 + 3 P1 + 3 P2 + P3) / 8.
    let bezier = n[0];
    assert_eq!(bezier.degree, 3);
    assert_eq!(bezier.knots, [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]);
    let (lo, hi) = bezier.domain();
    assert_near(xyz(&bezier.point_at(lo)), [0.0, 0.0, 0.0], 1e-12);
    assert_near(xyz(&bezier.point_at(hi)), [3.0, 0.0, 0.0], 1e-12);
    assert_near(xyz(&bezier.point_at(0.5)), [1.5, 1.5, 0.0], 1e-12);
    assert_eq!(bezier.motion, feed(250.0));
    // The second spline starts at the GOTO between the two and ends at its last CNTRL.
    let spline = n[1];
    assert_eq!(spline.degree, 3);
    assert_eq!(spline.control.len(), 7);
    assert_eq!(spline.knots.len(), 7 + 3 + 1);
    let (lo, hi) = spline.domain();
    assert_near(xyz(&spline.point_at(lo)), [4.0, 0.0, 0.0], 1e-12);
    assert_near(xyz(&spline.point_at(hi)), [10.0, 0.0, 0.0], 1e-12);
    assert_near(xyz(&spline.end()), [10.0, 0.0, 0.0], 1e-12);
}

/// CAMWorks: after `ROTABL/1.570796,AAXIS` the points are written in the table frame and are
/// read back into the part frame, where the drilling goes along the TLAXIS written before.
#[test]
fn camworks_rotabl_points_in_the_part_frame() {
    let path = read_clean("ok_camworks_rotabl.cl");
    let frames = frame_sources(&path);
    assert_eq!(frames.len(), 2, "{frames:?}");
    assert!(matches!(frames[0], FrameSource::Rotabl('A', a) if (a - FRAC_PI_2).abs() < 1e-6));
    let m = moves(&path);
    assert_eq!(m.len(), 3);
    // Rotation by +90° about X: (x, y, z) → (x, −z, y).
    assert_near(xyz(&m[0].to), [67.5, -25.0, 120.5], 1e-3);
    assert_near(xyz(&m[1].to), [67.5, 21.927686, 120.5], 1e-3);
    for mv in &m {
        assert_near(xyz(&*mv.axis), [0.0, -1.0, 0.0], 1e-12);
    }
    // The feed move goes into the part against the tool axis.
    let d = m[1].to - m[0].to;
    assert_near(xyz(&d.normalize()), [0.0, 1.0, 0.0], 1e-6);
    assert_eq!(m[0].motion, Motion::Rapid);
    assert_eq!(m[1].motion, feed(187.165839));
}

/// SOLIDWORKS CAM: each `CSYS` sets the tool axis of its set-up (the matrix's third column) for
/// the 3-value GOTOs and the holes that follow; the points are not moved.
#[test]
fn solidworks_csys_sets_its_set_ups_tool_axis() {
    let path = read_clean("ok_solidworks_csys_axis.cl");
    assert_eq!(path.info.cam_system, Some(CamSystem::SolidworksCam));
    let frames = frame_sources(&path);
    assert_eq!(frames.len(), 2, "{frames:?}");
    assert!(frames.iter().all(|f| matches!(f, FrameSource::Csys(_))));
    let m = moves(&path);
    assert_eq!(m.len(), 7);
    // The side face: +X, the points as written.
    for mv in &m[..4] {
        assert_near(xyz(&*mv.axis), [1.0, 0.0, 0.0], 1e-12);
    }
    assert_near(xyz(&m[1].to), [100.0, 20.0, -30.0], 1e-12);
    // From the top: +Z again, the hole too.
    for mv in &m[4..] {
        assert_near(xyz(&*mv.axis), [0.0, 0.0, 1.0], 1e-12);
    }
    assert_eq!(m[5].kind, MoveKind::Hole);
    assert_near(xyz(&m[5].to), [10.0, 10.0, 0.0], 1e-12);
}

/// NX: the part frame is the MSYS of the first operation; the points and tool axes of the
/// second operation are transformed from its own MSYS into it.
#[test]
fn nx_msys_change_between_operations() {
    let path = read_clean("ok_msys_change.cl");
    let m = moves(&path);
    assert_eq!(m.len(), 4);
    // First operation: in its own MSYS, which is the part frame.
    assert_near(xyz(&m[0].to), [0.0, 0.0, 10.0], 1e-12);
    assert_near(xyz(&m[1].to), [10.0, 0.0, 0.0], 1e-12);
    assert_near(xyz(&*m[1].axis), [0.0, 0.0, 1.0], 1e-12);
    // Second operation: MSYS at (100,0,0) turned +90° about Z; world = origin + R·p; part =
    // world − (0,0,50).
    assert_near(xyz(&m[2].to), [100.0, 10.0, -40.0], 1e-9);
    assert_near(xyz(&m[3].to), [100.0, 10.0, -50.0], 1e-9);
    assert_near(xyz(&*m[2].axis), [0.0, 1.0, 0.0], 1e-9);
    assert_near(xyz(&*m[3].axis), [0.0, 1.0, 0.0], 1e-9);
    let ops = path.items.iter().filter(|i| matches!(i.kind, ItemKind::OperationStart(_))).count();
    assert_eq!(ops, 2);
}

/// FROM before any tool change or move is the start point, not a move (no tool is known to move
/// yet): it is counted, and gives the position GODLTA moves from. GODLTA moves by a vector, or
/// along the tool axis. A FROM after a move is a move.
#[test]
fn godlta_and_from() {
    let path = read_clean("ok_godlta_from.cl");
    let from = path.info.start_points.expect("the start point is counted");
    assert_eq!(from.count, 1);
    assert_eq!(case_source("ok_godlta_from.cl").location(from.first.start as usize), "tests/cl/ok_godlta_from.cl:3:1");
    let m = moves(&path);
    let rest: Vec<([f64; 3], MoveKind)> = m.iter().map(|m| (xyz(&m.to), m.kind)).collect();
    let expected = [
        ([10.0, 20.0, 30.0], MoveKind::Goto),
        ([10.0, 20.0, 35.0], MoveKind::Godlta),
        ([10.0, 20.0, 30.0], MoveKind::Godlta),
        ([10.0, 20.0, 30.0], MoveKind::Goto),
        ([10.0, 22.0, 30.0], MoveKind::Godlta),
        ([10.0, 22.0, 60.0], MoveKind::From),
    ];
    assert_eq!(rest.len(), expected.len());
    for ((p, k), (ep, ek)) in rest.iter().zip(expected) {
        assert_near(*p, ep, 1e-12);
        assert_eq!(*k, ek);
    }
}

/// CATIA wraps at a fixed column, inside a number: `0$` + `.752602` is 0.752602.
#[test]
fn catia_wrap_inside_a_number() {
    let path = read_clean("ok_catia_column_wrap.cl");
    let m = moves(&path);
    // After the tool change the FROM is a move.
    assert_eq!(m[0].kind, MoveKind::From);
    assert_near(xyz(&*m[0].axis), [0.0, 0.0, 1.0], 1e-12);
    let raw = [-0.655944, 0.057682, 0.752602];
    let norm = raw.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert_near(xyz(&*m[1].axis), raw.map(|v| v / norm), 1e-12);
    assert_near(xyz(&m[1].to), [-5.673572, -1.310773, 13.476254], 1e-12);
    let texts: Vec<&str> = path
        .items
        .iter()
        .filter_map(|i| if let ItemKind::Text(TextKind::Pprint, t) = &i.kind { Some(t.as_str()) } else { None })
        .collect();
    assert_eq!(texts, [format!("({})", "=".repeat(60))]);
}

/// `$$` inside a quoted text is text; after a statement it starts a comment.
#[test]
fn double_dollar_inside_quotes() {
    let path = read_clean("ok_dollar_in_quotes.cl");
    let records: Vec<&Record> =
        path.items.iter().filter_map(|i| if let ItemKind::Record(r) = &i.kind { Some(r) } else { None }).collect();
    assert_eq!(records.len(), 1);
    assert_eq!((records[0].word.as_str(), records[0].args.as_str()), ("SYN", "'TLAXIS','$$*TLAXIS'"));
    assert!(path.items.iter().any(|i| i.kind == ItemKind::Text(TextKind::Pprint, "'cost $$ 5'".into())));
    let m = moves(&path);
    assert_eq!(m.len(), 1);
    assert_near(xyz(&m[0].to), [1.9949, 0.1148, 1.4399], 1e-12);
}

/// Creo: a `$$->` comment continued with a single `$` swallows its bare continuation lines.
#[test]
fn creo_continued_comment() {
    let path = read_clean("ok_creo_continued_comment.cl");
    assert_eq!(path.info.cam_system.map(|c| c.name()), Some("PTC Creo"));
    assert_eq!(path.info.part_name.as_deref(), Some("BOHREN"));
    // PARTNO MACHIN UNITS LOADTL SPINDL RAPID GOTO FEDRAT GOTO SPINDL FINI: the CSYS numbers
    // inside the comment are not statements.
    assert_eq!(path.info.statements, 11);
    assert!(path.items.iter().all(|i| !matches!(&i.kind, ItemKind::Record(r) if r.word != "MACHIN")));
    let m = moves(&path);
    assert_eq!(m.len(), 2);
    assert_eq!(m[1].motion, feed(1193.663081));
}

/// Hand-written APT in lower case reads like upper case.
#[test]
fn lower_case_apt() {
    let path = read_clean("ok_lower_case.cl");
    assert_eq!(path.info.part_name.as_deref(), Some("lower case part"));
    let a = arcs(&path);
    assert_eq!(a.len(), 1);
    assert_close(a[0].sweep, PI, 1e-12);
    assert!(a[0].point_at(0.5).y < 0.0, "counter-clockwise from (-5,0) to (5,0) passes below");
    assert_eq!(moves(&path)[0].motion, Motion::Rapid);
    assert_eq!(moves(&path)[1].motion, feed(100.0));
}

/// The GOTOs between CYCLE/DRILL and CYCLE/OFF are hole positions; `RETURN,0` returns to the
/// height the tool had before the first hole (25 mm above it).
#[test]
fn cycle_holes() {
    let path = read_clean("ok_cycle_holes.cl");
    let kinds: Vec<MoveKind> = moves(&path).iter().map(|m| m.kind).collect();
    use MoveKind::{Goto, Hole};
    assert_eq!(kinds, [Goto, Hole, Hole, Hole, Goto]);
    let c = cycles(&path);
    assert_eq!(c.len(), 1);
    assert_eq!((c[0].kind, c[0].depth, c[0].clearance, c[0].retract), (CycleKind::Drill, 4.6, 2.0, Some(25.0)));
    assert_eq!(c[0].feed, Some(Feed { value: 0.08, per: FeedPer::Revolution }));
    // The cycle comes before its first hole.
    let first_hole = path.items.iter().position(|i| matches!(&i.kind, ItemKind::Move(m) if m.kind == Hole));
    let cycle_at = path.items.iter().position(|i| matches!(i.kind, ItemKind::CycleOn(_)));
    assert!(cycle_at < first_hole);
}

fn cycles(path: &ToolPath) -> Vec<&Cycle> {
    path.items.iter().filter_map(|i| if let ItemKind::CycleOn(c) = &i.kind { Some(&**c) } else { None }).collect()
}

/// Every vendor form of the real files, typed: (kind, depth, R plane, retract, peck, dwell,
/// feed), all in mm above or below the hole point, which is each hole's GOTO.
#[test]
fn cycle_forms_typed() {
    let path = read_clean("ok_cycle_forms.cl");
    let per_min = |value| Some(Feed { value, per: FeedPer::Minute });
    let per_rev = |value| Some(Feed { value, per: FeedPer::Revolution });
    let peck = |first, next| Some(Peck { first, next });
    type Row = (CycleKind, f64, f64, Option<f64>, Option<Peck>, Option<Delay>, Option<Feed>, &'static str);
    let expected: [Row; 12] = [
        (CycleKind::Deep, 9.00161, 3.0, Some(25.0), peck(5.0, 2.0), None, per_min(382.27), "DEEP2"),
        (CycleKind::Drill, 5.4, 3.0, Some(27.5), None, None, per_min(364.49), "DRILL"),
        (CycleKind::Deep, 3.301, 29.0, Some(49.0), peck(10.0, 10.0), None, per_min(791.666667), "DEEP"),
        (CycleKind::Deep, 3.5, 1.0, None, peck(1.0, 1.0), None, per_min(50.0), "DEEP"),
        (CycleKind::Drill, 33.0043, 3.0, None, None, None, per_min(250.0), "DRILL"),
        (CycleKind::Drill, 33.0043, 3.0, Some(4.0), None, None, per_rev(0.25), "DRILL"),
        (CycleKind::Deep, 20.0, 3.0, None, peck(4.0, 4.0), None, per_min(100.0), "DRILL"),
        (CycleKind::Deep, 12.3733, 3.0, Some(46.927686), peck(5.0, 2.0), None, per_min(187.165839), "DRILL"),
        (CycleKind::ChipBreak, 10.0, 2.0, None, peck(2.0, 2.0), Some(Delay::Seconds(0.5)), per_min(100.0), "BRKCHP"),
        (CycleKind::Tap, 12.0, 3.0, None, None, None, per_rev(1.5), "TAP"),
        (CycleKind::Bore, 8.0, 2.0, None, None, Some(Delay::Revolutions(2.0)), per_min(60.0), "BORE"),
        (CycleKind::Bore, 8.0, 2.0, Some(10.0), None, None, per_min(60.0), "REAM"),
    ];
    let c = cycles(&path);
    assert_eq!(c.len(), expected.len());
    for (k, (c, e)) in c.iter().zip(expected).enumerate() {
        let got = (c.kind, c.depth, c.clearance, c.retract, c.peck, c.dwell, c.feed, c.word.as_str());
        assert_eq!(got, e, "cycle {}", k + 1);
    }
    assert_eq!(c[3].args, "DEPTH, 3.500000, STEP, 1.000000, MMPM, 50.000000, CLEAR, 1.000000");
    // INIT, CLEAR and ON are kept as records, not counted as uninterpreted words.
    let announced: Vec<&str> = path
        .items
        .iter()
        .filter_map(|i| if let ItemKind::Record(r) = &i.kind { Some(r.args.as_str()) } else { None })
        .collect();
    assert_eq!(announced, ["INIT", "INIT", "CLEAR", "ON"]);
    assert!(path.info.uninterpreted.is_empty());
    // Every GOTO between a cycle and OFF is a hole at the point written.
    let holes: Vec<[f64; 3]> = moves(&path).iter().filter(|m| m.kind == MoveKind::Hole).map(|m| xyz(&m.to)).collect();
    assert_eq!(holes.len(), 12);
    assert_near(holes[7], [70.0, 0.0, -21.927686], 1e-12);
}

/// The operation markers of NX, CATIA, Creo, Makino and CAMWorks, each an operation start with
/// its name in place; other Makino sections stay text.
#[test]
fn operation_markers() {
    let path = read_clean("ok_operation_markers.cl");
    let names: Vec<&str> = path
        .items
        .iter()
        .filter_map(|i| if let ItemKind::OperationStart(n) = &i.kind { Some(n.as_str()) } else { None })
        .collect();
    assert_eq!(names, ["PLANAR_MILL", "Drilling.1", "FEATNO 32", "MACHINING", "Contour Mill1"]);
    assert!(path.items.iter().any(|i| i.kind == ItemKind::Text(TextKind::Pprint, "BEGIN-SECTION,TOOL".into())));
    // Creo's REMARK style: header and operation, no APT source.
    let path = read_clean("ok_creo_remark_style.cl");
    assert_eq!(path.info.cam_system, Some(CamSystem::Creo));
    assert!(path.items.iter().any(|i| i.kind == ItemKind::OperationStart("FEATNO 1014".into())));
}

/// `--cl-units` replaces the file's UNITS and feed words: an inch file read in mm keeps its
/// numbers.
#[test]
fn cl_units_option() {
    let source = case_source("ok_inch.cl");
    let mm = ReadOptions { cl_units: Some(LengthUnit::Mm), ..ReadOptions::default() };
    let path = read_with(&source, &mm);
    assert!(path.diagnostics.is_empty(), "{}", listing(&source, &path.diagnostics));
    assert_eq!(path.info.units.unit, LengthUnit::Mm);
    assert_eq!(path.info.units.origin, UnitsOrigin::Option);
    assert_near(xyz(&moves(&path)[0].to), [1.0, 2.0, 3.0], 1e-12);
    assert_eq!(moves(&path)[0].motion, feed(10.0));
    // The Fusion file that says UNITS/INCHES over millimetre feeds: the warning names the option;
    // with the option, no warning and no conversion.
    let fusion = Source::from_path(&tests::shared_cl_dir().join("samueljmorris__kuka-fdm__1001.apt")).expect("reads");
    let warned = read(&fusion);
    let w = warned.diagnostics.iter().find(|d| d.message.starts_with("feed unit contradicts")).expect("a warning");
    assert!(w.help.as_deref().is_some_and(|h| h.contains("--cl-units mm|inch")), "{w:?}");
    let path = read_with(&fusion, &mm);
    assert!(path.diagnostics.iter().all(|d| !d.message.starts_with("feed unit")));
    let (a, b) = (moves(&warned)[1].to, moves(&path)[1].to);
    assert_near(xyz(&(a / 25.4)), xyz(&b), 1e-9);
}

/// The error cases keep reading after the error: the statements that follow still count.
#[test]
fn reading_goes_on_after_an_error() {
    let source = case_source("err_circle_without_end.cl");
    let path = read(&source);
    assert_eq!(path.diagnostics.len(), 1);
    // The second CIRCLE gets its end point.
    assert_eq!(arcs(&path).len(), 1);
}

// ----- 4. every real CL file under ../shared/data: arcs, operations, cycles ----------------------

/// Reads every real CL file of `../shared/data` (corpus, peer inputs, hold-out) once.
fn real_files() -> &'static [(String, Source, ToolPath)] {
    static FILES: std::sync::OnceLock<Vec<(String, Source, ToolPath)>> = std::sync::OnceLock::new();
    FILES.get_or_init(|| {
        tests::real_cl_files()
            .into_iter()
            .map(|(name, path)| {
                let source = Source::from_path(&path).expect("the file reads");
                let path = read(&source);
                (name, source, path)
            })
            .collect()
    })
}

/// The sense of the arcs of every real file with arcs: the CAM system's, and how many of the
/// arcs with a tangent neighbour agree with it (pinned per file). Nearly all do; those against
/// it were checked by hand (`docs/cl-reader.md`: rest-machining paths that reverse at an arc).
#[test]
fn arc_sense_of_real_files() {
    let mut table = String::new();
    for (name, source, path) in real_files() {
        let i = path.info.arc_sense;
        let c = i.checks;
        if c.arcs == 0 {
            continue;
        }
        let origin = match i.origin {
            ArcSenseOrigin::CamSystem(cam) => cam.name().to_string(),
            ArcSenseOrigin::None => "each record says CLOCKWISE or COUNTERCLOCKWISE".into(),
            other => format!("{other:?}"),
        };
        let sense = i.sense.map_or("spelled out", ArcSense::name);
        let _ = writeln!(
            table,
            "{name}: {sense} ({origin}): {} arcs, {} with a tangent neighbour, {} agree, {} against",
            c.arcs, c.checkable, c.agree, c.contradict
        );
        assert_eq!(c.agree + c.contradict, c.checkable, "{name}");
        assert!(c.contradict * 10 <= c.checkable, "{name}: {c:?}");
        let errors: Vec<&Diagnostic> = path.diagnostics.iter().filter(|d| d.is_error()).collect();
        assert!(errors.is_empty(), "{name}:\n{}", listing(source, &path.diagnostics));
    }
    insta::assert_snapshot!(table);
}

/// The operations of every real file, by name, in order.
#[test]
fn operations_of_real_files() {
    let mut table = String::new();
    for (name, _, path) in real_files() {
        let names: Vec<&str> = path
            .items
            .iter()
            .filter_map(|i| if let ItemKind::OperationStart(n) = &i.kind { Some(n.as_str()) } else { None })
            .collect();
        let _ = writeln!(table, "{name}: {}", if names.is_empty() { "-".to_string() } else { names.join(" | ") });
    }
    insta::assert_snapshot!(table);
}

/// The canned cycles of every real file with cycles, typed (mm from each hole's top point), with
/// the line of the CYCLE statement and the number of holes that follow.
#[test]
fn cycles_of_real_files() {
    let mut table = String::new();
    for (name, source, path) in real_files() {
        let mut rows: Vec<(String, usize)> = Vec::new();
        for item in &path.items {
            match &item.kind {
                ItemKind::CycleOn(c) => {
                    let line = source.line_col(item.span.start as usize).line;
                    let retract = c.retract.map_or("R plane".into(), |r| r.to_string());
                    let peck = c.peck.map_or("-".into(), |p| format!("{}/{}", p.first, p.next));
                    let dwell = c.dwell.map_or("-".into(), |d| format!("{d:?}"));
                    let feed = c.feed.map_or("modal".into(), |f| format!("{} per {:?}", f.value, f.per));
                    rows.push((
                        format!(
                            "  line {line}: {:?} ({}), depth {}, R {}, retract {retract}, peck {peck}, dwell {dwell}, feed {feed}",
                            c.kind, c.word, c.depth, c.clearance
                        ),
                        0,
                    ));
                }
                ItemKind::Move(m) if m.kind == MoveKind::Hole => {
                    if let Some(row) = rows.last_mut() {
                        row.1 += 1;
                    }
                }
                _ => {}
            }
        }
        if rows.is_empty() {
            continue;
        }
        let _ = writeln!(table, "{name}:");
        for (row, holes) in rows {
            let _ = writeln!(table, "{row}: {holes} hole(s)");
        }
        assert_eq!(errors_but_turning(name, &path.diagnostics), 0, "{name}:\n{}", listing(source, &path.diagnostics));
    }
    insta::assert_snapshot!(table);
}
