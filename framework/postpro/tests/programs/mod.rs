//! What the tests of whole programs share (`real_files.rs`, `rotary.rs`, `setup.rs`): running
//! `postpro` on a CL file, the tools a program's header lists (for rs274's tool table), numbers
//! printed with float noise, the CL file's points, and the tool tips a back-simulated program
//! reaches (the machine's forward kinematics on the axis values rs274 reports).

#![allow(dead_code)] // each test binary uses its part

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use nalgebra::{Point3, Unit, Vector3};
use postpro_cl::{ItemKind, Motion as ClMotion, MoveKind, ReadOptions, Source};
use postpro_kin::{Joints, Kinematics, ToolLength};
use postpro_machine::model::{AxisKind, Machine};
use tests::nc::{EventKind, Program, Units};

/// `../shared/data`, where the real CL files and the peers' programs live.
pub(crate) fn data_dir() -> PathBuf {
    tests::shared_cl_dir().parent().map_or_else(|| PathBuf::from("../shared/data"), Path::to_path_buf)
}

/// A fresh folder `name` under the test's target folder (kept after the test for a look).
pub(crate) fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("the test's output folder");
    dir
}

/// Runs `postpro` with `args` in `dir`.
pub(crate) fn postpro(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postpro"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("postpro runs")
}

/// Standard error as text.
pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A program `postpro` wrote.
pub(crate) struct Posted {
    /// Where.
    pub(crate) path: PathBuf,
    /// Its text.
    pub(crate) text: String,
    /// What `postpro` said on standard error.
    pub(crate) stderr: String,
}

/// Posts `file` (a path relative to `../shared/data`, or absolute) with `args` to `out`, from
/// `../shared/data` (so that the messages name the file as given); the error is `postpro`'s
/// standard error.
pub(crate) fn post(file: &str, args: &[&str], out: &Path) -> Result<Posted, String> {
    let out_text = out.to_str().expect("a UTF-8 path");
    let mut all: Vec<&str> = vec![file, "-o", out_text];
    all.extend_from_slice(args);
    let o = postpro(&all, &data_dir());
    let said = stderr(&o);
    if o.status.code() != Some(0) {
        return Err(format!("postpro {} failed ({}):\n{said}", all.join(" "), o.status));
    }
    let text = std::fs::read_to_string(out).map_err(|e| format!("{out_text}: {e}"))?;
    Ok(Posted { path: out.to_path_buf(), text, stderr: said })
}

/// A tool as a program's header lists it (`(T1 H1 MILL D1.1811 R0 L2.9528)` in the Fanuc and
/// LinuxCNC templates), in program units.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct HeaderTool {
    /// `T`.
    pub(crate) number: u32,
    /// `H`: the length register.
    pub(crate) register: u32,
    /// `D`: the diameter, when known.
    pub(crate) diameter: Option<f64>,
    /// `L`: the length, when known.
    pub(crate) length: Option<f64>,
}

/// The tools a Fanuc or LinuxCNC program's header lists: the comment lines before the first
/// block that start with `T<number> H<register>`; the diameter, corner radius and length are the
/// last words (`D…`, `R…`, `L…`, each optional, in that order), the name what lies between.
pub(crate) fn header_tools(text: &str) -> Vec<HeaderTool> {
    let mut tools = Vec::new();
    for line in text.lines() {
        let Some(inner) = line.strip_prefix('(').and_then(|l| l.strip_suffix(')')) else {
            if line.starts_with('%') || line.starts_with('O') {
                continue;
            }
            break;
        };
        let words: Vec<&str> = inner.split_whitespace().collect();
        let value = |w: &str, letter: char| w.strip_prefix(letter).and_then(|v| v.parse::<f64>().ok());
        let (Some(number), Some(register)) = (
            words.first().and_then(|w| value(w, 'T')).filter(|v| v.fract() == 0.0),
            words.get(1).and_then(|w| value(w, 'H')).filter(|v| v.fract() == 0.0),
        ) else {
            continue;
        };
        let mut rest = &words[2..];
        let mut last = |letter: char| -> Option<f64> {
            let v = rest.last().and_then(|w| value(w, letter))?;
            rest = &rest[..rest.len() - 1];
            Some(v)
        };
        let length = last('L');
        let _corner = last('R');
        let diameter = last('D');
        tools.push(HeaderTool { number: number as u32, register: register as u32, diameter, length });
    }
    tools
}

/// rs274's tool table for `tools` (in `units`): each tool under its number, and under its length
/// register when that is another number (G43 H takes the entry of that number), with its
/// length and diameter in mm (100 mm and 10 mm where the header gives none).
pub(crate) fn rs274_tools(tools: &[HeaderTool], units: Units) -> Vec<(u32, f64, f64)> {
    let mm = units.to_mm();
    let mut table: Vec<(u32, f64, f64)> = Vec::new();
    for t in tools {
        let entry = (t.length.map_or(100.0, |l| l * mm), t.diameter.map_or(10.0, |d| d * mm));
        for n in [t.number, t.register] {
            if !table.iter().any(|e| e.0 == n) {
                table.push((n, entry.0, entry.1));
            }
        }
    }
    table
}

/// The program's units as its header block says (`G20`/`G70`/`INCH`: inch).
pub(crate) fn program_units(text: &str) -> Units {
    let inch = text.lines().take(80).any(|l| {
        let code = l.split(['(', ';']).next().unwrap_or("");
        code.split_whitespace().any(|w| w == "G20" || w == "G70" || w == "INCH")
    });
    if inch { Units::Inch } else { Units::Mm }
}

/// The numbers of `text` printed with float noise (`6.095999999999999`, `0.30000000000000004`):
/// a run of five nines or five zeros in the decimals followed by another digit, what the regex
/// `\d\.\d*(99999|00000)\d` finds. Each as `line: number`.
pub(crate) fn float_noise(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let bytes = line.as_bytes();
        let mut k = 0;
        while k < bytes.len() {
            if !bytes[k].is_ascii_digit() {
                k += 1;
                continue;
            }
            let start = k;
            while k < bytes.len() && (bytes[k].is_ascii_digit() || bytes[k] == b'.') {
                k += 1;
            }
            let number = &line[start..k];
            if let Some((whole, decimals)) = number.split_once('.')
                && !whole.is_empty()
                && (noisy(decimals, "99999") || noisy(decimals, "00000"))
            {
                found.push(format!("{}: {number}", i + 1));
            }
        }
    }
    found
}

/// `run` in `decimals` with a digit after it.
fn noisy(decimals: &str, run: &str) -> bool {
    decimals.match_indices(run).any(|(at, _)| decimals[at + run.len()..].starts_with(|c: char| c.is_ascii_digit()))
}

/// The float noise of a program that is not the CL file's own text: a noisy number that the CL
/// file holds as written (a `PPRINT/PART-LEAST,0.0000001` passed on as a comment) is the CAM
/// system's, not ours.
pub(crate) fn our_float_noise(program: &str, cl_text: &str) -> Vec<String> {
    float_noise(program)
        .into_iter()
        .filter(|found| found.split_once(": ").is_none_or(|(_, number)| !cl_text.contains(number)))
        .collect()
}

/// A point of the CL file the tool tip must reach: the end of a feed move, an arc or a NURBS.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ClPoint {
    /// The tip, part frame, mm.
    pub(crate) tip: Point3<f64>,
    /// The tool axis there.
    pub(crate) axis: Unit<Vector3<f64>>,
    /// The CL line.
    pub(crate) line: usize,
}

/// The feed points of the CL file `file` read with `options` (holes left out: the cycle's
/// moves are the controller's).
pub(crate) fn cl_points(file: &Path, options: &ReadOptions) -> Vec<ClPoint> {
    let source = Source::from_path(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let path = postpro_cl::read_with(&source, options);
    assert!(!path.has_errors(), "{} does not read", file.display());
    let line = |span: postpro_cl::Span| source.line_col(span.start as usize).line;
    let mut points = Vec::new();
    for item in &path.items {
        let (tip, axis, motion) = match &item.kind {
            ItemKind::Move(m) if m.kind != MoveKind::Hole && m.kind != MoveKind::From => (m.to, m.axis, m.motion),
            ItemKind::Arc(a) => (a.end, a.axis, a.motion),
            ItemKind::Nurbs(n) => match n.control.last() {
                Some(&end) => (end, n.axis, n.motion),
                None => continue,
            },
            _ => continue,
        };
        if matches!(motion, ClMotion::Feed(_)) {
            points.push(ClPoint { tip, axis, line: line(item.span) });
        }
    }
    points
}

/// A built-in machine.
pub(crate) fn machine(name: &str) -> Machine {
    postpro_machine::Registry::builtin().expect("the built-in machines").find(name).expect("a machine").machine.clone()
}

/// Where the tool tip is at the end of each motion of a back-simulated program: its axis
/// values (mm, degrees, in the work offset's frame) turned into the kinematics' values and
/// through the machine's forward kinematics with the length of the tool loaded then (0 where
/// the controller applies the length: no rotary axis turns the tool). `lengths` are the tools'
/// lengths in mm by number (the header's); a head machine's tool without one has the machine
/// definition's. Returns the tip (mm) and the tool axis per motion.
pub(crate) fn tips(
    program: &Program,
    machine: &Machine,
    mode: postpro_motion::Mode,
    lengths: &[(u32, f64)],
) -> Vec<(Point3<f64>, Unit<Vector3<f64>>)> {
    let program = program.in_units(Units::Mm);
    let kin = postpro_kin::solver_for(machine);
    let frame = postpro_motion::work_frame(kin.as_ref(), mode);
    let head = !machine.chain.tool.is_empty();
    let mut events = program.events.iter().peekable();
    let mut length = 0.0;
    let mut out = Vec::with_capacity(program.motions.len());
    for (k, m) in program.motions.iter().enumerate() {
        while let Some(e) = events.next_if(|e| e.before <= k) {
            if let EventKind::ToolChange { tool } = e.kind {
                length = if head {
                    lengths.iter().find(|(n, _)| *n == tool).map_or(machine.chain.tool_length, |&(_, l)| l)
                } else {
                    0.0
                };
            }
        }
        let written: Vec<f64> = machine
            .axes
            .iter()
            .map(|a| {
                let letter = a.letter.chars().next().unwrap_or('X').to_ascii_uppercase();
                match (a.kind, letter) {
                    (AxisKind::Linear, 'X') => m.to[0],
                    (AxisKind::Linear, 'Y') => m.to[1],
                    (AxisKind::Linear, _) => m.to[2],
                    (_, l) => m.rotary.get(l).unwrap_or(0.0).to_radians(),
                }
            })
            .collect();
        let joints = frame.unapply(&Joints::from_slice(&written));
        let pose = ToolLength::new(kin.as_ref(), length).forward(&joints);
        out.push((pose.tip, pose.axis));
    }
    out
}

/// The tolerances within which the tip reaches a CL point: in position (mm), half a unit of
/// the last decimal written on each linear axis and the rotary axes' half units turning the
/// point about them (lever: its distance from the part zero, the part zero's from the machine
/// origin, and 300 mm for pivots and tool lengths); in the tool axis (degrees), the machine's
/// singular cone (where the free axis is carried the axis may deviate by up to it) and the
/// rotary rounding.
pub(crate) fn tolerances(machine: &postpro_machine::model::Machine, inch: bool) -> (impl Fn(&ClPoint) -> f64, f64) {
    let linear = if inch { 0.5e-4 * 25.4 } else { 0.5e-3 };
    let rotary_deg: f64 = machine
        .axes
        .iter()
        .filter(|a| a.kind == postpro_machine::model::AxisKind::Rotary)
        .map(|a| 0.5 * 10f64.powi(-(a.decimals as i32)))
        .sum();
    let reference = machine.chain.part_origin.translation.vector.norm() + 300.0;
    let tip =
        move |p: &ClPoint| 3f64.sqrt() * linear + (p.tip.coords.norm() + reference) * rotary_deg.to_radians() + 1e-6;
    (tip, machine.policy.singular_cone.to_degrees() + rotary_deg + 1e-6)
}

/// Every CL point is a tip the program reaches, in order (the program may reach more between),
/// within `tolerance(point)` (mm) and `axis_tolerance_deg`: the largest distance and angle found
/// (each point matched with the nearest of the tips in a row that reach it), or the first CL
/// point not reached, with the nearest tip after the last one matched.
pub(crate) fn reached_in_order(
    points: &[ClPoint],
    tips: &[(Point3<f64>, Unit<Vector3<f64>>)],
    tolerance: impl Fn(&ClPoint) -> f64,
    axis_tolerance_deg: f64,
) -> Result<(f64, f64), String> {
    let mut cursor = 0;
    let mut worst: (f64, f64) = (0.0, 0.0);
    for p in points {
        let tol = tolerance(p);
        let off = |k: usize| {
            let (tip, axis) = &tips[k];
            ((tip - p.tip).norm(), axis.angle(&p.axis).to_degrees())
        };
        let reached = |k: usize| {
            let (d, a) = off(k);
            d <= tol && a <= axis_tolerance_deg
        };
        match (cursor..tips.len()).find(|&k| reached(k)) {
            Some(mut k) => {
                // The nearest of the tips in a row that reach it.
                while k + 1 < tips.len() && reached(k + 1) && off(k + 1).0 <= off(k).0 {
                    k += 1;
                }
                cursor = k;
                let (d, a) = off(k);
                worst = (worst.0.max(d), worst.1.max(a));
            }
            None => {
                let nearest = (cursor..tips.len()).map(|k| (k, off(k))).min_by(|a, b| a.1.0.total_cmp(&b.1.0));
                return Err(format!(
                    "CL line {}: the tip {:.4} {:.4} {:.4} (axis {:.5} {:.5} {:.5}) is not reached within {tol:.4} mm \
                     and {axis_tolerance_deg:.4}° after motion {cursor}; nearest: {}",
                    p.line,
                    p.tip.x,
                    p.tip.y,
                    p.tip.z,
                    p.axis.x,
                    p.axis.y,
                    p.axis.z,
                    nearest.map_or("none".to_string(), |(k, (d, a))| format!("motion {k}, {d:.4} mm, {a:.4}°")),
                ));
            }
        }
    }
    Ok(worst)
}

/// `f` on every item on two threads (the CI machine's cores), the results in order.
pub(crate) fn on_two_threads<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<std::sync::Mutex<Option<R>>> = items.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(item) = items.get(k) else { break };
                    let r = f(item);
                    *results[k].lock().expect("a result slot") = Some(r);
                }
            });
        }
    });
    results.into_iter().map(|m| m.into_inner().expect("a result slot").expect("every item done")).collect()
}
