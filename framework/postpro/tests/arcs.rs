//! CL arcs as circular interpolation, validated by back-simulation: the real `postpro` writes
//! the program, LinuxCNC's `rs274` (or the harness's readers of the other dialects) runs it, and
//! the canonical feed path is held to the CL file's own path (`docs/validation-harness.md`).
//!
//! `--nocapture` prints the figures of each file.

mod common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use common::backsim;
use postpro_cl::ReadOptions;
use tests::compare::{arcs_match, feed_path_length};
use tests::golden::{self, Case, fanuc, heidenhain};
use tests::nc::{Program, Units};

/// The machine every 3-axis file runs on, and its dialect.
const VMC: &str = "example-3axis-vmc";

/// The figures, shown with `--nocapture`.
fn report(text: &str) {
    eprintln!("{text}");
}

/// The machine's linearization tolerance (mm): how far a chord may leave the CL path.
fn linearization_tolerance(machine: &str) -> f64 {
    let registry = postpro_machine::Registry::builtin().expect("the built-in machines");
    registry.find(machine).expect("the machine").machine.policy.linearization_tolerance
}

/// Which plane of the frame an arc about `normal` lies in: 0 XY, 1 ZX, 2 YZ; `None` for other
/// planes (the product's own test: within 1e-6 rad of a frame axis).
fn frame_plane(normal: [f64; 3]) -> Option<usize> {
    let n = (normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]).sqrt();
    let axis = (0..3).max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))?;
    let cos = normal[axis].abs() / n;
    (1.0 - cos <= 1e-12 / 2.0 + f64::EPSILON).then_some(match axis {
        2 => 0,
        1 => 1,
        _ => 2,
    })
}

/// Every real 3-axis CL file with arcs under `../shared/data` (corpus, peer inputs, hold-out),
/// as our reader classifies it.
fn three_axis_files_with_arcs() -> Vec<(String, PathBuf)> {
    tests::real_cl_files()
        .into_iter()
        .filter(|(_, path)| {
            let Ok(text) = std::fs::read_to_string(path) else { return false };
            let source = postpro_cl::Source::new(path.to_string_lossy(), text);
            let tool_path = postpro_cl::read(&source);
            let summary = postpro_cl::summarize_tool_path(&source, &tool_path);
            !tool_path.has_errors() && summary.axes == "3-axis" && summary.arcs > 0
        })
        .collect()
}

/// Every real 3-axis file with arcs, written for LinuxCNC on the 3-axis VMC and run by rs274:
/// the canonical feed path (`ARC_FEED` and `STRAIGHT_FEED`, the canned cycles' moves left out)
/// is as long as the CL file's feed path within 0.1 %, and passes within the machine's
/// linearization tolerance plus the written rounding of every CL feed point and of the points at
/// a quarter, half and three quarters of every CL arc (which an arc turning the wrong way
/// misses by up to its diameter). Every CL arc in a plane of the frame is written as one arc in
/// that plane; the counts per file are pinned.
#[test]
fn every_three_axis_file_with_arcs_keeps_its_path_through_rs274() {
    let files = three_axis_files_with_arcs();
    let tolerance = linearization_tolerance(VMC);
    let mut table = String::new();
    let mut figures = String::new();
    let mut failures = Vec::new();
    for (name, path) in &files {
        let cl = backsim::read_cl(path, &ReadOptions::default());
        let written = match backsim::write("arcs", path, VMC, "linuxcnc", &[]) {
            Ok(w) => w,
            Err(e) => {
                failures.push(format!("{name}: {e}"));
                continue;
            }
        };
        let Some(ran) = backsim::rs274(&written, &cl) else { return };
        let program = match ran {
            Ok(p) => p,
            Err(e) => {
                failures.push(format!("{name}: {e}"));
                continue;
            }
        };
        // The written decimals, and rs274's four decimals on top.
        let rounding = backsim::rounding(&written.text) + 0.5e-4 * 3f64.sqrt();
        let allowed = tolerance + rounding;
        let motions = backsim::cl_motions(&program, &written.text, &cl, rounding);
        let ours = feed_path_length(&motions);
        let relative = (ours - cl.length) / cl.length;
        let far = backsim::farthest_point(&cl.points, &motions, allowed).expect("CL feed points");
        let (written_planes, turning) = backsim::arc_counts(&motions);
        let mut cl_planes = [0; 3];
        let mut other = 0;
        for arc in &cl.arcs {
            match frame_plane(arc.normal) {
                Some(k) => cl_planes[k] += 1,
                None => other += 1,
            }
        }
        let _ = writeln!(
            table,
            "{name}: CL arcs {} (XY {}, ZX {}, YZ {}, other planes {other}); written G17 {}, G18 {}, G19 {} ({turning} with full turns)",
            cl.arcs.len(),
            cl_planes[0],
            cl_planes[1],
            cl_planes[2],
            written_planes[0],
            written_planes[1],
            written_planes[2],
        );
        let _ = writeln!(
            figures,
            "{name}: feed path {ours:.3} mm, CL {:.3} mm ({:+.4} %); CL points off it at most {:.4} mm (allowed {allowed:.4}; point {} near line {:?})",
            cl.length,
            relative * 100.0,
            far.distance,
            far.point,
            far.line
        );
        if relative.abs() > 1e-3 {
            failures.push(format!(
                "{name}: feed path {ours:.4} mm against the CL's {:.4} mm ({:+.4} %)",
                cl.length,
                relative * 100.0
            ));
        }
        if far.distance > allowed {
            let p = cl.points[far.point];
            failures.push(format!(
                "{name}: CL point {} ({:.4}, {:.4}, {:.4}) is {:.4} mm off our feed path (nearest: our line {:?} of {}), beyond {allowed:.4}",
                far.point,
                p[0],
                p[1],
                p[2],
                far.distance,
                far.line,
                written.path.display()
            ));
        }
        if written_planes != cl_planes {
            failures.push(format!(
                "{name}: the CL arcs in planes of the frame (XY, ZX, YZ) are {cl_planes:?}, written as arcs {written_planes:?}"
            ));
        }
    }
    report(&figures);
    assert!(failures.is_empty(), "{} failure(s):\n{}", failures.len(), failures.join("\n"));
    insta::assert_snapshot!(table);
}

/// True when our reader finds the CL file 3-axis.
fn three_axis(path: &Path) -> bool {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let source = postpro_cl::Source::new(path.to_string_lossy(), text);
    postpro_cl::summarize(&source).0.axes == "3-axis"
}

/// A peer's program read by `reader`.
fn theirs(path: &Path, reader: fn(&str, &str) -> Result<Program, tests::Error>) -> Program {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    reader(&backsim::data_name(path), &text).unwrap_or_else(|e| panic!("{e}"))
}

/// Siemens NX's own Haas post (the MECH491 pairs) against ours, on the four 3-axis NX CLSFs:
/// every arc of NX's program is in ours, in order, with the same end point, centre, plane and
/// sense (0.0002 in: both write four decimals of an inch, the centre as the start plus I J).
/// Ours twice: the LinuxCNC program as rs274 runs it (an interpreter that shares no code with
/// ours), and our Fanuc program read by the reader that reads NX's (our I J words and G2/G3).
/// The frame is NX's and ours alike: G54 on the part zero of the CLSF, in inches (`--units
/// inch`).
#[test]
fn every_arc_of_the_nx_posts_programs_is_ours() {
    let cases: Vec<(Case, PathBuf)> = golden::nx_haas_cases()
        .into_iter()
        .filter(|c| three_axis(&c.input))
        .map(|c| {
            let program = c.expected[0].clone();
            (c, program)
        })
        .collect();
    assert_eq!(cases.len(), 4, "the four 3-axis MECH491 pairs");
    peers_arcs_are_ours(&cases, ("fanuc", fanuc::read), &["--units", "inch"], Units::Inch, 2e-4);
}

/// clsplit's Heidenhain programs of the 3-axis SOLIDWORKS CAM parts (the AptPostProcessor
/// pairs) against ours: every arc of clsplit's (`CC` + `C … DR±`) is in ours, in order, with the
/// same end point, centre and sense (0.002 mm: both write three decimals, our centre as the
/// start plus I J). Ours twice: the LinuxCNC program as rs274 runs it, an interpreter
/// independent of both posts and of the harness's readers, which is why it is the reference;
/// and our Heidenhain program read by the reader that reads clsplit's (our `CC`/`C DR±`).
///
/// The frame: clsplit writes one program per CSYS set-up, `NN.h`, shifted by `CYCL DEF 7` to
/// the set-up's datum, which for a set-up about +Z is the CSYS origin itself (shift 0: its README,
/// "Datum shift per setup"), and `NNsetup.h` with the shift of the measured datum, which the
/// shop's probing (`0TREF.h`) fills in. So `11.h` is in the CL file's part frame, as ours (G54 on
/// the part zero): compared as they are, the 3-axis parts having the one set-up `11`.
#[test]
fn every_arc_of_clsplits_programs_is_ours() {
    let cases: Vec<(Case, PathBuf)> = golden::clsplit_cases()
        .into_iter()
        .filter(|c| three_axis(&c.input))
        .map(|c| {
            let programs = set_up_programs(&c);
            assert_eq!(programs.len(), 1, "{}: one set-up program: {programs:?}", c.name);
            let program = programs[0].clone();
            (c, program)
        })
        .collect();
    assert_eq!(cases.len(), 7, "the 3-axis AptPostProcessor parts");
    peers_arcs_are_ours(&cases, ("heidenhain", heidenhain::read), &[], Units::Mm, 2e-3);
}

/// clsplit's set-up programs of a part: `NN.h` (not the datum shifts `NNsetup.h`, nor the
/// probing `0TREF.h`).
fn set_up_programs(case: &Case) -> Vec<&PathBuf> {
    case.expected
        .iter()
        .filter(|p| p.file_stem().is_some_and(|s| s.to_string_lossy().chars().all(|c| c.is_ascii_digit())))
        .filter(|p| !p.ends_with("0TREF.h"))
        .collect()
}

/// A dialect and the harness's reader of it.
type Dialect = (&'static str, fn(&str, &str) -> Result<Program, tests::Error>);

/// Every arc of each case's peer program (read by the dialect's reader) is in ours on the VMC
/// (`extra` arguments), in `units`, within `tolerance`: our LinuxCNC program through rs274, and
/// our program in the peer's dialect read by the same reader.
fn peers_arcs_are_ours(
    cases: &[(Case, PathBuf)],
    (dialect, reader): Dialect,
    extra: &[&str],
    units: Units,
    tolerance: f64,
) {
    let mut out = String::new();
    let mut failures = Vec::new();
    for (case, program) in cases {
        let peer = theirs(program, reader);
        let cl = backsim::read_cl(&case.input, &ReadOptions::default());
        let through_rs274 = match backsim::write("arcs-peers", &case.input, VMC, "linuxcnc", extra) {
            Ok(written) => match backsim::rs274(&written, &cl) {
                None => return,
                Some(ran) => ran,
            },
            Err(e) => Err(e),
        };
        let same_dialect = backsim::write("arcs-peers", &case.input, VMC, dialect, extra)
            .and_then(|w| reader(&w.path.to_string_lossy(), &w.text).map_err(|e| e.to_string()));
        for (how, ours) in [("rs274", through_rs274), (dialect, same_dialect)] {
            let ours = match ours {
                Ok(p) => p.in_units(units),
                Err(e) => {
                    failures.push(format!("{} ({how}): {e}", case.name));
                    continue;
                }
            };
            let c = arcs_match(&ours.motions, &peer.motions, tolerance);
            let _ = writeln!(out, "{} ({how}): their arcs {c}", case.name);
            if !c.is_match() {
                failures.push(format!("{} ({how}): {c}", case.name));
            }
        }
    }
    report(&out);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// clsplit's program of a set-up as written: its `CYCL DEF 7` datum shift taken back out of the
/// positions (the reader adds it, to give them in the frame the program starts in).
fn without_datum_shift(program: &Program) -> Program {
    let mut out = program.clone();
    for event in &program.events {
        let tests::nc::EventKind::WorkOffset { name, offset: Some(shift) } = &event.kind else { continue };
        if name != "CYCL DEF 7" {
            continue;
        }
        let shift = shift.map(|v| v.unwrap_or(0.0));
        let back = |p: &mut [f64; 3]| (0..3).for_each(|k| p[k] -= shift[k]);
        for m in &mut out.motions[event.before..] {
            back(&mut m.from);
            back(&mut m.to);
            if let tests::nc::MotionKind::Arc(arc) = &mut m.kind {
                back(&mut arc.center);
            }
        }
    }
    out
}

/// clsplit's programs of the tilted set-ups (its 3+2 SOLIDWORKS CAM parts: a side face, 90°
/// about Y, of Teste-Metrologia and boss; the opposite side, C 180° B 90°, of wall-holes; a wedge
/// tilted 0.29° of shimemcunha) against ours on the Haas UMC-750, a table-table with B about Y and
/// C about Z like clsplit's machine, through rs274: every arc of each set-up program is in ours,
/// with end, centre, plane and sense (0.002 mm).
///
/// The frame: clsplit writes a set-up's points rotated about the part zero so that the set-up's
/// axis is +Z (`p' = Ry(−B)·Rz(−C)·p`, its README), then shifts the datum by `CYCL DEF 7` to
/// where the measured pivot puts it. Ours, in joint mode with the part zero on the table axes'
/// intersection (`--part-origin 0,0,0`), are the same rotation of the same points: the axis values
/// of the tilted table. So clsplit's positions are compared as written, the datum shift taken
/// back out. Sacrifice-Board is left out: its second set-up points along −Z, beyond the Haas's B
/// travel (and clsplit wrote `nan` for it); shimemcunha's second set-up, `12.h`, has a test of its
/// own ([`shimemcunhas_second_set_up_is_about_z_as_its_csys_says`]).
#[test]
fn every_arc_of_clsplits_tilted_set_ups_is_ours() {
    let cases: Vec<Case> = golden::clsplit_cases()
        .into_iter()
        .filter(|c| !three_axis(&c.input) && !c.name.ends_with("Sacrifice-Board"))
        .collect();
    assert_eq!(cases.len(), 4, "{cases:?}");
    tilted_set_ups(&cases, |program| !program.ends_with("shimemcunha/expected/12.h"));
}

/// shimemcunha's second set-up (`CSYS/1.,0,0,0,0,1.,0,0,0,0,1.,0` after the first's tilted one,
/// then 3-value GOTOs) is about +Z: clsplit machines it so (`12.h`: "axis 0.000 0.000 1.000";
/// its README: the set-up axis is the CSYS's third column), and so does our reader, which takes a
/// SOLIDWORKS CAM set-up's tool axis from its `CSYS`. It used to keep the tool axis of the first
/// set-up's 6-value GOTOs, (0.005061, 0, 0.999987): the Haas stayed at B 0.29° for the three holes
/// and the contours, whose 28 arcs were then not circles of the frame and came out as chords (none
/// of clsplit's arcs was in ours).
#[test]
fn shimemcunhas_second_set_up_is_about_z_as_its_csys_says() {
    let cases: Vec<Case> = golden::clsplit_cases().into_iter().filter(|c| c.name.ends_with("shimemcunha")).collect();
    tilted_set_ups(&cases, |program| program.ends_with("shimemcunha/expected/12.h"));
}

/// Every arc of clsplit's set-up programs of `cases` that `compared` keeps is in ours (the Haas,
/// through rs274, the part zero on the table axes' intersection), the datum shift taken out.
fn tilted_set_ups(cases: &[Case], compared: impl Fn(&Path) -> bool) {
    let mut out = String::new();
    let mut failures = Vec::new();
    for case in cases {
        let cl = backsim::read_cl(&case.input, &ReadOptions::default());
        let extra = ["--units", "mm", "--part-origin", "0,0,0"];
        let ours = match backsim::write("arcs-peers", &case.input, "haas-umc750", "linuxcnc", &extra) {
            Ok(written) => match backsim::rs274(&written, &cl) {
                None => return,
                Some(ran) => ran,
            },
            Err(e) => Err(e),
        };
        let ours = match ours {
            Ok(p) => p,
            Err(e) => {
                failures.push(format!("{}: {e}", case.name));
                continue;
            }
        };
        let set_ups = set_up_programs(case).into_iter().filter(|p| compared(p));
        for program in set_ups {
            let clsplit = without_datum_shift(&theirs(program, heidenhain::read));
            let c = arcs_match(&ours.motions, &clsplit.motions, 2e-3);
            let _ = writeln!(out, "{} {}: clsplit's arcs {c}", case.name, backsim::data_name(program));
            if !c.is_match() {
                failures.push(format!("{} {}: {c}", case.name, backsim::data_name(program)));
            }
        }
    }
    report(&out);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// An NX CLSF (3-axis, arcs clockwise about their axis vector) with the arc cases a post gets
/// wrong: a full circle of R 20 about +Z (start = end; G2 seen from +Z), a helix of 3 turns in
/// all about −Z (`TIMES,3`: two full turns and a quarter, counter-clockwise seen from +Z, 6 mm
/// down: LinuxCNC `P3`, Siemens `TURN=2`, Heidenhain `CP IPA+810`, Fanuc one block per turn),
/// and a quarter of R 10 in a plane tilted 36.87° about X (axis (0, −0.6, 0.8)), not a plane of
/// the frame. Each arc has a straight lead-in tangent to it.
const EDGES: &str = "TOOL PATH/EDGES,TOOL,MILL-10
TLDATA/MILL,10.0000,0.0000,75.0000,0.0000,0.0000
LOAD/TOOL,1
SPINDL/RPM,5000,CLW
RAPID
GOTO/20.0000,10.0000,10.0000,0.0000000,0.0000000,1.0000000
FEDRAT/MMPM,1000.0000
GOTO/20.0000,10.0000,0.0000
GOTO/20.0000,0.0000,0.0000
CIRCLE/0.0000,0.0000,0.0000,0.0000000,0.0000000,1.0000000,20.0000,0.0600,0.5000,10.0000,0.0000
GOTO/20.0000,0.0000,0.0000
CIRCLE/0.0000,0.0000,-6.0000,0.0000000,0.0000000,-1.0000000,20.0000,0.0600,0.5000,10.0000,0.0000,TIMES,3
GOTO/0.0000,20.0000,-6.0000
CIRCLE/0.0000,12.0000,-12.0000,0.0000000,-0.6000000,0.8000000,10.0000,0.0600,0.5000,10.0000,0.0000
GOTO/10.0000,12.0000,-12.0000
GOTO/10.0000,12.0000,5.0000
END-OF-PATH
";

/// The helix's length: 4.5 turns of R 20 (two full turns and a quarter… of the 810° sweep), 6 mm
/// down.
fn helix_length() -> f64 {
    (20.0 * 4.5 * std::f64::consts::PI).hypot(6.0)
}

/// `EDGES` written to the test's target folder, once: the tests run in parallel, and one must
/// not read the file while another writes it.
fn edges_file() -> PathBuf {
    static FILE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    FILE.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("arcs-edges");
        std::fs::create_dir_all(&dir).expect("a folder");
        let path = dir.join("edges.cls");
        std::fs::write(&path, EDGES).expect("the CL file");
        path
    })
    .clone()
}

/// The arcs of a program, in order.
fn arcs(program: &Program) -> Vec<&tests::nc::Motion> {
    program.motions.iter().filter(|m| m.arc().is_some()).collect()
}

/// `EDGES` through rs274 (LinuxCNC on the VMC): the full circle is one `ARC_FEED` of 360°,
/// clockwise seen from +Z, 2π·20 long; the helix one of 810° (`P3`: two full turns on top),
/// counter-clockwise, as long as the CL helix, ending 6 mm down where the CL file does; the tilted
/// arc is chords (no third arc) within the machine's tolerance and the rounding of every point
/// of it (64 along the quarter); the feed path is the CL file's within 0.1 %.
#[test]
fn a_full_circle_a_multi_turn_helix_and_a_tilted_arc_run_as_the_cl_file_says() {
    let path = edges_file();
    let cl = backsim::read_cl(&path, &ReadOptions::default());
    let written = backsim::write("arcs-edges", &path, VMC, "linuxcnc", &[]).unwrap_or_else(|e| panic!("{e}"));
    let Some(ran) = backsim::rs274(&written, &cl) else { return };
    let program = ran.unwrap_or_else(|e| panic!("{e}"));
    let arcs = arcs(&program);
    assert_eq!(arcs.len(), 2, "the circle and the helix; the tilted arc as chords");
    let (circle, helix) = (arcs[0], arcs[1]);
    let tau = std::f64::consts::TAU;
    assert_eq!(circle.arc().map(|a| (a.plane, a.clockwise, a.full_turns)), Some((tests::nc::Plane::Xy, true, 0)));
    assert!((circle.sweep().unwrap_or(0.0) - tau).abs() < 1e-9, "{circle:?}");
    assert!((circle.length() - tau * 20.0).abs() < 1e-3, "{}", circle.length());
    assert_eq!(helix.arc().map(|a| (a.plane, a.clockwise, a.full_turns)), Some((tests::nc::Plane::Xy, false, 2)));
    assert!((helix.sweep().unwrap_or(0.0) - 2.25 * tau).abs() < 1e-6, "{helix:?}");
    assert!((helix.length() - helix_length()).abs() < 1e-3, "{} against {}", helix.length(), helix_length());
    assert!(helix.to.iter().zip([0.0, 20.0, -6.0]).all(|(a, b)| (a - b).abs() < 1e-3), "{helix:?}");
    // The tilted quarter, 64 points along it.
    let mut tilted = cl.path.items.iter().filter_map(|i| match &i.kind {
        postpro_cl::ItemKind::Arc(a) => Some(a),
        _ => None,
    });
    let tilted = tilted.next_back().expect("the tilted arc");
    let rounding = backsim::rounding(&written.text) + 0.5e-4 * 3f64.sqrt();
    let allowed = linearization_tolerance(VMC) + rounding;
    let points: Vec<[f64; 3]> = (0..=64).map(|k| tilted.point_at(f64::from(k) / 64.0).into()).collect();
    let far = backsim::farthest_point(&points, &program.motions, allowed).expect("points");
    assert!(far.distance <= allowed, "the tilted arc is {} mm off the chords (allowed {allowed})", far.distance);
    let chords = program
        .motions
        .iter()
        .filter(|m| m.is_feed() && m.arc().is_none() && m.to[2] < -6.0 + 1e-6 && m.from[2] <= -6.0 + 1e-6)
        .count();
    assert!(chords >= 4, "{chords} chords on the tilted quarter");
    let ours = feed_path_length(&backsim::cl_motions(&program, &written.text, &cl, rounding));
    assert!(((ours - cl.length) / cl.length).abs() < 1e-3, "{ours} against {}", cl.length);
    report(&format!(
        "edges: circle {:.4} mm, helix {:.4} mm (CL {:.4}), tilted quarter as {chords} chords, {:.4} mm off at most; feed path {ours:.4} mm, CL {:.4} mm",
        circle.length(),
        helix.length(),
        helix_length(),
        far.distance,
        cl.length
    ));
}

/// Fanuc has no `P` on arcs: the helix is written one turn per block. Read back by the harness's
/// Fanuc reader, the helix is three arcs, counter-clockwise seen from +Z, of 360°, 360° and 90°
/// that end at 1/4.5, 2/4.5 and all of the 6 mm down, as long as the helix together; the full
/// circle is one block of 360°. Heidenhain writes the helix as one `CP IPA+810 IZ-6 DR+` and the
/// circle as `C … DR-` ending where it starts; its reader finds the same two arcs.
#[test]
fn fanuc_writes_a_helix_one_turn_per_block_and_heidenhain_in_one() {
    let path = edges_file();
    let tau = std::f64::consts::TAU;
    let written = backsim::write("arcs-edges", &path, VMC, "fanuc", &[]).unwrap_or_else(|e| panic!("{e}"));
    let fanuc = fanuc::read("edges.nc", &written.text).unwrap_or_else(|e| panic!("{e}"));
    let arcs_of_fanuc = arcs(&fanuc);
    assert_eq!(arcs_of_fanuc.len(), 4, "the circle, and the helix in three blocks: {arcs_of_fanuc:?}");
    assert!((arcs_of_fanuc[0].sweep().unwrap_or(0.0) - tau).abs() < 1e-9);
    let helix = &arcs_of_fanuc[1..];
    let sweeps: Vec<f64> = helix.iter().map(|m| m.sweep().unwrap_or(0.0) / tau * 360.0).collect();
    assert!(sweeps.iter().zip([360.0, 360.0, 90.0]).all(|(a, b)| (a - b).abs() < 1e-6), "{sweeps:?}");
    assert!(helix.iter().all(|m| m.arc().is_some_and(|a| !a.clockwise && a.full_turns == 0)));
    let depths: Vec<f64> = helix.iter().map(|m| m.to[2]).collect();
    for (depth, expected) in depths.iter().zip([-6.0 / 4.5 * 2.0, -6.0 / 4.5 * 4.0, -6.0]) {
        assert!((depth - expected).abs() < 1e-3, "{depths:?}");
    }
    let length: f64 = helix.iter().map(|m| m.length()).sum();
    assert!((length - helix_length()).abs() < 2e-3, "{length} against {}", helix_length());

    let written = backsim::write("arcs-edges", &path, VMC, "heidenhain", &[]).unwrap_or_else(|e| panic!("{e}"));
    assert!(written.text.contains("CP IPA+810.000 IZ-6.000 DR+"), "{}", written.text);
    let heidenhain = heidenhain::read("edges.h", &written.text).unwrap_or_else(|e| panic!("{e}"));
    let arcs_of_heidenhain = arcs(&heidenhain);
    assert_eq!(arcs_of_heidenhain.len(), 2, "{arcs_of_heidenhain:?}");
    assert!((arcs_of_heidenhain[0].sweep().unwrap_or(0.0) - tau).abs() < 1e-9, "{:?}", arcs_of_heidenhain[0]);
    assert!(arcs_of_heidenhain[0].arc().is_some_and(|a| a.clockwise));
    let helix = arcs_of_heidenhain[1];
    assert!((helix.sweep().unwrap_or(0.0) - 2.25 * tau).abs() < 1e-6, "{helix:?}");
    assert!((helix.length() - helix_length()).abs() < 2e-3, "{}", helix.length());
}

/// `--arcs linear`: no arc at all in the program, and the chords keep the CL path as the arcs
/// did (length within 0.1 %, every CL point and arc quarter within the tolerance and the
/// rounding), on `EDGES` and on the NX CLSF with 140 arcs.
#[test]
fn arcs_linear_writes_chords_within_the_tolerance() {
    let tolerance = linearization_tolerance(VMC);
    let files = [edges_file(), tests::shared_cl_dir().join("HumMan__CLSFProcessor__cutcom.clsf")];
    for path in &files {
        let cl = backsim::read_cl(path, &ReadOptions::default());
        let written = backsim::write("arcs-linear", path, VMC, "linuxcnc", &["--arcs", "linear"])
            .unwrap_or_else(|e| panic!("{e}"));
        let Some(ran) = backsim::rs274(&written, &cl) else { return };
        let program = ran.unwrap_or_else(|e| panic!("{e}"));
        assert!(arcs(&program).is_empty(), "{}: arcs written", cl.name);
        let rounding = backsim::rounding(&written.text) + 0.5e-4 * 3f64.sqrt();
        let motions = backsim::cl_motions(&program, &written.text, &cl, rounding);
        let ours = feed_path_length(&motions);
        let relative = (ours - cl.length) / cl.length;
        let far = backsim::farthest_point(&cl.points, &motions, tolerance + rounding).expect("points");
        report(&format!(
            "{} --arcs linear: {} feed motions, feed path {ours:.3} mm against {:.3} ({:+.4} %), {:.4} mm off at most",
            cl.name,
            motions.iter().filter(|m| m.is_feed()).count(),
            cl.length,
            relative * 100.0,
            far.distance
        ));
        assert!(relative.abs() < 1e-3, "{}: {ours} against {}", cl.name, cl.length);
        assert!(far.distance <= tolerance + rounding, "{}: {far:?}", cl.name);
    }
}
