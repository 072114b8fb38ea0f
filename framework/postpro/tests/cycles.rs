//! Canned cycles validated by back-simulation: every real CL file with drilling cycles of PTC
//! Creo, SOLIDWORKS CAM and CAMWorks, written by the real `postpro` in each dialect, drills each
//! hole of the CL file to its depth, and never moves sideways below the hole tops.
//!
//! - LinuxCNC: `rs274` runs the program (it expands G81/G83 into its moves), natively and with
//!   `--cycles expand`;
//! - Fanuc and Heidenhain: the harness's readers (`tests::golden`, which read the NX post's and
//!   clsplit's programs) expand G81/G83 and `CYCL DEF 200/203` into their moves;
//! - Siemens 840D: nc-gcode-interpreter reads the program (it does not expand `MCALL CYCLE8x`):
//!   the holes are where it puts the tool on each line after the `MCALL`, and the cycle's own
//!   parameters (RTP, RFP, SDIS, DP) are the CL file's.
//!
//! A hole is expected at the CL file's hole point (its top), in the program's frame: the CL point
//! itself on the 3-axis VMC, the solved position (`postpro solve --csv`) on a table machine, whose
//! spindle stays along Z; its bottom is the top minus the cycle's depth along Z, its R plane the
//! top plus the cycle's clearance. `--nocapture` prints what each program drilled.

mod common;

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use common::backsim::{self, Cl};
use postpro_cl::{CamSystem, ItemKind, ReadOptions};
use tests::golden::{fanuc, heidenhain};
use tests::nc::{EventKind, Motion, Program, Units};

/// Every real CL file of Creo, SOLIDWORKS CAM and CAMWorks with canned cycles (under
/// `../shared/data`), and a machine it runs on: the 3-axis VMC for 3-axis files; for 3+2 files a
/// table machine that reaches their set-ups (a tilt of 0.29° about Y, a part turned over, a side
/// face: B about Y and C about Z; CAMWorks's `ROTABL` about A).
const CASES: &[(&str, &str)] = &[
    ("cl/MichaHofft__CreoPost__bohren_1.ncl.8", "example-3axis-vmc"),
    ("cl/aamorim1913__AptPostProcessor__Interface-glue.clt", "example-4axis-a-table"),
    ("cl/aamorim1913__AptPostProcessor__manufacture3-top.apt", "example-3axis-vmc"),
    ("cl/aamorim1913__AptPostProcessor__shimemcunha.apt", "haas-umc750"),
    (
        "peers/aamorim1913__AptPostProcessor/parts-2021/Sacrifice-Board/input/Sacrifice-Board.apt",
        "example-4axis-a-table",
    ),
    ("peers/aamorim1913__AptPostProcessor/parts-2021/basemach/input/basemach.apt", "example-3axis-vmc"),
    ("peers/aamorim1913__AptPostProcessor/parts-2022/Dem-target1/input/Dem-target1.apt", "example-3axis-vmc"),
    ("peers/aamorim1913__AptPostProcessor/parts-2022/Dem-target2/input/Dem-target2.apt", "example-3axis-vmc"),
    ("peers/aamorim1913__AptPostProcessor/parts-2022/Interface-glue/input/Interface-glue.apt", "example-3axis-vmc"),
    ("peers/aamorim1913__AptPostProcessor/parts-2022/SupPetriLED/input/SupPetriLED.apt", "example-3axis-vmc"),
    ("peers/aamorim1913__AptPostProcessor/parts-2022/Top-light-cover/input/Top-light-cover.apt", "example-3axis-vmc"),
    ("peers/aamorim1913__AptPostProcessor/parts-2022/shimemcunha/input/shimemcunha.apt", "haas-umc750"),
    ("peers/aamorim1913__AptPostProcessor/parts-2023/Teflon-gasket/input/Teflon-gasket.apt", "example-3axis-vmc"),
    ("peers/aamorim1913__AptPostProcessor/parts-tools/wall-holes/input/wall-holes.apt", "haas-umc750"),
];

/// How far a hole may be from where it is expected, mm: both sides rounded to three decimals
/// of a millimetre (or four of an inch), the solved positions to four.
const TOLERANCE: f64 = 0.003;

fn data() -> PathBuf {
    tests::shared_cl_dir().parent().map(Path::to_path_buf).unwrap_or_default()
}

/// The figures, shown with `--nocapture`.
fn report(text: &str) {
    eprintln!("{text}");
}

/// A hole as a program must drill it, in the program's frame (mm).
#[derive(Clone, Copy, Debug)]
struct Hole {
    x: f64,
    y: f64,
    /// The CL file's hole point.
    top: f64,
    bottom: f64,
    r_plane: f64,
    /// The CL lines of the cycle and of the hole's point.
    cycle_line: usize,
    goto_line: usize,
}

/// The holes of a CL file where `machine` must drill them.
fn expected_holes(file: &Path, cl: &Cl, machine: &str) -> Vec<Hole> {
    let solved = (machine != "example-3axis-vmc").then(|| backsim::solved_positions(file, machine));
    cl.holes
        .iter()
        .map(|h| {
            let top = match &solved {
                None => h.top,
                Some(positions) => *positions.get(&h.goto_line).unwrap_or_else(|| {
                    panic!("{}: no solved position of the hole on CL line {}", cl.name, h.goto_line)
                }),
            };
            Hole {
                x: top[0],
                y: top[1],
                top: top[2],
                bottom: top[2] - h.depth,
                r_plane: top[2] + h.clearance,
                cycle_line: h.line,
                goto_line: h.goto_line,
            }
        })
        .collect()
}

fn xy_gap(m: &Motion, x: f64, y: f64) -> f64 {
    (m.to[0] - x).abs().max((m.to[1] - y).abs()).max((m.from[0] - x).abs()).max((m.from[1] - y).abs())
}

fn sideways(m: &Motion) -> f64 {
    (m.to[0] - m.from[0]).abs().max((m.to[1] - m.from[1]).abs())
}

/// The motions (mm) drill every hole, in order: a straight feed motion ends at the hole's X Y and
/// bottom, none of the motions at that X Y between coming down to its R plane and going back up
/// goes deeper, and, from the motion into a cycle's first hole to the one out of its last, every
/// motion that moves sideways is a rapid at or above the cycle's hole tops. Returns the number
/// of holes.
fn drills(motions: &[Motion], holes: &[Hole]) -> Result<usize, String> {
    let mut next = 0;
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (i, h) in holes.iter().enumerate() {
        let at_hole = |m: &Motion| xy_gap(m, h.x, h.y) <= TOLERANCE;
        let reaches =
            |m: &Motion| m.is_feed() && m.arc().is_none() && at_hole(m) && (m.to[2] - h.bottom).abs() <= TOLERANCE;
        let Some(k) = motions[next..].iter().position(reaches).map(|k| next + k) else {
            let deepest = motions[next..]
                .iter()
                .filter(|m| m.is_feed() && at_hole(m))
                .map(|m| m.to[2])
                .fold(f64::INFINITY, f64::min);
            return Err(format!(
                "hole {} (CL line {}) at X{:.3} Y{:.3}, top Z{:.3}: no feed motion reaches its bottom Z{:.3} (the deepest feed there: Z{deepest:.3})",
                i + 1,
                h.goto_line,
                h.x,
                h.y,
                h.top,
                h.bottom
            ));
        };
        // The hole's motions: back to the one coming down from above its R plane, on to the one
        // going back up to it (a hole drilled again by the next tool is another run).
        let mut first = k;
        while first > next && at_hole(&motions[first - 1]) && motions[first].from[2] <= h.r_plane + TOLERANCE {
            first -= 1;
        }
        let mut last = k;
        while last + 1 < motions.len() && at_hole(&motions[last + 1]) && motions[last].to[2] < h.r_plane - TOLERANCE {
            last += 1;
        }
        if let Some(m) = motions[first..=last].iter().find(|m| m.to[2] < h.bottom - TOLERANCE) {
            return Err(format!(
                "hole {} (CL line {}): line {} goes to Z{:.4}, below its bottom Z{:.4}",
                i + 1,
                h.goto_line,
                m.line,
                m.to[2],
                h.bottom
            ));
        }
        runs.push((first, last));
        next = last + 1;
    }
    // Per cycle, from the motion into its first hole to the one out of its last.
    let mut i = 0;
    while i < holes.len() {
        let j = (i..holes.len()).take_while(|&j| holes[j].cycle_line == holes[i].cycle_line).last().unwrap_or(i);
        let tops = holes[i..=j].iter().map(|h| h.top).fold(f64::NEG_INFINITY, f64::max);
        let from = runs[i].0.saturating_sub(1);
        let to = (runs[j].1 + 1).min(motions.len() - 1);
        for m in &motions[from..=to] {
            if sideways(m) <= TOLERANCE {
                continue;
            }
            if m.is_feed() {
                return Err(format!(
                    "line {}: a feed move sideways in the cycle of CL line {} (from {:?} to {:?})",
                    m.line, holes[i].cycle_line, m.from, m.to
                ));
            }
            if m.from[2].min(m.to[2]) < tops - TOLERANCE {
                return Err(format!(
                    "line {}: a rapid sideways at Z{:.4}, below the hole tops (Z{tops:.4}) of the cycle of CL line {}",
                    m.line,
                    m.from[2].min(m.to[2]),
                    holes[i].cycle_line
                ));
            }
        }
        i = j + 1;
    }
    Ok(holes.len())
}

/// The holes a reader expanded (`Hole` events: X, Y, start height, bottom) are the expected
/// ones, with the R plane as their start.
fn hole_events(program: &Program, holes: &[Hole]) -> Result<(), String> {
    let events: Vec<([f64; 3], f64)> = program
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Hole { at, bottom, .. } => Some((*at, *bottom)),
            _ => None,
        })
        .collect();
    if events.len() != holes.len() {
        return Err(format!("{} holes read, {} in the CL file", events.len(), holes.len()));
    }
    for (k, ((at, bottom), h)) in events.iter().zip(holes).enumerate() {
        let off = [at[0] - h.x, at[1] - h.y, at[2] - h.r_plane, bottom - h.bottom].map(f64::abs);
        if off.iter().any(|d| *d > TOLERANCE) {
            return Err(format!(
                "hole {} (CL line {}): read at X{:.4} Y{:.4} from Z{:.4} to Z{:.4}; expected X{:.4} Y{:.4} from the R plane Z{:.4} to Z{:.4}",
                k + 1,
                h.goto_line,
                at[0],
                at[1],
                at[2],
                bottom,
                h.x,
                h.y,
                h.r_plane,
                h.bottom
            ));
        }
    }
    Ok(())
}

/// Our Siemens program read by nc-gcode-interpreter: each hole is a line after an `MCALL
/// CYCLE8x(RTP, RFP, SDIS, DP, …)` that puts the tool over it, and the cycle in force there has
/// the hole's top as RFP, its bottom as DP and its clearance as SDIS (program units).
fn siemens_holes(python: &Path, written: &backsim::Written, holes: &[Hole], axes: &str) -> Result<(), String> {
    let rows = backsim::siemens_rows(python, &written.path, axes)?;
    let lines: Vec<&str> = written.text.lines().collect();
    let scale = if lines.iter().any(|l| l.split_whitespace().any(|w| w == "G700")) { 25.4 } else { 1.0 };
    let mut cycle: Option<Vec<Option<f64>>> = None;
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let code = line.split(';').next().unwrap_or("").trim();
        if let Some(args) =
            code.strip_prefix("MCALL CYCLE8").and_then(|r| r.split_once('(')).map(|(_, a)| a.trim_end_matches(')'))
        {
            cycle = Some(args.split(',').map(|a| a.trim().parse::<f64>().ok().map(|v| v * scale)).collect());
        } else if code == "MCALL" {
            cycle = None;
        } else if let Some(parameters) = &cycle {
            // A line in the modal call: the tool goes over a hole.
            if let Some(&[Some(x), Some(y), ..]) = rows.get(i).map(Vec::as_slice) {
                found.push((i + 1, x * scale, y * scale, parameters.clone()));
            }
        }
    }
    if found.len() != holes.len() {
        return Err(format!("{} holes called, {} in the CL file", found.len(), holes.len()));
    }
    for (k, ((line, x, y, p), h)) in found.iter().zip(holes).enumerate() {
        let [rfp, sdis, dp] = [p.get(1), p.get(2), p.get(3)].map(|v| v.copied().flatten());
        let off = [
            Some(x - h.x),
            Some(y - h.y),
            rfp.map(|v| v - h.top),
            sdis.map(|v| v - (h.r_plane - h.top)),
            dp.map(|v| v - h.bottom),
        ];
        if off.iter().any(|d| d.is_none_or(|d| d.abs() > TOLERANCE)) {
            return Err(format!(
                "line {line}: hole {} (CL line {}) at X{x:.4} Y{y:.4} with RFP {rfp:?}, SDIS {sdis:?}, DP {dp:?}; expected X{:.4} Y{:.4}, RFP {:.4}, SDIS {:.4}, DP {:.4}",
                k + 1,
                h.goto_line,
                h.x,
                h.y,
                h.top,
                h.r_plane - h.top,
                h.bottom
            ));
        }
    }
    Ok(())
}

/// The program with each line that is a CL `INSERT` text as a comment (`(…)` or `; …`).
///
/// The 3+2 set-ups in the work offset's frame (axis values), where the hole axis is the
/// machine's Z: the holes are compared with the solved axis values. The tilted working planes
/// are checked by their own tests.
const JOINTS: &[&str] = &["--plane-mode", "joints"];

/// The linear and rotary axis letters of a machine, for siemens.py.
fn axis_letters(machine: &str) -> String {
    let registry = postpro_machine::Registry::builtin().expect("the built-in machines");
    registry.find(machine).expect("the machine").machine.axes.iter().map(|a| a.letter.to_string()).collect()
}

/// The CASES are every real CL file with cycles of the three CAM systems.
#[test]
fn the_cases_are_every_real_file_with_cycles_of_creo_solidworks_and_camworks() {
    let mut with_cycles = BTreeSet::new();
    for (name, path) in tests::real_cl_files() {
        let text = std::fs::read_to_string(&path).expect("a CL file");
        let tool_path = postpro_cl::read(&postpro_cl::Source::new(name.clone(), text));
        let system = tool_path.info.cam_system;
        let cycles = tool_path.items.iter().any(|i| matches!(i.kind, ItemKind::CycleOn(_)));
        if cycles && matches!(system, Some(CamSystem::Creo | CamSystem::SolidworksCam | CamSystem::CamWorks)) {
            with_cycles.insert(name);
        }
    }
    let cases: BTreeSet<String> = CASES.iter().map(|(f, _)| f.to_string()).collect();
    assert_eq!(cases, with_cycles);
}

/// One case: the CL file as our reader reads it, the machine, the holes as it must drill them.
struct Drilling {
    machine: &'static str,
    path: PathBuf,
    cl: Cl,
    holes: Vec<Hole>,
}

/// Runs `check` on every case; it returns, for each program it checked, how (`LinuxCNC
/// (rs274)`…) and the figures or what is wrong. Prints the figures, fails with every failure.
fn every_case(check: impl Fn(&Drilling) -> Vec<(&'static str, Result<String, String>)>) {
    let mut out = String::new();
    let mut failures = Vec::new();
    for &(file, machine) in CASES {
        let path = data().join(file);
        let cl = backsim::read_cl(&path, &ReadOptions::default());
        let holes = expected_holes(&path, &cl, machine);
        for (how, result) in check(&Drilling { machine, path, cl, holes }) {
            match result {
                Ok(figures) => {
                    let _ = writeln!(out, "{file} on {machine}, {how}: {figures}");
                }
                Err(e) => failures.push(format!("{file} on {machine}, {how}: {e}")),
            }
        }
    }
    report(&out);
    assert!(failures.is_empty(), "{} failure(s):\n{}", failures.len(), failures.join("\n"));
}

/// The LinuxCNC program of each case, with the controller's cycles and with `--cycles expand`,
/// run by rs274, drills every hole of the CL file to its depth, never sideways below the tops.
#[test]
fn linuxcnc_drills_every_hole_to_its_depth_through_rs274() {
    every_case(|case| {
        let mut results = Vec::new();
        for extra in [&[][..], &["--cycles", "expand"][..]] {
            let how = if extra.is_empty() { "LinuxCNC (rs274)" } else { "LinuxCNC --cycles expand (rs274)" };
            let result = backsim::write("cycles", &case.path, case.machine, "linuxcnc", extra).and_then(|w| {
                let Some(ran) = backsim::rs274(&w, &case.cl) else { return Ok("skipped".to_string()) };
                let program = ran?.in_units(Units::Mm);
                let cycles =
                    w.text.lines().filter(|l| l.contains("G81") || l.contains("G83") || l.contains("G73")).count();
                if extra.is_empty() == (cycles == 0) {
                    return Err(format!("{cycles} blocks with G81/G83/G73 in {}", w.path.display()));
                }
                drills(&program.motions, &case.holes).map(|n| format!("{n} holes drilled, {cycles} cycle blocks"))
            });
            results.push((how, result));
        }
        results
    });
}

/// The Fanuc and Heidenhain programs of each case, read by the harness's readers of the NX
/// post's and clsplit's programs (which expand G81/G83 and `CYCL DEF 200/203`), have a hole at
/// each of the CL file's, from its R plane to its bottom, and drill it so.
#[test]
fn fanuc_and_heidenhain_drill_every_hole_to_its_depth() {
    every_case(|case| {
        [("fanuc", fanuc::read as fn(&str, &str) -> _), ("heidenhain", heidenhain::read)]
            .into_iter()
            .map(|(dialect, reader)| {
                let result = backsim::write("cycles", &case.path, case.machine, dialect, JOINTS).and_then(|w| {
                    let program =
                        reader(&w.path.to_string_lossy(), &w.text).map_err(|e| e.to_string())?.in_units(Units::Mm);
                    hole_events(&program, &case.holes)?;
                    drills(&program.motions, &case.holes).map(|n| format!("{n} holes drilled"))
                });
                (dialect, result)
            })
            .collect()
    });
}

/// The Siemens program of each case reads with nc-gcode-interpreter, calls a hole at each of the
/// CL file's, and the `CYCLE8x` in force there has its top, clearance and bottom.
#[test]
fn siemens_calls_every_hole_with_its_depth() {
    let Some(python) = backsim::nc_python() else { return };
    every_case(|case| {
        let result = backsim::write("cycles", &case.path, case.machine, "siemens-840d", JOINTS).and_then(|w| {
            siemens_holes(&python, &w, &case.holes, &axis_letters(case.machine))
                .map(|()| format!("{} holes called", case.holes.len()))
        });
        vec![("Siemens (nc-gcode-interpreter)", result)]
    });
}

/// SOLIDWORKS CAM writes tool descriptions and the stock size with `INSERT`
/// (`INSERT/[HOLDER=C40-32ERP412] 10.0mm JOBBER DRILL`, `INSERT/Stock Size X463.939 Y500 Z6.`).
/// Written as blocks, a controller rejects them (nc-gcode-interpreter: "Parse error" on that line;
/// the Fanuc reader: "expected a word (letter and number), found `[`"), or worse, reads them as
/// words (`X463.939 Y500 Z6.`): by default every dialect writes `INSERT` text as a comment
/// (`--insert verbatim` passes it as is), and says so on stderr.
#[test]
fn insert_text_is_never_a_block_a_controller_cannot_read() {
    let path = data().join("cl/aamorim1913__AptPostProcessor__manufacture3-top.apt");
    let written = backsim::write("cycles", &path, "example-3axis-vmc", "fanuc", &[]).unwrap_or_else(|e| panic!("{e}"));
    fanuc::read(&written.path.to_string_lossy(), &written.text).unwrap_or_else(|e| panic!("{e}"));
    assert!(written.text.contains("(INSERT Stock Size X463.939 Y500 Z6.)"), "{}", written.text);
    assert!(written.stderr.contains("INSERT text(s) written as comments"), "{}", written.stderr);
    let verbatim = backsim::write("cycles", &path, "example-3axis-vmc", "fanuc", &["--insert", "verbatim"])
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(verbatim.text.lines().any(|l| l == "Stock Size X463.939 Y500 Z6."), "{}", verbatim.text);
    if let Some(python) = backsim::nc_python() {
        let written =
            backsim::write("cycles", &path, "example-3axis-vmc", "siemens-840d", &[]).unwrap_or_else(|e| panic!("{e}"));
        backsim::siemens_rows(&python, &written.path, "XYZ").unwrap_or_else(|e| panic!("{e}"));
    }
}
