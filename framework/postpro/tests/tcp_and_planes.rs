//! Controller-faithful output (issue 14): every dialect's tool-centre-point (TCP) and tilted
//! working-plane programs put the tool where the CL file says.
//!
//! Each program is read back by a reader of the harness (`tests::golden`: Fanuc/Haas, Heidenhain,
//! and Siemens with nc-gcode-interpreter's positions) and placed in the part frame here, with the
//! machine's forward kinematics (`postpro_kin`) wherever the program gives axis values:
//!
//! - **TCP** (`--mode tcp`; Fanuc `G43.4`/`G43.5`, Haas `G234`, Siemens `TRAORI` with `ORIAXES` or
//!   `ORIVECT`, Heidenhain `M128` with `L` or `LN`): the tip is the written X Y Z (the work offset
//!   is the part zero); the tool axis is the forward kinematics of the written rotary angles, or
//!   the written vector.
//! - **Tilted plane** (`--plane-mode cycle`; Fanuc `G68.2`+`G53.1`, Siemens `CYCLE800`, Heidenhain
//!   `PLANE VECTOR … STAY`): the plane the command defines turns the written coordinates into
//!   the part frame (origin and Euler angles or vectors, as the controller reads them); the
//!   rotary axes' values through the forward kinematics must give the plane's z as the tool
//!   axis, and no rotary axis turns inside the plane. Haas's dynamic work offset (`G254`): the
//!   written coordinates are the part's, the tool axis the kinematics' of the set-up's rotaries.
//! - Outside both (the moves at the clearance, 3+2 set-ups with the rotaries at zero): the axis
//!   values through the forward kinematics, in the work offset's frame (the part zero).
//!
//! Then every CL feed point is reached in order with its tool axis, within the written precision
//! (`programs::reached_in_order`); every CL point and the quarter points of every CL arc lie on
//! the program's path in the part frame (arcs of a tilted plane turned into it), within the
//! linearization tolerance; every CL hole's bottom is reached; and the move across at the
//! clearance, written in axis values before TCP or the plane comes on, puts the tool on the
//! spindle's line through the first position in the new frame (the approach then runs along
//! the spindle).
//!
//! The interpreters CI runs read them too: LinuxCNC's `rs274` every Fanuc and Haas program, each
//! construct it does not have (`G43.4`, `G68.2`, `G234`…) named with its message, pinned, and
//! taken out one after another until the rest reads, whose positions must then be the Fanuc
//! reader's; nc-gcode-interpreter every Siemens program, whose positions the Siemens reader
//! takes (the tool vector words `A3= B3= C3=`, which it has no grammar for, are pinned with its
//! error and taken out of its copy). Heidenhain has no interpreter here: its reader carries the
//! check. LinuxCNC has neither TCP nor working planes: its 3+2 program (axis values) runs in
//! rs274 and reaches the CL points through the kinematics. Without the interpreters their parts
//! are skipped with a line, except under CI.
//!
//! `-- --nocapture` prints what each program measured.

mod common;
mod programs;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Unit, Vector3};
use postpro_cl::{ArcSense, ReadOptions};
use postpro_kin::{Joints, ToolLength};
use postpro_machine::model::{AxisKind, Machine};
use postpro_motion::WorkFrame;

use common::backsim::{self, Written};
use programs::{ClPoint, cl_points, data_dir, header_tools, machine, on_two_threads, reached_in_order, rs274_tools};
use tests::golden::{fanuc, heidenhain, siemens};
use tests::nc::{Event, EventKind, Frame, Motion, MotionKind, Program, Rotary, Units};
use tests::rs274::Rs274;

/// A CL file (relative to the repository, else to `../shared/data`), a built-in 5-axis machine
/// whose travels hold it, and the reading options it needs.
#[derive(Clone, Copy, Debug)]
struct Case {
    file: &'static str,
    machine: &'static str,
    args: &'static [&'static str],
}

const VARIABLE_AXIS: &str = "peers/userFour__MECH491-postprocessor/Variable_Axis/input/APT_Variable_Axis.txt";
const PROJECT2: &str = "cl/userFour__MECH491-postprocessor__APT_Project2.txt";
const FIXTURE: &str = "framework/postpro/tests/planes/compound_tilt.cl";

/// Simultaneous 5-axis files in TCP mode: the bundled examples on the three built-in 5-axis
/// machines (A/C, B/C with the part zero off the table's axes, B/C in inch), NX's
/// `Variable_Axis` on the Haas it was made for, and NX's 15-operation `APT_Project2` (arcs about
/// the tool axis, and a helix in a tilted plane written as points).
const TCP_CASES: &[Case] = &[
    Case { file: "examples/cl/hypar-5axis.cl", machine: "mikron-ucp710", args: &[] },
    Case { file: "examples/cl/hypar-5axis.cl", machine: "maho600e", args: &[] },
    Case { file: "examples/cl/hypar-5axis.cl", machine: "haas-umc750", args: &[] },
    Case { file: "examples/cl/bicubic-5axis.cl", machine: "mikron-ucp710", args: &[] },
    Case { file: "examples/cl/bicubic-5axis.cl", machine: "maho600e", args: &[] },
    Case { file: "examples/cl/bicubic-5axis.cl", machine: "haas-umc750", args: &[] },
    Case { file: VARIABLE_AXIS, machine: "haas-umc750", args: &[] },
    Case { file: PROJECT2, machine: "haas-umc750", args: &[] },
];

/// Each dialect with TCP, and how it gives the orientation (Haas's `G234` takes angles only).
const TCP_DIALECTS: [(&str, bool); 7] = [
    ("fanuc", false),
    ("fanuc", true),
    ("haas", false),
    ("siemens-840d", false),
    ("siemens-840d", true),
    ("heidenhain", false),
    ("heidenhain", true),
];

/// Tilted 3+2 set-ups: the fixture (three set-ups: 30° about X then 40° about Z, 25° about Y
/// then −110° about Z, and +Z; a half circle about the tool axis in each) on the three machines,
/// and clsplit's SOLIDWORKS parts with tilted set-ups (tool along +X and −X, a 0.29° wedge;
/// holes in tilted planes), on the MAHO (B/C, part zero off the table's axes) and the Haas.
const PLANE_CASES: &[Case] = &[
    Case { file: FIXTURE, machine: "mikron-ucp710", args: &["--arc-sense", "ccw"] },
    Case { file: FIXTURE, machine: "maho600e", args: &["--arc-sense", "ccw"] },
    Case { file: FIXTURE, machine: "haas-umc750", args: &["--arc-sense", "ccw"] },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2021/Teste-Metrologia/input/Teste-Metrologia.apt",
        machine: "maho600e",
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2021/Teste-Metrologia/input/Teste-Metrologia.apt",
        machine: "haas-umc750",
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-tools/wall-holes/input/wall-holes.apt",
        machine: "maho600e",
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2022/shimemcunha/input/shimemcunha.apt",
        machine: "haas-umc750",
        args: &[],
    },
];

/// Each dialect with working planes.
const PLANE_DIALECTS: [&str; 4] = ["fanuc", "haas", "siemens-840d", "heidenhain"];

/// What a program is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// `--mode tcp`, the orientation as vectors or angles.
    Tcp { vectors: bool },
    /// 3+2 set-ups in the controller's working planes (`--plane-mode cycle`, the default).
    Plane,
    /// 3+2 set-ups in axis values (LinuxCNC).
    Joints,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Tcp { vectors: false } => "tcp angles",
            Kind::Tcp { vectors: true } => "tcp vectors",
            Kind::Plane => "planes",
            Kind::Joints => "axis values",
        }
    }

    /// postpro's options for it.
    fn args(self) -> &'static [&'static str] {
        match self {
            Kind::Tcp { vectors: false } => &["--mode", "tcp", "--tcp-orientation", "angles"],
            Kind::Tcp { vectors: true } => &["--mode", "tcp", "--tcp-orientation", "vectors"],
            Kind::Plane | Kind::Joints => &["--plane-mode", "cycle"],
        }
    }
}

/// What LinuxCNC's rs274 refuses in our programs of each dialect and kind (sorted): the
/// construct, and rs274's message. Each is taken out of the program for the next run
/// (`rs274_reads`). A machine with rotary brakes (the Haas's M10–M13) adds them.
fn rs274_refuses(dialect: &str, kind: Kind, m: &Machine) -> Vec<String> {
    let brakes = m.axes.iter().any(|a| a.clamp.is_some());
    let mut refused: Vec<String> = rs274_refuses_in(dialect, kind).iter().map(|r| r.to_string()).collect();
    if brakes && matches!(dialect, "fanuc" | "haas") {
        refused.push(format!("{BRAKES}: Unknown m code used"));
    }
    refused.sort();
    refused
}

/// The machine's rotary brakes, as rs274's refusal names them.
const BRAKES: &str = "the rotary brakes' M codes";

/// What rs274 refuses in the programs of a dialect and kind, but the brakes.
fn rs274_refuses_in(dialect: &str, kind: Kind) -> &'static [&'static str] {
    match (dialect, kind) {
        ("fanuc", Kind::Tcp { vectors: false }) => &["G43.4: Unknown g code used"],
        ("fanuc", Kind::Tcp { vectors: true }) => &[
            "G43.5: Unknown g code used",
            "I J K on a straight move: I word with no G2, G3, G5, G5.1, G10, G33.1, G76, or G87 to use it",
        ],
        ("haas", Kind::Tcp { .. }) => &[
            "G187: G-code out of range",
            "D on G43: D word with no G41, G41.1, G42, G42.1, G71, G71.1, G71.2 or G96 to use it",
            "G234: G-code out of range",
        ],
        ("fanuc", Kind::Plane) => {
            &["G68.2: Unknown g code used", "G53.1: Unknown g code used", "G69: Unknown g code used"]
        }
        ("haas", Kind::Plane) => &[
            "G187: G-code out of range",
            "D on G43: D word with no G41, G41.1, G42, G42.1, G71, G71.1, G71.2 or G96 to use it",
            "G254: G-code out of range",
            "G255: G-code out of range",
        ],
        _ => &[],
    }
}

/// The G codes of our Fanuc and Haas programs that LinuxCNC does not have.
const FOREIGN_G: [&str; 9] = ["G43.4", "G43.5", "G68.2", "G53.1", "G69", "G234", "G254", "G255", "G187"];

/// The CL file's path.
fn cl_path(file: &str) -> PathBuf {
    let repo = common::repo().join(file);
    if repo.exists() { repo } else { data_dir().join(file) }
}

/// The reading options of a case's arguments.
fn read_options(args: &[&str]) -> ReadOptions {
    let arc_sense = args.windows(2).find(|w| w[0] == "--arc-sense").map(|w| match w[1] {
        "cw" => ArcSense::Cw,
        _ => ArcSense::Ccw,
    });
    ReadOptions { arc_sense, ..ReadOptions::default() }
}

/// The letters of the machine's rotary axes, in its order.
fn rotary_letters(m: &Machine) -> String {
    m.axes.iter().filter(|a| a.kind == AxisKind::Rotary).map(|a| a.letter.to_ascii_uppercase()).collect()
}

/// Posts `case` in `dialect` as `kind`.
fn write(case: &Case, dialect: &str, kind: Kind) -> Result<Written, String> {
    let mut args: Vec<&str> = case.args.to_vec();
    args.extend_from_slice(kind.args());
    let group = format!("tcp_and_planes/{}", case.machine);
    backsim::write(&group, &cl_path(case.file), case.machine, dialect, &args)
}

/// The interpreters, found once.
struct Interpreters {
    rs274: Option<Rs274>,
    python: Option<PathBuf>,
}

impl Interpreters {
    fn find() -> Interpreters {
        Interpreters { rs274: Rs274::for_test(), python: backsim::nc_python() }
    }
}

/// Reads our program of `dialect` back: the harness's reader, and the interpreter CI runs for
/// it where there is one. Returns the program and what the interpreter said.
fn read_back(
    written: &Written,
    dialect: &str,
    kind: Kind,
    m: &Machine,
    interpreters: &Interpreters,
) -> Result<(Program, String), String> {
    let name = written.path.to_string_lossy().into_owned();
    match dialect {
        "fanuc" | "haas" => {
            let program = fanuc::read(&name, &written.text).map_err(|e| e.to_string())?;
            let said = match &interpreters.rs274 {
                Some(rs274) => rs274_reads(rs274, written, &program, m, &rs274_refuses(dialect, kind, m))?,
                None => "rs274 skipped".to_string(),
            };
            Ok((program, said))
        }
        "heidenhain" => {
            let program = heidenhain::read(&name, &written.text).map_err(|e| e.to_string())?;
            Ok((program, "no interpreter".to_string()))
        }
        "siemens-840d" => {
            let Some(python) = &interpreters.python else {
                return Err("skipped: nc-gcode-interpreter not installed".to_string());
            };
            siemens_reads(python, written, &rotary_letters(m))
        }
        "linuxcnc" => {
            let Some(rs274) = &interpreters.rs274 else { return Err("skipped: rs274 not installed".to_string()) };
            let units = programs::program_units(&written.text);
            let tools = rs274_tools(&header_tools(&written.text), units);
            let program = rs274.run(&written.path, &tools).map_err(|e| e.to_string())?;
            Ok((program, "rs274 reads it".to_string()))
        }
        other => Err(format!("no reader for {other}")),
    }
}

/// How a construct rs274 refuses is taken out of a line.
type LineFix = Box<dyn Fn(&str) -> String>;

/// Runs our Fanuc or Haas program through rs274: each construct it refuses (a G code of
/// [`FOREIGN_G`], the I J K of a straight move, the D of a `G43`, the M codes of the machine's
/// rotary brakes) is noted with rs274's message and taken out of every line (the line kept, as a
/// comment, so that the lines stay), until it reads the program to its end; the noted constructs
/// must be `expected`, and the positions rs274 reaches (in the program's own frame) the Fanuc
/// reader's `reader`, in order.
fn rs274_reads(
    rs274: &Rs274,
    written: &Written,
    reader: &Program,
    m: &Machine,
    expected: &[String],
) -> Result<String, String> {
    let brakes: Vec<String> =
        m.axes.iter().filter_map(|a| a.clamp.as_ref()).flat_map(|c| [c.lock.clone(), c.unlock.clone()]).collect();
    let units = reader.units;
    let tools = rs274_tools(&header_tools(&written.text), units);
    let name = written.path.to_string_lossy().into_owned();
    let mut text = written.text.clone();
    let mut refused: Vec<String> = Vec::new();
    let theirs = loop {
        let error = match rs274.run_text(&name, &text, &tools) {
            Ok(p) => break p,
            Err(e) => e,
        };
        let tests::Error::Rs274 { line: Some(line), text: Some(block), message, .. } = &error else {
            return Err(format!("rs274: {error}"));
        };
        let words: Vec<&str> = block.split('(').next().unwrap_or("").split_whitespace().collect();
        let g = FOREIGN_G.iter().find(|g| words.contains(g));
        let brake = words.iter().any(|w| brakes.iter().any(|b| b == w));
        let (construct, fix): (String, LineFix) = if let Some(&g) = g {
            let fix = move |l: &str| {
                let code: Vec<&str> = l.split('(').next().unwrap_or("").split_whitespace().collect();
                if code.contains(&g) { format!("(rs274 has no {g})") } else { l.to_string() }
            };
            (g.to_string(), Box::new(fix))
        } else if message.starts_with("I word with no") {
            let fix = |l: &str| {
                let code: Vec<&str> = l.split('(').next().unwrap_or("").split_whitespace().collect();
                if code.iter().any(|w| matches!(*w, "G2" | "G3")) {
                    return l.to_string();
                }
                code.into_iter().filter(|w| !w.starts_with(['I', 'J', 'K'])).collect::<Vec<_>>().join(" ")
            };
            ("I J K on a straight move".to_string(), Box::new(fix))
        } else if message.starts_with("Unknown m code used") && brake {
            let brakes = brakes.clone();
            let fix = move |l: &str| {
                let code: Vec<&str> = l.split('(').next().unwrap_or("").split_whitespace().collect();
                if code.iter().any(|w| brakes.iter().any(|b| b == w)) {
                    "(rs274 has no rotary brakes)".to_string()
                } else {
                    l.to_string()
                }
            };
            (BRAKES.to_string(), Box::new(fix))
        } else if message.starts_with("D word with no") && words.contains(&"G43") {
            let fix = |l: &str| {
                let code: Vec<&str> = l.split('(').next().unwrap_or("").split_whitespace().collect();
                if !code.contains(&"G43") {
                    return l.to_string();
                }
                code.into_iter().filter(|w| !w.starts_with('D')).collect::<Vec<_>>().join(" ")
            };
            ("D on G43".to_string(), Box::new(fix))
        } else {
            return Err(format!("rs274 refused line {line} `{block}`, which is none of ours it lacks: {message}"));
        };
        // rs274 names the M code it does not know: the brakes are one construct.
        let message = if construct == BRAKES { message.split(':').next().unwrap_or("") } else { message.as_str() };
        let said = format!("{construct}: {message}");
        if refused.contains(&said) {
            return Err(format!("rs274 refused {said} again at line {line}"));
        }
        refused.push(said);
        text = text.lines().map(|l| format!("{}\n", fix(l))).collect();
    };
    let mut sorted = refused.clone();
    sorted.sort();
    if sorted != expected {
        return Err(format!("rs274 refused {sorted:?}, not {expected:?}"));
    }
    let theirs = theirs.in_units(units);
    // rs274 prints four decimals; ours may have five.
    let c = tests::compare::motions_in_order(&theirs.motions, &reader.motions, 0.5e-4 + 1e-9, 0.5e-4 + 1e-9);
    if !c.is_match() {
        return Err(format!("rs274's positions are not the Fanuc reader's: {c}"));
    }
    let refused: Vec<&str> = refused.iter().map(|r| r.split(':').next().unwrap_or("")).collect();
    Ok(format!("rs274 reads it but {} and reaches the reader's {} positions", refused.join(", "), c.compared))
}

/// Reads our Siemens program with nc-gcode-interpreter and the harness's Siemens reader. The
/// interpreter has no grammar for the tool vector's `A3=` (an axis A, then `3`, then `=`): a
/// program with one is refused at the `=` of the first, which is pinned, and the interpreter
/// reads a copy without `A3= B3= C3=`, whose positions the reader takes (the vectors it reads from
/// the text).
fn siemens_reads(python: &Path, written: &Written, rotaries: &str) -> Result<(Program, String), String> {
    let axes = format!("XYZ{rotaries}IJK");
    let name = written.path.to_string_lossy().into_owned();
    // The first `A3=`: its line and the column of its `=` (1-based).
    let first_vector = written.text.lines().enumerate().find_map(|(i, l)| l.find(" A3=").map(|c| (i + 1, c + 4)));
    let (rows, said) = match (backsim::siemens_table(python, &written.path, &axes), first_vector) {
        (Ok(rows), None) => (rows, "nc-gcode-interpreter reads it".to_string()),
        (Ok(_), Some((line, _))) => {
            return Err(format!("nc-gcode-interpreter reads the A3= of line {line} now: read it and unpin this"));
        }
        (Err(e), None) => return Err(e),
        (Err(e), Some((line, column))) => {
            // The interpreter's position of the `=` after `A3` (1-based line and column).
            let expected = format!("line_col: Pos(({line}, {column})),");
            if !(e.contains("ParsingError") && e.contains(&expected)) {
                return Err(format!("nc-gcode-interpreter refused it, not at `A3=` ({expected}): {e}"));
            }
            let copy = written.path.with_extension("no-a3b3c3.mpf");
            let stripped: String = written
                .text
                .lines()
                .map(|l| {
                    let kept: Vec<&str> = l
                        .split(' ')
                        .filter(|w| !(w.starts_with("A3=") || w.starts_with("B3=") || w.starts_with("C3=")))
                        .collect();
                    format!("{}\n", kept.join(" "))
                })
                .collect();
            std::fs::write(&copy, stripped).map_err(|e| format!("{}: {e}", copy.display()))?;
            let rows = backsim::siemens_table(python, &copy, &axes)?;
            (rows, format!("nc-gcode-interpreter refuses A3= (line {line}, column {column}), reads the rest"))
        }
    };
    let program = siemens::read(&name, &written.text, &rows).map_err(|e| e.to_string())?;
    Ok((program, said))
}

/// Where the program's coordinates are, motion by motion.
#[derive(Clone, Copy, Debug)]
enum Map {
    /// The part frame (TCP, Haas's dynamic work offset).
    Part,
    /// A tilted working plane.
    Plane(Frame),
    /// Axis values, through the forward kinematics (with the rotaries of the motion).
    Joints(Rotary),
}

/// The program placed in the part frame.
#[derive(Default)]
struct Placed {
    /// The tip (mm) and tool axis at the end of every motion.
    tips: Vec<(Point3<f64>, Unit<Vector3<f64>>)>,
    /// The feed path in the part frame (arcs of a tilted plane or of axis values as 64 chords).
    path: Vec<Motion>,
    /// Hole bottoms the program reaches, in order: canned-cycle holes and feed-move ends.
    bottoms: Vec<Point3<f64>>,
    /// TCP and working planes switched on.
    frames: usize,
    /// The first position in each frame switched on (part frame, mm) and its line: where a block
    /// leaves X and Y to the controller (`G0 Z…` after `G68.2`), the controller's, on the
    /// spindle's line through the move across.
    firsts: Vec<(usize, Point3<f64>)>,
    /// The largest distance of a frame's first position from the spindle's line through the
    /// move across before it, mm.
    approach: f64,
    /// The largest angle between a tilted plane's z and the tool axis of its rotaries, degrees.
    plane_axis: f64,
}

/// The written values of axis values `p` with the rotaries `r`, as the kinematics' joints.
fn joints(m: &Machine, frame: &WorkFrame, p: [f64; 3], r: &Rotary, line: usize) -> Result<Joints, String> {
    let mut values = Vec::with_capacity(m.axes.len());
    for a in &m.axes {
        let letter = a.letter.chars().next().unwrap_or('X').to_ascii_uppercase();
        values.push(match (a.kind, letter) {
            (AxisKind::Linear, 'X') => p[0],
            (AxisKind::Linear, 'Y') => p[1],
            (AxisKind::Linear, _) => p[2],
            (_, l) => r.get(l).ok_or_else(|| format!("line {line}: the {l} axis is not known"))?.to_radians(),
        });
    }
    Ok(frame.unapply(&Joints::from_slice(&values)))
}

fn point(p: [f64; 3]) -> Point3<f64> {
    Point3::new(p[0], p[1], p[2])
}

/// Places the program (in mm) in the part frame: its frames from its events, axis values through
/// the machine's forward kinematics in `frame` (the tool length is the controller's: the
/// machines' rotaries carry the part).
fn place(program: &Program, m: &Machine, frame: &WorkFrame) -> Result<Placed, String> {
    assert!(m.chain.tool.is_empty(), "{}: a machine whose rotaries carry the part", m.name);
    let kin = postpro_kin::solver_for(m);
    let nose = ToolLength::new(kin.as_ref(), 0.0);
    let forward = |p: [f64; 3], r: &Rotary, line: usize| -> Result<postpro_kin::Pose, String> {
        Ok(postpro_kin::Kinematics::forward(&nose, &joints(m, frame, p, r, line)?))
    };
    let mut placed = Placed::default();
    let (mut tcp, mut dynamic, mut plane): (bool, bool, Option<Frame>) = (false, false, None);
    // The move across at the clearance (X Y known, Z not), and a frame waiting for its first
    // position: its command's line and the move across before it.
    let mut across: Option<[f64; 2]> = None;
    let mut pending: Option<(usize, Option<[f64; 2]>)> = None;
    // The spindle's line through the move across (a point and the tool axis, part frame) with
    // the rotaries of the frame's first motion; a first position is on it.
    let spindle_line = |across: [f64; 2], r: &Rotary, line: usize| -> Result<(Point3<f64>, Vector3<f64>), String> {
        let pose = forward([across[0], across[1], 0.0], r, line)?;
        Ok((pose.tip, pose.axis.into_inner()))
    };
    let mut plane_rotaries: Option<Rotary> = None;
    let mut last_rotary = Rotary::default();
    let mut events = program.events.iter().peekable();
    let hole = |e: &Event, map: Map| -> Option<(usize, [f64; 3], Map)> {
        match &e.kind {
            EventKind::Hole { at, bottom, .. } => Some((e.line, [at[0], at[1], *bottom], map)),
            _ => None,
        }
    };
    let map_point = |map: Map, p: [f64; 3], line: usize| -> Result<[f64; 3], String> {
        match map {
            Map::Part => Ok(p),
            Map::Plane(f) => Ok(f.outer(p)),
            Map::Joints(r) => Ok(forward(p, &r, line)?.tip.into()),
        }
    };
    let current = |tcp: bool, dynamic: bool, plane: Option<Frame>, r: Rotary| match (tcp || dynamic, plane) {
        (true, _) => Map::Part,
        (false, Some(f)) => Map::Plane(f),
        (false, None) => Map::Joints(r),
    };
    // Every motion, with the events before it; after the last, the events left.
    for k in 0..=program.motions.len() {
        while let Some(e) = events.next_if(|e| e.before <= k || k == program.motions.len()) {
            let on = match &e.kind {
                EventKind::Tcp { on } => {
                    tcp = *on;
                    *on
                }
                EventKind::WorkOffset { name, .. } if name == "G254" || name == "G255" => {
                    dynamic = name == "G254";
                    dynamic
                }
                EventKind::WorkingPlane { frame, .. } => {
                    plane = *frame;
                    plane_rotaries = None;
                    frame.is_some()
                }
                EventKind::Positioning { to: [Some(x), Some(y), None], .. } if pending.is_none() => {
                    across = Some([*x, *y]);
                    false
                }
                // The first position in a frame, along Z only: X and Y are where the move across
                // left the tool, in the frame's coordinates (the rotaries are the next motion's).
                EventKind::Positioning { to: [None, None, Some(z)], .. } if pending.is_some() => {
                    let (on_line, across) = pending.take().unwrap_or_default();
                    let Some(across) = across else {
                        return Err(format!(
                            "line {on_line}: no move across at the clearance before the frame comes on"
                        ));
                    };
                    let r = program.motions.get(k).map_or(last_rotary, |m| m.rotary);
                    let (start, axis) = spindle_line(across, &r, e.line)?;
                    let (s, a) = match current(tcp, dynamic, plane, r) {
                        Map::Plane(f) => (f.inner(start.into()), f.inner_direction(axis.into())),
                        _ => (start.into(), axis.into()),
                    };
                    if a[2].abs() < 1e-6 {
                        return Err(format!("line {}: a move along Z across the spindle", e.line));
                    }
                    let t = (z - s[2]) / a[2];
                    let p = [s[0] + t * a[0], s[1] + t * a[1], *z];
                    let map = current(tcp, dynamic, plane, r);
                    placed.firsts.push((e.line, point(map_point(map, p, e.line)?)));
                    false
                }
                _ => {
                    if let Some((line, p, map)) = hole(e, current(tcp, dynamic, plane, last_rotary)) {
                        placed.bottoms.push(point(map_point(map, p, line)?));
                    }
                    false
                }
            };
            if on {
                placed.frames += 1;
                pending = Some((e.line, across));
            }
        }
        let Some(motion) = program.motions.get(k) else { break };
        let line = motion.line;
        let map = current(tcp, dynamic, plane, motion.rotary);
        let kinematic = forward([0.0; 3], &motion.rotary, line)?.axis;
        let axis = match (tcp, motion.vector) {
            (true, Some(v)) => {
                Unit::try_new(Vector3::from(v), 1e-9).ok_or_else(|| format!("line {line}: a zero vector"))?
            }
            _ => kinematic,
        };
        let tip = point(map_point(map, motion.to, line)?);
        if let Some(f) = plane.filter(|_| !tcp && !dynamic) {
            // The plane's z is the tool axis of the rotaries, which stand inside it.
            let angle = kinematic.angle(&Vector3::from(f.z())).to_degrees();
            placed.plane_axis = placed.plane_axis.max(angle);
            match &plane_rotaries {
                None => plane_rotaries = Some(motion.rotary),
                Some(r) if *r != motion.rotary => {
                    return Err(format!(
                        "line {line}: a rotary axis turns inside the working plane ({r:?} to {:?})",
                        motion.rotary
                    ));
                }
                Some(_) => {}
            }
        }
        if let Some((on_line, across)) = pending.take() {
            let Some(across) = across else {
                return Err(format!("line {on_line}: no move across at the clearance before the frame comes on"));
            };
            let (start, axis) = spindle_line(across, &motion.rotary, line)?;
            placed.approach = placed.approach.max((tip - start).cross(&axis).norm());
            placed.firsts.push((line, tip));
        }
        if !motion.is_feed() {
            across = None;
        }
        placed.tips.push((tip, axis));
        if motion.is_feed() {
            placed.bottoms.push(tip);
            let from = map_point(map, motion.from, line)?;
            match (map, motion.kind) {
                (Map::Part, _) => placed.path.push(*motion),
                (_, MotionKind::Arc(_)) => {
                    let mut at = from;
                    for s in 1..=64 {
                        let next = map_point(map, motion.point_at(f64::from(s) / 64.0), line)?;
                        placed.path.push(Motion { kind: MotionKind::Feed, from: at, to: next, ..*motion });
                        at = next;
                    }
                }
                _ => placed.path.push(Motion { from, to: tip.into(), ..*motion }),
            }
        }
        last_rotary = motion.rotary;
    }
    if let Some((line, _)) = pending {
        return Err(format!("line {line}: a frame comes on with no position after it"));
    }
    if placed.firsts.len() != placed.frames {
        return Err(format!("{} frames on, {} first positions", placed.frames, placed.firsts.len()));
    }
    Ok(placed)
}

/// Every CL hole's bottom (its top less its depth along the tool axis) is one the program
/// reaches, in order, within `tolerance`: the largest distance.
fn holes_reached(holes: &[backsim::ClHole], bottoms: &[Point3<f64>], tolerance: f64) -> Result<f64, String> {
    let mut cursor = 0;
    let mut worst: f64 = 0.0;
    for h in holes {
        let bottom = point([0, 1, 2].map(|k| h.top[k] - h.depth * h.axis[k]));
        let Some(k) = (cursor..bottoms.len()).find(|&k| (bottoms[k] - bottom).norm() <= tolerance) else {
            return Err(format!("the hole of CL line {} (bottom {bottom:.4}) is not drilled", h.goto_line));
        };
        worst = worst.max((bottoms[k] - bottom).norm());
        cursor = k;
    }
    Ok(worst)
}

/// What one program measured.
struct Measured {
    points: usize,
    tip: f64,
    axis: f64,
    path: f64,
    /// The program line nearest the farthest CL point.
    path_line: usize,
    holes: usize,
    hole: f64,
    frames: usize,
    approach: f64,
    plane_axis: f64,
}

/// The independent check of one program read back: placed in the part frame, it reaches the CL
/// file's points, path and holes; its frames come on over the approach; its planes' z is the
/// tool axis.
fn check(program: &Program, case: &Case, m: &Machine, kind: Kind) -> Result<Measured, String> {
    let kin = postpro_kin::solver_for(m);
    let frame = match kind {
        Kind::Joints => postpro_motion::work_frame(kin.as_ref(), postpro_motion::Mode::G1),
        _ => postpro_motion::part_zero_frame(kin.as_ref()),
    };
    let inch = program.units == Units::Inch;
    let placed = place(&program.in_units(Units::Mm), m, &frame)?;
    let file = cl_path(case.file);
    let options = read_options(case.args);
    let points = cl_points(&file, &options);
    let (joint_tolerance, cone) = programs::tolerances(m, inch);
    // TCP: the tip's four decimals (five in inch); the vector's seven.
    let tcp_linear = 3f64.sqrt() * if inch { 0.5e-5 * 25.4 } else { 0.5e-4 } + 1e-6;
    // The end of an arc may be moved onto its circle (a CL helix's end radius rounded off its
    // start's), within the linearization tolerance.
    let cl = backsim::read_cl(&file, &options);
    let arc_ends: std::collections::BTreeSet<usize> = cl.arcs.iter().map(|a| a.line).collect();
    let on_arc = |p: &ClPoint| if arc_ends.contains(&p.line) { m.policy.linearization_tolerance } else { 0.0 };
    let tolerance = |p: &ClPoint| {
        on_arc(p)
            + match kind {
                Kind::Tcp { .. } => tcp_linear,
                _ => joint_tolerance(p),
            }
    };
    let axis_tolerance = if kind == (Kind::Tcp { vectors: true }) { 1e-4 } else { cone };
    let (tip, axis) = reached_in_order(&points, &placed.tips, tolerance, axis_tolerance)?;
    let far = points.iter().map(&tolerance).fold(0.0, f64::max);
    let allowed = m.policy.linearization_tolerance + far;
    // Exact for every point beyond the written precision (the walk searches the whole path for
    // those): a point near two passes is not reported at the farther.
    let precision = 3f64.sqrt() * 0.5e-3 * if inch { 2.54 } else { 1.0 };
    let off = backsim::farthest_point(&cl.points, &placed.path, precision);
    let path = off.map_or(0.0, |o| o.distance);
    let path_line = off.and_then(|o| o.line).unwrap_or(0);
    if let Some(o) = off.filter(|o| o.distance > allowed) {
        let p = cl.points[o.point];
        return Err(format!(
            "the CL point {:.4} {:.4} {:.4} is {:.4} mm from the path (nearest at line {:?}), more than {allowed:.4}",
            p[0], p[1], p[2], o.distance, o.line
        ));
    }
    let hole = holes_reached(&cl.holes, &placed.bottoms, far)?;
    // Each frame's first position is a position of the CL file (rapid or feed), or above a hole
    // on its axis (a cycle starts at the return level, or higher where the tool is).
    let positions: Vec<Point3<f64>> = cl
        .path
        .items
        .iter()
        .filter_map(|item| match &item.kind {
            postpro_cl::ItemKind::Move(m) => Some(m.to),
            postpro_cl::ItemKind::Arc(a) => Some(a.end),
            _ => None,
        })
        .collect();
    for (line, first) in &placed.firsts {
        let nearest = positions.iter().map(|p| (p - first).norm()).fold(f64::INFINITY, f64::min);
        let above_hole = cl.holes.iter().any(|h| {
            let (top, axis) = (point(h.top), Vector3::from(h.axis));
            (first - top).dot(&axis) >= 0.0 && (first - top).cross(&axis).norm() <= far
        });
        if nearest > far && !above_hole {
            return Err(format!(
                "line {line}: the first position in the frame, {:.4} {:.4} {:.4}, is no CL position (nearest {nearest:.4} mm)",
                first.x, first.y, first.z
            ));
        }
    }
    if placed.approach > far + joint_tolerance(&points[0]) {
        return Err(format!(
            "a frame comes on {:.4} mm off the spindle's line through the move across",
            placed.approach
        ));
    }
    let rounding = 0.5e-3 * 3.0 + 1e-6;
    if placed.plane_axis > rounding {
        return Err(format!("a working plane's z is {:.5}° off the tool axis of its rotaries", placed.plane_axis));
    }
    Ok(Measured {
        points: points.len(),
        tip,
        axis,
        path,
        path_line,
        holes: cl.holes.len(),
        hole,
        frames: placed.frames,
        approach: placed.approach,
        plane_axis: placed.plane_axis,
    })
}

/// Posts, reads back and checks one program; its report line.
fn run(case: &Case, dialect: &str, kind: Kind, interpreters: &Interpreters) -> Result<String, String> {
    let m = machine(case.machine);
    let label =
        format!("{} on {}, {dialect} {}", case.file.rsplit('/').next().unwrap_or(case.file), case.machine, kind.name());
    let outcome = write(case, dialect, kind).and_then(|written| {
        let (program, said) = match read_back(&written, dialect, kind, &m, interpreters) {
            Err(e) if e.starts_with("skipped") => return Ok(e),
            other => other?,
        };
        let frames = frame_commands(&written.text, dialect, kind);
        let x = check(&program, case, &m, kind).map_err(|e| format!("{e} ({})", written.path.display()))?;
        if (frames == 0 && kind != Kind::Joints) || x.frames < frames {
            return Err(format!("{} frame commands written, {} read ({})", frames, x.frames, written.path.display()));
        }
        let mut report = format!(
            "{} CL points within {:.4} mm and {:.4}°, path {:.4} mm (line {})",
            x.points, x.tip, x.axis, x.path, x.path_line
        );
        if x.holes > 0 {
            let _ = write!(report, ", {} holes within {:.4} mm", x.holes, x.hole);
        }
        if kind != Kind::Joints {
            let _ = write!(report, "; {} frames on, approach {:.4} mm off the spindle", x.frames, x.approach);
        }
        if kind == Kind::Plane && dialect != "haas" {
            let _ = write!(report, ", plane z {:.5}° off the rotaries' axis", x.plane_axis);
        }
        Ok(format!("{report}; {said}"))
    });
    outcome.map(|r| format!("{label}: {r}")).map_err(|e| format!("{label}: {e}"))
}

/// How many times the program switches TCP or a working plane on (as written).
fn frame_commands(text: &str, dialect: &str, kind: Kind) -> usize {
    let command: &[&str] = match (dialect, kind) {
        (_, Kind::Joints) => return 0,
        ("fanuc", Kind::Tcp { .. }) => &["G43.4", "G43.5"],
        ("fanuc", Kind::Plane) => &["G68.2"],
        ("haas", Kind::Tcp { .. }) => &["G234"],
        ("haas", Kind::Plane) => &["G254"],
        ("siemens-840d", Kind::Tcp { .. }) => &["TRAORI"],
        ("siemens-840d", Kind::Plane) => &["CYCLE800(0,"],
        ("heidenhain", Kind::Tcp { .. }) => &["M128"],
        ("heidenhain", Kind::Plane) => &["VECTOR"],
        _ => &[],
    };
    let comment: &[char] = if matches!(dialect, "fanuc" | "haas") { &['(', ';'] } else { &[';'] };
    text.lines()
        .filter(|l| {
            let code = l.split(comment).next().unwrap_or("");
            code.split_whitespace().any(|w| command.contains(&w))
        })
        .count()
}

/// Runs `jobs` on two threads; prints the reports, fails with every failure.
fn run_all(jobs: &[(Case, &str, Kind)], interpreters: &Interpreters) {
    let outcomes = on_two_threads(jobs, |(case, dialect, kind)| run(case, dialect, *kind, interpreters));
    let (ok, failed): (Vec<_>, Vec<_>) = outcomes.into_iter().partition(Result::is_ok);
    let ok: Vec<String> = ok.into_iter().map(|r| r.unwrap_or_default()).collect();
    eprintln!("{}", ok.join("\n"));
    let failed: Vec<String> = failed.into_iter().filter_map(Result::err).collect();
    assert!(failed.is_empty(), "{} program(s) failed:\n{}", failed.len(), failed.join("\n\n"));
}

/// TCP in every dialect that has it, angles and vectors: the tips and tool axes are the CL
/// file's, in order; the approach comes down along the spindle.
#[test]
fn tcp_programs_put_the_tool_on_the_cl_points() {
    let interpreters = Interpreters::find();
    let jobs: Vec<(Case, &str, Kind)> = TCP_CASES
        .iter()
        .flat_map(|c| TCP_DIALECTS.iter().map(move |&(d, vectors)| (*c, d, Kind::Tcp { vectors })))
        .collect();
    run_all(&jobs, &interpreters);
}

/// Tilted working planes in every dialect that has them, and LinuxCNC's axis values for the
/// same set-ups: the points, arcs and holes are the CL file's in the part frame; each plane's z
/// is the tool axis of the rotaries; the approach comes down along the spindle.
#[test]
fn tilted_plane_programs_put_the_tool_on_the_cl_points() {
    let interpreters = Interpreters::find();
    let mut jobs: Vec<(Case, &str, Kind)> =
        PLANE_CASES.iter().flat_map(|c| PLANE_DIALECTS.iter().map(move |&d| (*c, d, Kind::Plane))).collect();
    jobs.extend(PLANE_CASES.iter().filter(|c| c.file == FIXTURE).map(|c| (*c, "linuxcnc", Kind::Joints)));
    run_all(&jobs, &interpreters);
}

/// The checks fail on a program whose plane or angle is wrong: a G68.2 turned by 1° more about
/// X, a Heidenhain plane turned 90° about its normal, a CYCLE800 turned by 1° more about Y, a
/// Haas G254 set-up with B 1° off, a TCP angle 3° off, a TCP vector turned by 2°.
#[test]
fn a_wrong_plane_or_angle_fails_the_checks() {
    let tilted = PLANE_CASES[1];
    let tcp = TCP_CASES[0];
    let python = backsim::nc_python();
    let cases: [(Case, &str, Kind, &str, &str); 6] = [
        (tilted, "fanuc", Kind::Plane, "I40 J30 K-90", "I40 J31 K-90"),
        (tilted, "heidenhain", Kind::Plane, "BX+0.5566704 BY-0.6634139 BZ-0.5", "BX+0.7660444 BY+0.6427876 BZ+0"),
        (tilted, "siemens-840d", Kind::Plane, "23.8587, 18.7472", "23.8587, 19.7472"),
        (tilted, "haas", Kind::Plane, "G0 B30.000 C50.000", "G0 B31.000 C50.000"),
        (tcp, "fanuc", Kind::Tcp { vectors: false }, "A-24.5965 C-42.5021", "A-21.5965 C-42.5021"),
        (tcp, "heidenhain", Kind::Tcp { vectors: true }, "TX+0.2812089 TY+0.3068629", "TX+0.3068629 TY+0.2812089"),
    ];
    for (case, dialect, kind, right, wrong) in cases {
        let written = write(&case, dialect, kind).unwrap_or_else(|e| panic!("{e}"));
        assert!(written.text.contains(right), "{dialect}: `{right}` is not in {}", written.path.display());
        let text = written.text.replacen(right, wrong, 1);
        let name = written.path.to_string_lossy().into_owned();
        let m = machine(case.machine);
        let program = match dialect {
            "fanuc" | "haas" => fanuc::read(&name, &text),
            "heidenhain" => heidenhain::read(&name, &text),
            _ => {
                let Some(python) = &python else { continue };
                let axes = format!("XYZ{}IJK", rotary_letters(&m));
                let rows = backsim::siemens_table(python, &written.path, &axes).unwrap_or_else(|e| panic!("{e}"));
                siemens::read(&name, &text, &rows)
            }
        }
        .unwrap_or_else(|e| panic!("{e}"));
        let right_program =
            read_back(&written, dialect, kind, &m, &Interpreters { rs274: None, python: python.clone() })
                .unwrap_or_else(|e| panic!("{e}"))
                .0;
        check(&right_program, &case, &m, kind).unwrap_or_else(|e| panic!("{dialect} as written: {e}"));
        let e = check(&program, &case, &m, kind).err();
        assert!(e.is_some(), "{dialect} {}: `{wrong}` for `{right}` passes the checks", kind.name());
        eprintln!("{dialect} {}: `{wrong}` for `{right}`: {}", kind.name(), e.unwrap_or_default());
    }
}

/// The fixture is what its comment says: three set-ups whose tool axes are the rotations named,
/// each a rectangle with a half circle (six feed points), 2 mm deep.
#[test]
fn the_tilted_fixture_has_its_three_set_ups() {
    let points = cl_points(&cl_path(FIXTURE), &read_options(&["--arc-sense", "ccw"]));
    let mut axes: Vec<[f64; 3]> = Vec::new();
    for p in &points {
        let a = [p.axis.x, p.axis.y, p.axis.z];
        if axes.last().is_none_or(|b| (0..3).any(|k| (a[k] - b[k]).abs() > 1e-9)) {
            axes.push(a);
        }
    }
    let expected = [
        Frame::euler_zxz([0.0; 3], [40.0, 30.0, 0.0]).z(),
        Frame::euler_xyz([0.0; 3], [0.0, 25.0, 0.0]).outer_direction([0.0, 0.0, 1.0]),
        [0.0, 0.0, 1.0],
    ];
    assert_eq!(axes.len(), 3, "{axes:?}");
    let turned = |v: [f64; 3], deg: f64| {
        let (s, c) = deg.to_radians().sin_cos();
        [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
    };
    let expected = [expected[0], turned(expected[1], -110.0), expected[2]];
    for (a, e) in axes.iter().zip(expected) {
        assert!((0..3).all(|k| (a[k] - e[k]).abs() < 1e-6), "{a:?} is not {e:?}");
    }
    assert_eq!(points.len(), 3 * 6, "three set-ups of six feed points");
}
