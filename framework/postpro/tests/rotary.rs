//! Real 5-axis files as a commercial post takes them, and rotary motion that would not startle a
//! machinist (issue 13), against Siemens NX's own Haas UMC-750 post (issue 11's golden test):
//!
//! - NX's CLSFs on `haas-umc750` with `--units inch`: our positions are NX's to 1e-4 in (the
//!   three-axis ones as written, `Variable_Axis` in TCP mode as NX wrote it, G234);
//! - `APT_Variable_Axis.txt` posts with default options, and its B and C are NX's within 0.001°
//!   wherever the tool axis lies outside the singular cone;
//! - every real 5-axis and 3+2 file on every built-in 5-axis machine whose travels hold it, in
//!   the machine's own dialect: every rapid that turns a rotary axis moves no linear axis and
//!   starts at the machine's clearance (a `G53`/`SUPA`/`M91` retract right before it), and no
//!   block turns a rotary axis by more than 180° (unless the travel forbids the shorter way, or
//!   it unwinds at the clearance); no number printed with float noise;
//! - a feed above the machine's `feed_max` is written at it and said once, with its line.

mod programs;

use std::fmt::Write as _;
use std::path::Path;

use postpro_machine::model::{AxisKind, Clearance, Machine, Travel};
use programs::{data_dir, machine, on_two_threads, our_float_noise, out_dir, post, postpro, stderr, tips};
use tests::compare::motions_in_order;
use tests::golden::{self, fanuc};
use tests::nc::{EventKind, Motion, Program, Rotary, Units};

/// A program read with the harness's Fanuc reader.
fn read_fanuc(path: &Path) -> Program {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    fanuc::read(&path.display().to_string(), &text).unwrap_or_else(|e| panic!("{e}"))
}

/// The motions between a program's TCP on and off (its positions are the tool tip's there).
fn under_tcp(p: &Program) -> Vec<Motion> {
    let mut on = None;
    let mut out = Vec::new();
    for e in &p.events {
        match e.kind {
            EventKind::Tcp { on: true } => on = Some(e.before),
            EventKind::Tcp { on: false } => {
                if let Some(start) = on.take() {
                    out.extend_from_slice(&p.motions[start..e.before]);
                }
            }
            _ => {}
        }
    }
    if let Some(start) = on {
        out.extend_from_slice(&p.motions[start..]);
    }
    out
}

/// Golden, inch: the NX Haas post's programs of its own CLSFs and ours on `haas-umc750` with
/// `--units inch` reach the same positions, in the same order, to 1e-4 in (ours may have more
/// between: the clearance moves, linearization). `Variable_Axis` is a G234 (TCP) program: ours in
/// `--mode tcp`, its positions compared (the tool vector is written as I J K there, not B C).
#[test]
fn golden_inch_our_positions_are_the_nx_haas_posts() {
    let dir = out_dir("golden_inch");
    let cases = golden::nx_haas_cases();
    assert_eq!(cases.len(), 5);
    let mut report = String::new();
    for case in &cases {
        let tcp = case.name.contains("Variable_Axis");
        let out = dir.join(format!("{}.nc", case.name.replace('/', "__")));
        let file = case.input.to_str().expect("a UTF-8 path");
        let mut args = vec!["--machine", "haas-umc750", "--units", "inch", "--no-predict"];
        if tcp {
            args.extend_from_slice(&["--mode", "tcp"]);
        }
        post(file, &args, &out).unwrap_or_else(|e| panic!("{e}"));
        let ours = read_fanuc(&out);
        let theirs = read_fanuc(&case.expected[0]);
        assert_eq!((ours.units, theirs.units), (Units::Inch, Units::Inch), "{}", case.name);
        let (ours, theirs) = if tcp {
            // Positions only: NX writes B C on every block, ours the I J K vector.
            let strip = |ms: Vec<Motion>| ms.into_iter().map(|m| Motion { rotary: Rotary::default(), ..m }).collect();
            (strip(under_tcp(&ours)), strip(under_tcp(&theirs)))
        } else {
            (ours.motions, theirs.motions)
        };
        // Both write four decimals: a value half-way between two is rounded either way.
        let c = motions_in_order(&ours, &theirs, 1e-4 + 1e-9, 1e-3);
        assert!(c.is_match(), "{} ({}): {c}", case.name, out.display());
        let _ = writeln!(report, "{}: NX's {} motions are ours, in order, to 1e-4 in", case.name, theirs.len());
    }
    eprintln!("{report}");
}

/// `APT_Variable_Axis.txt` posts on `haas-umc750` with the default policy in G1 (axis values;
/// the table swings near the pole are motion, not errors), and wherever NX's tool axis lies
/// outside the singular cone (B beyond 0.1°) our B and C at the same tool tip are NX's within
/// 0.001°: the same branch and the same winding of C. Our tips are our axis values through the
/// machine's kinematics. (The default mode, TCP, is compared block for block in `golden_nx.rs`.)
#[test]
fn variable_axis_posts_by_default_with_the_b_and_c_of_nx() {
    let case = golden::nx_haas_cases().into_iter().find(|c| c.name.contains("Variable_Axis")).expect("the case");
    let out = out_dir("variable_axis").join("APT_Variable_Axis.nc");
    let posted = post(case.input.to_str().expect("UTF-8"), &["--machine", "haas-umc750", "--mode", "g1"], &out)
        .unwrap_or_else(|e| panic!("{e}"));
    let ours = read_fanuc(&posted.path);
    let theirs = read_fanuc(&case.expected[0]).in_units(Units::Mm);
    let haas = machine("haas-umc750");
    let our_tips = tips(&ours, &haas, postpro_motion::Mode::G1, &[]);
    let cone = haas.policy.singular_cone.to_degrees();
    let mut cursor = 0;
    let (mut compared, mut in_cone, mut worst) = (0, 0, 0.0_f64);
    for m in under_tcp(&theirs) {
        let (Some(b), Some(c)) = (m.rotary.b, m.rotary.c) else { continue };
        let tip = nalgebra::Point3::from(m.to);
        // NX's four decimals in inches, ours through the kinematics: within 0.0003 in.
        let Some(k) = (cursor..our_tips.len()).find(|&k| (our_tips[k].0 - tip).norm() <= 0.0003 * 25.4) else {
            panic!(
                "NX's line {} (tip {:?} B{b} C{c}) is not a tip of ours after motion {cursor} ({})",
                m.line,
                m.to,
                out.display()
            )
        };
        cursor = k;
        if b.abs() <= cone + 1e-3 {
            in_cone += 1;
            continue;
        }
        let (ob, oc) = (ours.motions[k].rotary.b.unwrap_or(f64::NAN), ours.motions[k].rotary.c.unwrap_or(f64::NAN));
        let off = (ob - b).abs().max((oc - c).abs());
        assert!(
            off <= 1e-3 + 1e-9,
            "NX's line {} B{b} C{c}: ours (line {}) B{ob} C{oc} ({})",
            m.line,
            ours.motions[k].line,
            out.display()
        );
        worst = worst.max(off);
        compared += 1;
    }
    eprintln!("{compared} orientations outside the cone equal NX's within {worst:.4}°; {in_cone} inside the cone");
    assert!(compared >= 300, "{compared} orientations compared");
}

// ----- every real 5-axis file on every 5-axis machine ---------------------------------------

/// The real files with a tool axis other than +Z (`postpro check`: `5-axis` or `3+2`), each once
/// (the peers' copies of corpus files are the same bytes), with the options they need: Creo's
/// `finition.ncl` says inches over millimetre data.
const FIVE_AXIS: &[(&str, &[&str])] = &[
    ("cl/HumMan__CLSFProcessor__ust_a2.cls", &[]),
    ("cl/aamorim1913__AptPostProcessor__Interface-glue.clt", &[]),
    ("cl/aamorim1913__AptPostProcessor__Teste-Metrologia.apt", &[]),
    ("cl/aamorim1913__AptPostProcessor__shimemcunha.apt", &[]),
    ("cl/liubaishuo-github__peening-post-processor__peening.aptsource", &[]),
    ("cl/userFour__MECH491-postprocessor__APT_Project2.txt", &[]),
    ("cl/userFour__MECH491-postprocessor__APT_code.txt", &[]),
    ("peers/4r19415__5-axis-Rotation-tool-center-point-RTCP-/input/finition.ncl", &["--cl-units", "mm"]),
    ("peers/aamorim1913__AptPostProcessor/parts-2021/Sacrifice-Board/input/Sacrifice-Board.apt", &[]),
    ("peers/aamorim1913__AptPostProcessor/parts-tools/boss/input/boss.apt", &[]),
    ("peers/aamorim1913__AptPostProcessor/parts-tools/wall-holes/input/wall-holes.apt", &[]),
    ("peers/userFour__MECH491-postprocessor/Variable_Axis/input/APT_Variable_Axis.txt", &[]),
];

/// The CATIA lathe program the reader calls 3+2 (its drilling turns the tool): refused by the
/// reader, not a milling file.
const LATHE: &str = "cl/karlo-c277__CATIAV5-Post-Processor-__DEMO3.txt";

/// The built-in machines with two rotary axes.
fn five_axis_machines() -> Vec<Machine> {
    let registry = postpro_machine::Registry::builtin().expect("the built-in machines");
    registry
        .entries()
        .iter()
        .map(|e| e.machine.clone())
        .filter(|m| m.axes.iter().filter(|a| a.kind == AxisKind::Rotary).count() == 2)
        .collect()
}

#[test]
fn the_five_axis_files_are_every_real_file_that_tilts_the_tool() {
    let mut tilted = Vec::new();
    let mut seen: Vec<Vec<u8>> = Vec::new();
    for (name, path) in tests::real_cl_files() {
        if name.starts_with("peers/holdout/") || name == LATHE {
            continue;
        }
        let o = postpro(&["check", "--json", path.to_str().expect("UTF-8")], &data_dir());
        let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{name}: {e}"));
        let bytes = std::fs::read(&path).expect("the file");
        if matches!(json["axes"].as_str(), Some("5-axis" | "3+2")) && !seen.contains(&bytes) {
            seen.push(bytes);
            tilted.push(name);
        }
    }
    let listed: Vec<&str> = FIVE_AXIS.iter().map(|f| f.0).collect();
    assert_eq!(tilted, listed, "the real files that tilt the tool, once each");
}

/// A block of a program as a controller reads it: how it moves, the axis words it gives, and
/// whether it is a move in machine coordinates.
#[derive(Clone, Debug)]
struct TextBlock {
    line: usize,
    kind: Kind,
    words: Vec<(char, f64)>,
    machine_frame: bool,
    text: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Rapid,
    Feed,
    Cycle,
}

/// The motion blocks of a program in a G-code dialect (Fanuc, Siemens, LinuxCNC: modal G0–G3,
/// `G53`/`SUPA` in machine coordinates, cycles) or Heidenhain's (`L … FMAX` rapids, `L … F`
/// feeds, `C`/`CP` arcs, `M91` in machine coordinates, `CYCL CALL`/`M99` cycles). Lines that are not
/// blocks (text a CL `INSERT` passed on, comments) are left out.
fn motion_blocks(text: &str, heidenhain: bool) -> Vec<TextBlock> {
    let mut out = Vec::new();
    let mut modal = None;
    for (i, raw) in text.lines().enumerate() {
        let mut code = raw;
        if heidenhain {
            code = code.split_once(' ').filter(|(n, _)| n.parse::<u32>().is_ok()).map_or(code, |(_, r)| r);
        }
        let code = code.split(';').next().unwrap_or("");
        let code: String = if heidenhain {
            code.to_string()
        } else {
            let mut s = String::new();
            let mut depth = 0;
            for c in code.chars() {
                match c {
                    '(' => depth += 1,
                    ')' => depth -= 1,
                    c if depth == 0 => s.push(c),
                    _ => {}
                }
            }
            s
        };
        let mut tokens: Vec<&str> = code.split_whitespace().collect();
        if tokens.first().is_some_and(|t| t.starts_with('N') && t[1..].parse::<u32>().is_ok()) {
            tokens.remove(0);
        }
        let Some(&first) = tokens.first() else { continue };
        let word = |t: &str| -> Option<(char, f64)> {
            let mut chars = t.chars();
            let letter = chars.next()?;
            let v = chars.as_str().trim_start_matches('=');
            ("XYZABC".contains(letter) && !v.is_empty()).then(|| v.parse().ok().map(|v| (letter, v))).flatten()
        };
        let words: Vec<(char, f64)> = tokens.iter().filter_map(|t| word(t)).collect();
        let machine_frame = tokens.iter().any(|t| matches!(*t, "G53" | "SUPA" | "M91"));
        let line = i + 1;
        let text = raw.to_string();
        if heidenhain {
            // A cycle moves where it is called (`CYCL DEF` only defines it, or sets a datum).
            let kind = match first {
                "CYCL" if tokens.get(1) == Some(&"CALL") => Some(Kind::Cycle),
                _ if tokens.contains(&"M99") => Some(Kind::Cycle),
                "L" if !words.is_empty() => Some(if tokens.contains(&"FMAX") { Kind::Rapid } else { Kind::Feed }),
                "C" | "CP" => Some(Kind::Feed),
                _ => None,
            };
            if let Some(kind) = kind {
                out.push(TextBlock { line, kind, words, machine_frame, text });
            }
            continue;
        }
        // A block starts with a G word or an axis word (a Siemens MCALL position); anything else
        // (`T1 M6`, `S8000 M3`, text of a CL INSERT) moves nothing here.
        let g = |t: &str| t.strip_prefix('G').is_some_and(|n| n.parse::<f64>().is_ok());
        if !(g(first) || word(first).is_some() || first == "MCALL") {
            continue;
        }
        let mut cycle = tokens.iter().any(|t| t.starts_with("CYCLE") || *t == "MCALL" && tokens.len() > 1);
        for t in tokens.iter().filter(|t| g(t)) {
            match *t {
                "G0" | "G00" => modal = Some(Kind::Rapid),
                "G1" | "G01" | "G2" | "G02" | "G3" | "G03" => modal = Some(Kind::Feed),
                "G73" | "G81" | "G82" | "G83" | "G84" | "G85" | "G86" | "G89" => cycle = true,
                _ => {}
            }
        }
        let kind = if cycle { Some(Kind::Cycle) } else { modal.filter(|_| !words.is_empty()) };
        if let Some(kind) = kind {
            out.push(TextBlock { line, kind, words, machine_frame, text });
        }
    }
    out
}

/// What a program's rotary motion breaks of the rules, each as `line: what`; and the number of
/// rotary rapids checked. `clearance` is the machine's safe height in program units.
fn rotary_faults(
    blocks: &[TextBlock],
    machine: &Machine,
    clearance: Option<f64>,
    decimals: f64,
) -> (Vec<String>, usize) {
    let travel = |letter: char| {
        machine.axes.iter().find(|a| a.letter.starts_with(letter)).map_or((f64::NEG_INFINITY, f64::INFINITY), |a| {
            match a.travel {
                Travel::Limited { min, max } => (min.to_degrees(), max.to_degrees()),
                Travel::Endless => (f64::NEG_INFINITY, f64::INFINITY),
            }
        })
    };
    let mut at: Vec<(char, f64)> = Vec::new();
    let get = |at: &[(char, f64)], l: char| at.iter().find(|(c, _)| *c == l).map(|w| w.1);
    let mut faults = Vec::new();
    let mut checked = 0;
    let mut before: Option<&TextBlock> = None;
    for b in blocks {
        if b.kind == Kind::Cycle {
            before = Some(b);
            continue;
        }
        let changed = |l: char, v: f64| get(&at, l).is_none_or(|p| (p - v).abs() > 1e-9);
        let rotary: Vec<(char, f64)> =
            b.words.iter().copied().filter(|(l, v)| "ABC".contains(*l) && changed(*l, *v)).collect();
        let linear: Vec<char> =
            b.words.iter().filter(|(l, v)| "XYZ".contains(*l) && changed(*l, *v)).map(|w| w.0).collect();
        // After a retract to the machine's clearance in machine coordinates.
        let at_clearance = before.is_some_and(|p| {
            p.machine_frame
                && clearance.is_none_or(|z| p.words.iter().any(|(l, v)| *l == 'Z' && (v - z).abs() <= decimals))
        });
        if !rotary.is_empty() && b.kind == Kind::Rapid && !b.machine_frame {
            checked += 1;
            if !linear.is_empty() {
                faults.push(format!("{}: a rapid turning {rotary:?} moves {linear:?}: {}", b.line, b.text));
            }
            if !at_clearance {
                let after = before.map_or("the start".to_string(), |p| format!("line {} `{}`", p.line, p.text));
                faults.push(format!(
                    "{}: a rapid turning {rotary:?} not from the clearance (after {after}): {}",
                    b.line, b.text
                ));
            }
        }
        for &(l, v) in &rotary {
            let Some(from) = get(&at, l) else { continue };
            let turn = v - from;
            if turn.abs() <= 180.0 + 1e-9 {
                continue;
            }
            // The shorter way to the same angle, when the travel allows it.
            let shorter = from + (turn - 360.0 * (turn / 360.0).round());
            let (lo, hi) = travel(l);
            let forced = shorter < lo - 1e-9 || shorter > hi + 1e-9;
            let unwinding = b.kind == Kind::Rapid && at_clearance && linear.is_empty() && v.abs() < from.abs();
            if !forced && !unwinding {
                faults.push(format!(
                    "{}: {l} turns {turn:.3}° ({from} → {v}) where {:.3}° would do: {}",
                    b.line,
                    shorter - from,
                    b.text
                ));
            }
        }
        if b.machine_frame {
            at.retain(|(l, _)| !"XYZ".contains(*l) || !b.words.iter().any(|w| w.0 == *l));
        } else {
            for &(l, v) in &b.words {
                at.retain(|w| w.0 != l);
                at.push((l, v));
            }
        }
        before = Some(b);
    }
    (faults, checked)
}

/// Every real 5-axis and 3+2 file on every built-in 5-axis machine, in the machine's own dialect
/// (the prediction left out: it adds comments, not blocks): where the travels hold it, every
/// rapid that turns a rotary axis moves no linear axis and comes right after a retract to the
/// machine's clearance in machine coordinates, no block turns a rotary axis more than 180° but
/// where the travel forbids the shorter way or the table unwinds at the clearance, and no
/// number has float noise. Which machines hold which files is pinned.
#[test]
fn every_real_five_axis_file_turns_its_rotary_axes_only_at_the_clearance() {
    let dir = out_dir("rotary");
    let machines = five_axis_machines();
    assert!(machines.len() >= 8, "{:?}", machines.iter().map(|m| &m.name).collect::<Vec<_>>());
    let runs: Vec<(&(&str, &[&str]), &Machine)> =
        FIVE_AXIS.iter().flat_map(|f| machines.iter().map(move |m| (f, m))).collect();
    let outcomes = on_two_threads(&runs, |&(&(file, args), m)| {
        let name = Path::new(file).file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let dialect = postpro_emit::dialect(&m.dialect).expect("a dialect");
        let out = dir.join(format!("{name}.{}.{}", m.name, dialect.extension));
        let mut all = vec!["--machine", m.name.as_str(), "--no-predict"];
        all.extend_from_slice(args);
        match post(file, &all, &out) {
            Err(e) => {
                let first = e.lines().find(|l| l.trim_start().starts_with('×')).unwrap_or("").trim().to_string();
                (format!("{name} on {}: refused: {first}", m.name), Vec::new())
            }
            Ok(posted) => {
                let blocks = motion_blocks(&posted.text, dialect.name == "heidenhain");
                let inch = posted.text.lines().take(60).any(|l| l.contains("units inch") || l.contains(" INCH"));
                let unit = if inch { 25.4 } else { 1.0 };
                let clearance = match m.clearance {
                    Clearance::SafeZ(z) => Some(z / unit),
                    Clearance::Retract(_) => None,
                };
                let decimals = if inch { 0.5e-4 } else { 0.5e-3 };
                let (mut faults, checked) = rotary_faults(&blocks, m, clearance, decimals + 1e-9);
                let cl =
                    String::from_utf8_lossy(&std::fs::read(data_dir().join(file)).expect("the CL file")).into_owned();
                faults.extend(our_float_noise(&posted.text, &cl).into_iter().map(|n| format!("float noise at {n}")));
                faults.iter_mut().for_each(|f| *f = format!("{}:{f}", out.display()));
                (format!("{name} on {}: posted, {checked} rotary rapids at the clearance", m.name), faults)
            }
        }
    });
    let matrix: Vec<&str> = outcomes.iter().map(|o| o.0.as_str()).collect();
    let faults: Vec<&String> = outcomes.iter().flat_map(|o| &o.1).collect();
    assert!(
        faults.is_empty(),
        "{} fault(s):\n{}",
        faults.len(),
        faults.iter().take(40).map(|s| s.as_str()).collect::<Vec<_>>().join("\n")
    );
    insta::assert_snapshot!(matrix.join("\n"));
}

/// The rules of `rotary_faults` catch what they are about: a rotary rapid with a linear axis, one
/// not at the clearance, and a turn the long way round.
#[test]
fn the_rotary_rules_catch_their_faults() {
    let maho = machine("maho600e");
    let program = "G53 G0 Z500.000\nG0 B10.000 C0.000\nG0 X1.000 Y2.000\nG1 Z-5.000 F100.\nG0 C30.000\nG53 G0 Z500.000\nG0 B20.000 Z3.000\nG53 G0 Z500.000\nG0 C-200.000\nG1 C100.000\n";
    let (faults, checked) = rotary_faults(&motion_blocks(program, false), &maho, Some(500.0), 0.0005);
    assert_eq!(checked, 4);
    assert_eq!(faults.len(), 4, "{faults:#?}");
    assert!(faults[0].starts_with("5: a rapid turning [('C', 30.0)] not from the clearance"), "{faults:#?}");
    assert!(faults[1].starts_with("7: a rapid turning [('B', 20.0)] moves ['Z']"), "{faults:#?}");
    assert!(faults[2].starts_with("9: C turns -230.000° (30 → -200) where 130.000° would do"), "{faults:#?}");
    assert!(faults[3].starts_with("10: C turns 300.000°"), "{faults:#?}");
}

/// A programmed feed above the machine's `feed_max` is written at `feed_max` and said once on
/// standard error with the CL line, however many moves use it; one below `feed_min` likewise.
#[test]
fn a_feed_beyond_the_machines_range_is_clamped_and_said_once() {
    let dir = out_dir("feed_range");
    let cl = "UNITS/MM\nLOADTL/1\nSPINDL/RPM,6000,CLW\nCOOLNT/FLOOD\nRAPID\nGOTO/0,0,10\nFEDRAT/MMPM,20000\nGOTO/0,0,0\nGOTO/50,0,0\nGOTO/50,50,0\nFEDRAT/MMPM,0.5\nGOTO/50,50,-1\nFEDRAT/MMPM,20000\nGOTO/0,50,0\nRAPID\nGOTO/0,50,10\nFINI\n";
    std::fs::write(dir.join("fast.cl"), cl).expect("the CL file");
    let o = postpro(&["--machine", "maho600e", "fast.cl", "-o", "fast.nc", "--no-predict"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let said = stderr(&o);
    let fast: Vec<&str> = said.lines().filter(|l| l.contains("feed 20000 mm/min")).collect();
    assert_eq!(
        fast,
        ["warning: fast.cl:8:1: feed 20000 mm/min limited to 10000 mm/min (the machine's range 1…10000 mm/min)"],
        "{said}"
    );
    let slow: Vec<&str> = said.lines().filter(|l| l.contains("feed 0.5 mm/min")).collect();
    assert_eq!(
        slow,
        ["warning: fast.cl:12:1: feed 0.5 mm/min limited to 1 mm/min (the machine's range 1…10000 mm/min)"],
        "{said}"
    );
    let program = std::fs::read_to_string(dir.join("fast.nc")).expect("the program");
    let feeds: Vec<f64> = program
        .lines()
        .flat_map(|l| {
            l.split('(')
                .next()
                .unwrap_or("")
                .split_whitespace()
                .filter_map(|w| w.strip_prefix('F')?.parse().ok())
                .collect::<Vec<f64>>()
        })
        .collect();
    assert!(feeds.iter().all(|f| (1.0..=10000.0).contains(f)), "{feeds:?}");
    assert!(feeds.contains(&10000.0) && feeds.contains(&1.0), "{feeds:?}");
}

/// The start of the CL files the tests of small rotary turns write: a tool, the spindle, the
/// coolant, five-axis moves.
const START: &str = "UNITS/MM\nLOADTL/1\nSPINDL/RPM,6000,CLW\nCOOLNT/FLOOD\nMULTAX\n";

/// A tool axis in the XZ plane with `i` its x component, to seven decimals as CAM systems write.
fn axis_xz(i: f64) -> String {
    format!("{i:.7},0.0000000,{:.7}", (1.0 - i * i).sqrt())
}

/// Appends a cut of 3000 moves 0.01 mm apart along X whose tool axis turns by 2e-7 a move (0.03°
/// over the cut): from above its start, at feed, to above its end.
fn drifting_cut(cl: &mut String) {
    let drift = |k: usize| axis_xz(0.3 + 2e-7 * k as f64);
    writeln!(cl, "RAPID\nGOTO/0.0000,0.0000,20.0000,{}\nFEDRAT/MMPM,1000", drift(0)).expect("a string");
    for k in 0..3000 {
        writeln!(cl, "GOTO/{:.4},0.0000,0.0000,{}", 0.01 * k as f64, drift(k)).expect("a string");
    }
    cl.push_str("RAPID\nGOTO/29.9900,0.0000,20.0000\n");
}

/// The bundled 3+2 example (the hyperbolic paraboloid).
fn example_3plus2() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/cl/hypar-3plus2.cl")
}

/// A CAM system writes tool axes to seven decimals, and two of one 3+2 set-up may differ in the
/// last (1e-7 rad): no re-orientation. The hyperbolic paraboloid in 3+2 with such noise in every
/// tool axis posts as with the exact axes, on the three built-in machines: the same program but
/// for its name (no retract to the clearance between moves of one set-up, no working plane for a
/// turn below what the rotaries are written to, the same predicted time, the Haas's brakes locked
/// through each set-up as with the exact axes).
#[test]
fn tool_axes_that_differ_in_their_last_decimal_are_one_orientation() {
    let dir = out_dir("axis_noise");
    let exact = std::fs::read_to_string(example_3plus2()).expect("the example");
    let mut noisy = String::new();
    let mut changed = 0;
    for (k, line) in exact.lines().enumerate() {
        let values: Option<Vec<f64>> = line
            .strip_prefix("GOTO/")
            .map(|args| args.split(',').map(|v| v.trim().parse().expect("a number")).collect());
        match values {
            Some(v) if v.len() == 6 => {
                // ±1e-7 on i and j by turns, renormalized, written to seven decimals as CAM does.
                let nudge = [1e-7, -1e-7, 0.0][k % 3];
                let (i, j, kk) = (v[3] + nudge, v[4] - nudge, v[5]);
                let n = (i * i + j * j + kk * kk).sqrt();
                let noisy_line =
                    format!("GOTO/{:.4},{:.4},{:.4},{:.7},{:.7},{:.7}", v[0], v[1], v[2], i / n, j / n, kk / n);
                changed += usize::from(noisy_line != line);
                writeln!(noisy, "{noisy_line}").expect("a string");
            }
            _ => writeln!(noisy, "{line}").expect("a string"),
        }
    }
    assert!(changed > 100, "the noise reaches the tool axes: {changed} lines");
    std::fs::write(dir.join("exact.cl"), &exact).expect("the exact file");
    std::fs::write(dir.join("noisy.cl"), &noisy).expect("the noisy file");
    for machine in ["mikron", "maho600e", "haas-umc750"] {
        // Each program's lines but those that name its file (the header's).
        let [exact, noisy] = ["exact", "noisy"].map(|name| {
            let o = postpro(&["--machine", machine, &format!("{name}.cl"), "-o", &format!("{name}.nc")], &dir);
            assert_eq!(o.status.code(), Some(0), "{machine} {name}: {}", stderr(&o));
            let text = std::fs::read_to_string(dir.join(format!("{name}.nc"))).expect("the program");
            text.lines().filter(|l| !l.to_lowercase().contains(name)).map(str::to_string).collect::<Vec<_>>()
        });
        // The noisy program's lines the exact one has not (each line of it matched once).
        let extra: Vec<&String> = {
            let mut left: Vec<&String> = exact.iter().collect();
            noisy.iter().filter(|l| left.iter().position(|e| e == l).map(|p| left.remove(p)).is_none()).collect()
        };
        assert!(
            extra.is_empty() && noisy.len() == exact.len(),
            "{machine}: the noisy axes' program differs by {extra:?}"
        );
    }
}

/// The other side of the same tolerance: a tool axis that turns a little at every feed move, each
/// turn below what the rotaries are written to but adding up (0.03° over the cut), is simultaneous
/// motion. A program with such a cut after a true 3+2 set-up is a 5-axis program: its work offset
/// on the rotary axes' intersection (the frame simultaneous motion is computed in), no working
/// plane, and the rotary words change along the cut. It fails where the tolerance is taken
/// between consecutive moves only (the program then was the part zero's, with a G68.2 plane).
#[test]
fn a_tool_axis_that_drifts_below_the_resolution_at_each_move_is_simultaneous_motion() {
    let dir = out_dir("axis_drift");
    let mut cl = String::from(START);
    // A 3+2 set-up: the tool tilted 30°, standing.
    writeln!(cl, "RAPID\nGOTO/0.0000,10.0000,20.0000,{}\nFEDRAT/MMPM,1000", axis_xz(0.5)).expect("a string");
    for x in 0..20 {
        writeln!(cl, "GOTO/{x}.0000,10.0000,0.0000,{}", axis_xz(0.5)).expect("a string");
    }
    writeln!(cl, "RAPID\nGOTO/19.0000,10.0000,20.0000,{}", axis_xz(0.5)).expect("a string");
    drifting_cut(&mut cl);
    cl.push_str("FINI\n");
    std::fs::write(dir.join("drift.cl"), &cl).expect("the CL file");
    for (machine, rotary) in [("maho600e", 'B'), ("mikron", 'A')] {
        let o = postpro(&["--machine", machine, "drift.cl", "-o", "drift.nc", "--no-predict"], &dir);
        assert_eq!(o.status.code(), Some(0), "{machine}: {}", stderr(&o));
        let program = std::fs::read_to_string(dir.join("drift.nc")).expect("the program");
        let offset = program.lines().find(|l| l.contains("work offset")).unwrap_or_default();
        assert!(offset.contains("intersection"), "{machine}: {offset}");
        assert!(!program.contains("G68.2") && !program.contains("CYCLE800"), "{machine}: a working plane");
        let rotary_words: std::collections::BTreeSet<&str> = program
            .lines()
            .filter(|l| l.starts_with("G1") || l.contains(" G1 "))
            .flat_map(|l| l.split_whitespace().filter(|w| w.starts_with(rotary)))
            .collect();
        assert!(rotary_words.len() >= 10, "{machine}: the rotary words of the cuts: {rotary_words:?}");
    }
}

/// On the Haas (brakes on B and C: M13/M12, M11/M10), no block writes a rotary value other than
/// the last one written while that axis's brake is locked: a turn below the rotaries' resolution
/// keeps the brake locked only where the written value stays. Checked on a drifting cut (B
/// written anew along it), the 3+2 example (one set-up on this machine), and a set-up whose last
/// moves turn B across a rounding boundary of its written value.
#[test]
fn a_locked_rotary_is_never_written_to_another_value() {
    let dir = out_dir("brakes");
    let mut cl = String::from(START);
    drifting_cut(&mut cl);
    cl.push_str("FINI\n");
    std::fs::write(dir.join("drift.cl"), &cl).expect("the CL file");
    std::fs::copy(example_3plus2(), dir.join("exact.cl")).expect("the example");
    // A set-up at B 30.0004999° (written B30.000, the brake locked) whose last moves turn 2e-7° to
    // 30.0005001°: one set-up, but written B30.001 (the brake released first).
    let tilted = |degrees: f64| {
        let (s, c) = degrees.to_radians().sin_cos();
        format!("{s:.12},0.000000000000,{c:.12}")
    };
    let mut cl = String::from(START);
    writeln!(cl, "RAPID\nGOTO/0.0000,0.0000,20.0000,{}\nFEDRAT/MMPM,1000", tilted(30.0004999)).expect("a string");
    for x in 0..7 {
        let degrees = if x < 5 { 30.0004999 } else { 30.0005001 };
        writeln!(cl, "GOTO/{x}.0000,0.0000,0.0000,{}", tilted(degrees)).expect("a string");
    }
    cl.push_str("RAPID\nGOTO/6.0000,0.0000,20.0000\nFINI\n");
    std::fs::write(dir.join("straddle.cl"), &cl).expect("the CL file");
    let cases: [(&str, &[&str], usize); 3] =
        [("drift", &[], 10), ("exact", &[], 0), ("straddle", &["--plane-mode", "joints"], 1)];
    for (name, options, least) in cases {
        let (cl, nc) = (format!("{name}.cl"), format!("{name}.nc"));
        let mut args = vec!["--machine", "haas-umc750", &cl, "-o", &nc];
        args.extend_from_slice(options);
        let o = postpro(&args, &dir);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        let program = std::fs::read_to_string(dir.join(format!("{name}.nc"))).expect("the program");
        // Per axis: its letter, its brake's codes, locked or not, the last value written.
        let mut axes = [("B", "M12", "M13", false, None::<String>), ("C", "M10", "M11", false, None)];
        let mut turns = 0;
        for (n, line) in program.lines().enumerate() {
            let code = line.split('(').next().unwrap_or_default();
            for word in code.split_whitespace() {
                for (letter, lock, unlock, locked, last) in &mut axes {
                    if word == *lock {
                        *locked = true;
                    } else if word == *unlock {
                        *locked = false;
                    } else if let Some(value) = word.strip_prefix(*letter) {
                        if last.as_deref().is_some_and(|l| l != value) {
                            assert!(!*locked, "{name}:{}: {letter} turns with its brake locked: {line}", n + 1);
                            turns += 1;
                        }
                        *last = Some(value.to_string());
                    }
                }
            }
        }
        assert!(turns >= least, "{name}: {turns} turns written, {least} at least");
    }
}
