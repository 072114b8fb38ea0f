//! The validation harness against real data: the readers of `tests::golden` read every program
//! the peers' posts wrote, and the NX post's programs agree with the CL files they came from
//! (feed path length, arc senses, every CL point on the feed path). `--nocapture` prints the
//! figures.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use nalgebra::Point3;
use postpro_cl::{ItemKind, Motion as ClMotion};
use tests::compare::{feed_path_length, max_distance_of_points_to_feed_path};
use tests::golden::{self, Case, fanuc, heidenhain};
use tests::nc::{EventKind, Plane, Program, Units};

/// A program read by `reader`, named by its path under `../shared/data`.
fn read(path: &Path, reader: fn(&str, &str) -> Result<Program, tests::Error>) -> Result<Program, tests::Error> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let data = tests::shared_peers_dir().parent().map(Path::to_path_buf).unwrap_or_default();
    let name = path.strip_prefix(&data).unwrap_or(path).to_string_lossy().replace('\\', "/");
    reader(&name, &text)
}

/// What a program holds, in one line.
fn summary(p: &Program) -> String {
    let count = |wanted: fn(&EventKind) -> bool| p.events.iter().filter(|e| wanted(&e.kind)).count();
    format!(
        "{}: {} motions ({} arcs), feed path {:.4} {}, {} holes, {} machine-frame moves, {} positionings, {} unresolved",
        p.name,
        p.motions.len(),
        p.motions.iter().filter(|m| m.arc().is_some()).count(),
        feed_path_length(&p.motions),
        if p.units == Units::Inch { "in" } else { "mm" },
        count(|k| matches!(k, EventKind::Hole { .. })),
        count(|k| matches!(k, EventKind::MachineFrameMove { .. })),
        count(|k| matches!(k, EventKind::Positioning { .. })),
        count(|k| matches!(k, EventKind::Unresolved { .. })),
    )
}

fn report(text: &str) {
    let _ = writeln!(std::io::stderr(), "{text}");
}

#[test]
fn every_program_of_the_nx_haas_post_reads() {
    let cases = golden::nx_haas_cases();
    assert_eq!(cases.len(), 5, "{cases:?}");
    let mut out = String::new();
    for case in &cases {
        for path in &case.expected {
            let p = read(path, fanuc::read).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(p.units, Units::Inch, "{}", p.name);
            let _ = writeln!(out, "{}", summary(&p));
            assert!(p.motions.iter().any(|m| m.is_feed()), "{}", p.name);
            // NX's post writes its arcs in G17.
            assert!(p.motions.iter().filter_map(|m| m.arc()).all(|a| a.plane == Plane::Xy), "{}", p.name);
            assert!(p.events.iter().any(|e| e.kind == EventKind::End), "{}", p.name);
        }
    }
    report(&out);
}

#[test]
fn every_program_of_clsplit_reads_but_its_nan_set_up() {
    let cases = golden::clsplit_cases();
    assert_eq!(cases.len(), 12, "{cases:?}");
    let mut out = String::new();
    let mut refused = Vec::new();
    for case in &cases {
        for path in &case.expected {
            match read(path, heidenhain::read) {
                Ok(p) => {
                    let _ = writeln!(out, "{}", summary(&p));
                }
                Err(e) => refused.push(e.to_string()),
            }
        }
    }
    report(&out);
    // clsplit writes `nan` for the set-up whose axis is -Z (its README): those two programs,
    // and only they, do not read.
    assert_eq!(
        refused,
        [
            "peers/aamorim1913__AptPostProcessor/parts-2021/Sacrifice-Board/expected/912.h:5:16: not a number: `Xnan`",
            "peers/aamorim1913__AptPostProcessor/parts-2021/Sacrifice-Board/expected/912setup.h:4:17: not a number: `Xnan`"
        ]
    );
}

/// The CL file's feed path (mm) and its points, as our reader reads it.
struct ClPath {
    length: f64,
    points: Vec<[f64; 3]>,
    /// Each arc's end point and whether it runs clockwise seen from +Z.
    arcs: Vec<([f64; 3], bool)>,
}

fn cl_path(case: &Case) -> ClPath {
    let text = std::fs::read_to_string(&case.input).expect("the CL file");
    let source = postpro_cl::Source::new(tests::repo_relative(&case.input), text);
    let path = postpro_cl::read(&source);
    assert!(!path.has_errors(), "{}: {:?}", case.name, path.diagnostics);
    let mut last: Option<Point3<f64>> = None;
    let mut out = ClPath { length: 0.0, points: Vec::new(), arcs: Vec::new() };
    for item in &path.items {
        match &item.kind {
            ItemKind::Move(m) => {
                if let (ClMotion::Feed(_), Some(from)) = (m.motion, last) {
                    out.length += (m.to - from).norm();
                    out.points.push(m.to.into());
                }
                last = Some(m.to);
            }
            ItemKind::Arc(a) => {
                out.length += a.length();
                out.points.push(a.end.into());
                // Counter-clockwise about its normal: clockwise seen from +Z when the normal points down.
                out.arcs.push((a.end.into(), a.normal.z < 0.0));
                last = Some(a.end);
            }
            _ => {}
        }
    }
    out
}

/// NX's own post and our reader agree on the NX CLSFs: the feed path of NX's program (read by
/// `golden::fanuc`) is as long as the CL file's (read by `postpro_cl`, its arcs clockwise about
/// their axis as NX writes them), every NX arc turns the way the CL arc with its end point turns,
/// and every CL feed point lies on NX's feed path (its four decimals in inches).
#[test]
fn the_nx_programs_follow_their_cl_files() {
    let mut out = String::new();
    for case in golden::nx_haas_cases() {
        let nx = read(&case.expected[0], fanuc::read).unwrap_or_else(|e| panic!("{e}")).in_units(Units::Mm);
        let cl = cl_path(&case);
        let nx_length = feed_path_length(&nx.motions);
        let relative = (nx_length - cl.length) / cl.length;
        // Arcs: each NX arc against the CL arc with the same end point, in order.
        let (mut agree, mut disagree, mut unmatched) = (0, 0, 0);
        let mut next = 0;
        for m in nx.motions.iter().filter(|m| m.arc().is_some()) {
            let clockwise = m.arc().is_some_and(|a| a.clockwise);
            let found = cl.arcs[next..].iter().position(|(end, _)| (0..3).all(|k| (end[k] - m.to[k]).abs() < 0.01));
            match found {
                Some(k) => {
                    next += k + 1;
                    if cl.arcs[next - 1].1 == clockwise { agree += 1 } else { disagree += 1 }
                }
                None => unmatched += 1,
            }
        }
        let far = max_distance_of_points_to_feed_path(&cl.points, &nx.motions).expect("CL points");
        let _ = writeln!(
            out,
            "{}: NX feed path {nx_length:.3} mm, CL {:.3} mm ({:+.4} %); NX arcs {}: {agree} agree in sense with the CL's, \
             {disagree} disagree, {unmatched} without a CL arc ending there (CL arcs: {}); CL points off NX's feed path: \
             at most {:.4} mm (point {}, NX line {:?})",
            case.name,
            cl.length,
            relative * 100.0,
            agree + disagree + unmatched,
            cl.arcs.len(),
            far.distance,
            far.point,
            far.line
        );
        assert_eq!(disagree, 0, "{}", case.name);
        assert!(far.distance < 0.01, "{}: {far:?}", case.name);
        if case.name.ends_with("SimpleMillPlane_ZIG") {
            assert!(relative.abs() < 1e-4, "{}: {nx_length} against {}", case.name, cl.length);
            assert_eq!((agree, unmatched), (30, 0));
        }
    }
    report(&out);
}
