//! Our programs written by the real `postpro` and read back (rs274, the harness's readers), and
//! the CL file's own path they are held to: what the back-simulation tests of arcs and canned
//! cycles share.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use postpro_cl::{ItemKind, Motion as ClMotion, MoveKind, ReadOptions, Source, ToolPath};
use tests::compare::WINDOW;
use tests::golden::siemens;
use tests::nc::{Motion, Plane, Program};
use tests::rs274::Rs274;

use super::{postpro, repo, stderr};

/// A program `postpro` wrote.
pub(crate) struct Written {
    /// Where it is (kept under the test's target folder for a look after a failure).
    pub(crate) path: PathBuf,
    /// Its text.
    pub(crate) text: String,
    /// What `postpro` said on standard error (warnings).
    pub(crate) stderr: String,
}

/// The extension `postpro` gives a dialect's programs.
fn extension(dialect: &str) -> &'static str {
    match dialect {
        "linuxcnc" => "ngc",
        "fanuc" | "haas" => "nc",
        "siemens-840d" => "mpf",
        "heidenhain" => "h",
        other => panic!("no dialect {other}"),
    }
}

/// Runs `postpro --machine MACHINE CL --dialect DIALECT [extra…] -o OUT --no-predict` from the
/// repository root into `target/tmp/GROUP/`, the file named after the CL file, the dialect and
/// the extra arguments. An error is the command and what postpro said.
pub(crate) fn write(group: &str, cl: &Path, machine: &str, dialect: &str, extra: &[&str]) -> Result<Written, String> {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(group);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let stem = cl.file_name().map(|n| n.to_string_lossy().replace('.', "_")).unwrap_or_default();
    let tag: String =
        extra.iter().map(|a| a.trim_start_matches('-').replace([' ', '/', '.'], "_")).collect::<Vec<_>>().join("_");
    let name = if tag.is_empty() { format!("{stem}__{dialect}") } else { format!("{stem}__{dialect}__{tag}") };
    let out = dir.join(format!("{name}.{}", extension(dialect)));
    let out_text = out.to_string_lossy().into_owned();
    let cl_text = cl.to_string_lossy().into_owned();
    let mut args = vec!["--machine", machine, cl_text.as_str(), "--dialect", dialect, "--no-predict", "-o", &out_text];
    args.extend_from_slice(extra);
    let o = postpro(&args, &repo());
    if !o.status.success() {
        return Err(format!("postpro {} failed:\n{}", args.join(" "), stderr(&o)));
    }
    let text = std::fs::read_to_string(&out).map_err(|e| format!("{out_text}: {e}"))?;
    Ok(Written { path: out, text, stderr: stderr(&o) })
}

/// Runs our LinuxCNC program through rs274 with a tool table of the CL file's tools and of
/// those the program calls (postpro takes tool 1 where the CL file loads none); `None` when
/// rs274 is not installed (a "skipped" line; a failure under CI). Feeds per revolution (`G95`,
/// a lathe file's) are run as per minute: the harness does not model them, and the path does
/// not depend on the feed. The work offset G54 is set 450 mm below the machine's Z zero (on the
/// program's first comment line, so that no line moves), as a shop sets it: without it the
/// retracts to the machine's Z zero (`G53 G0 Z0`) would end below the part in the work frame.
pub(crate) fn rs274(written: &Written, cl: &Cl) -> Option<Result<Program, String>> {
    let rs274 = Rs274::for_test()?;
    let mut tools = cl.tools.clone();
    for number in called_tools(&written.text) {
        if !tools.iter().any(|(n, _, _)| *n == number) {
            tools.push((number, 100.0, 10.0));
        }
    }
    let name = written.path.to_string_lossy();
    let mut set = false;
    let text: String = written
        .text
        .replace("G95", "G94")
        .lines()
        .map(|line| {
            if !set && line.starts_with('(') {
                set = true;
                format!("G10 L2 P1 X0 Y0 Z-450 {line}\n")
            } else {
                format!("{line}\n")
            }
        })
        .collect();
    Some(rs274.run_text(&name, &text, &tools).map_err(|e| e.to_string()))
}

/// The numbers of the `T` and `H` words of a G-code program.
fn called_tools(text: &str) -> BTreeSet<u32> {
    text.lines()
        .flat_map(|l| l.split(['(', ';']).next().unwrap_or("").split_whitespace())
        .filter_map(|w| w.strip_prefix('T').or_else(|| w.strip_prefix('H')))
        .filter_map(|n| n.parse().ok())
        .collect()
}

/// A canned cycle's hole in the CL file: its top point (where the CL file puts the hole), the
/// cycle's depth below it and R plane above it, along the tool axis (+Z in 3-axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ClHole {
    /// The top of the hole (part frame, mm).
    pub(crate) top: [f64; 3],
    /// The bottom of the hole below the top, mm.
    pub(crate) depth: f64,
    /// The R plane above the top, mm.
    pub(crate) clearance: f64,
    /// The tool axis (the hole's axis, pointing out of it).
    pub(crate) axis: [f64; 3],
    /// The CL line of the cycle.
    pub(crate) line: usize,
    /// The CL line of the hole's position (its `GOTO`).
    pub(crate) goto_line: usize,
}

/// A CL arc as the reader gives it (counter-clockwise about `normal`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ClArc {
    /// The end point.
    pub(crate) end: [f64; 3],
    /// The axis the motion is counter-clockwise about.
    pub(crate) normal: [f64; 3],
    /// The swept angle, radians, full turns included.
    pub(crate) sweep: f64,
    /// The CL line.
    pub(crate) line: usize,
}

/// A CL file as our reader reads it: its feed path (moves at feed and arcs, the holes of canned
/// cycles left out), the points along it, its arcs, holes and tools.
pub(crate) struct Cl {
    /// Its path relative to `../shared/data` (or as given).
    pub(crate) name: String,
    /// The reader's tool path.
    pub(crate) path: ToolPath,
    /// The length of the feed path, mm: straight feed moves and arcs (helices and turns
    /// included), not the moves into, between and out of canned-cycle holes.
    pub(crate) length: f64,
    /// The feed path's points in order: the end of every feed move, and of every arc the end and
    /// the points at a quarter, half and three quarters of its sweep (which a wrong sense misses).
    pub(crate) points: Vec<[f64; 3]>,
    /// The arcs, at feed.
    pub(crate) arcs: Vec<ClArc>,
    /// The holes of the canned cycles.
    pub(crate) holes: Vec<ClHole>,
    /// The end points of feed moves from nowhere (the file's first move at feed): postpro comes
    /// to them across at the clearance and down at the feed, a move the CL file does not have.
    pub(crate) approaches: Vec<[f64; 3]>,
    /// The tools, `(number, length mm, diameter mm)` for rs274's tool table (length 100 mm where
    /// the file gives none: the canonical positions are the tool tip's, whatever the length).
    pub(crate) tools: Vec<(u32, f64, f64)>,
}

/// The name of a file under `../shared/data`, or its path as given.
pub(crate) fn data_name(path: &Path) -> String {
    let data = tests::shared_cl_dir().parent().map(Path::to_path_buf).unwrap_or_default();
    let path = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    let data = data.canonicalize().unwrap_or(data);
    path.strip_prefix(&data).unwrap_or(&path).to_string_lossy().replace('\\', "/")
}

/// Reads a CL file with our reader (which must read it without errors).
pub(crate) fn read_cl(file: &Path, options: &ReadOptions) -> Cl {
    let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let name = data_name(file);
    let source = Source::new(name.clone(), text);
    let path = postpro_cl::read_with(&source, options);
    let errors: Vec<String> = path.diagnostics.iter().filter(|d| d.is_error()).map(|d| d.message.clone()).collect();
    assert!(errors.is_empty(), "{name} does not read: {errors:?}");
    let line = |span: postpro_cl::Span| source.line_col(span.start as usize).line;
    let mut cl = Cl {
        name,
        path: ToolPath::default(),
        length: 0.0,
        points: Vec::new(),
        arcs: Vec::new(),
        holes: Vec::new(),
        approaches: Vec::new(),
        tools: Vec::new(),
    };
    let mut at: Option<nalgebra::Point3<f64>> = None;
    let mut cycle: Option<(postpro_cl::Cycle, usize)> = None;
    let mut diameter = 10.0;
    for item in &path.items {
        match &item.kind {
            ItemKind::Move(m) => {
                match (m.kind, m.motion, at) {
                    (MoveKind::Hole, _, _) => {
                        if let Some((c, cycle_line)) = &cycle {
                            cl.holes.push(ClHole {
                                top: m.to.into(),
                                depth: c.depth,
                                clearance: c.clearance,
                                axis: m.axis.into_inner().into(),
                                line: *cycle_line,
                                goto_line: line(item.span),
                            });
                        }
                    }
                    (MoveKind::From, _, _) | (_, ClMotion::Rapid, _) => {}
                    (_, _, None) => cl.approaches.push(m.to.into()),
                    (_, _, Some(from)) => {
                        cl.length += (m.to - from).norm();
                        cl.points.push(m.to.into());
                    }
                }
                at = Some(m.to);
            }
            ItemKind::Arc(a) => {
                if a.motion != ClMotion::Rapid {
                    cl.length += a.length();
                    for t in [0.25, 0.5, 0.75] {
                        cl.points.push(a.point_at(t).into());
                    }
                    cl.points.push(a.end.into());
                    cl.arcs.push(ClArc {
                        end: a.end.into(),
                        normal: a.normal.into_inner().into(),
                        sweep: a.sweep,
                        line: line(item.span),
                    });
                }
                at = Some(a.end);
            }
            ItemKind::CycleOn(c) => cycle = Some(((**c).clone(), line(item.span))),
            ItemKind::CycleOff => cycle = None,
            ItemKind::ToolShape(s) => diameter = s.diameter.max(0.1),
            ItemKind::ToolChange(t) if !cl.tools.iter().any(|(n, _, _)| *n == t.number) => {
                cl.tools.push((t.number, 100.0, diameter));
            }
            _ => {}
        }
    }
    cl.path = path;
    cl
}

/// The lines of a G-code program (LinuxCNC, Fanuc) that run in a canned cycle: from a block
/// with G73 or G81…G89 to the G80 (or another motion code) that cancels it.
pub(crate) fn cycle_lines(text: &str) -> BTreeSet<usize> {
    let mut lines = BTreeSet::new();
    let mut in_cycle = false;
    for (i, line) in text.lines().enumerate() {
        let code = line.split(['(', ';']).next().unwrap_or("");
        let g: Vec<&str> = code.split_whitespace().filter(|w| w.starts_with('G')).collect();
        if g.iter().any(|w| matches!(*w, "G73" | "G81" | "G82" | "G83" | "G84" | "G85" | "G86" | "G89")) {
            in_cycle = true;
        } else if g.iter().any(|w| matches!(*w, "G80" | "G0" | "G1" | "G2" | "G3")) {
            in_cycle = false;
        }
        if in_cycle {
            lines.insert(i + 1);
        }
    }
    lines
}

/// The program's motions but those of its canned cycles and its approaches at feed to the CL
/// file's moves from nowhere (the first straight feed motion ending at each, within `within`).
pub(crate) fn cl_motions(program: &Program, text: &str, cl: &Cl, within: f64) -> Vec<Motion> {
    let cycles = cycle_lines(text);
    let mut approaches = cl.approaches.clone();
    let mut motions = Vec::with_capacity(program.motions.len());
    for m in program.motions.iter().filter(|m| !cycles.contains(&m.line)) {
        let straight_feed = m.is_feed() && m.arc().is_none();
        let gap = |p: &[f64; 3]| (0..3).map(|k| (p[k] - m.to[k]).abs()).fold(0.0, f64::max);
        if let Some(k) = approaches.iter().position(|p| straight_feed && gap(p) <= within) {
            approaches.remove(k);
            continue;
        }
        motions.push(*m);
    }
    motions
}

/// The arcs of a program by plane (XY, ZX, YZ) and how many of them make full turns on top.
pub(crate) fn arc_counts(motions: &[Motion]) -> ([usize; 3], usize) {
    let mut planes = [0; 3];
    let mut turning = 0;
    for arc in motions.iter().filter_map(Motion::arc) {
        planes[match arc.plane {
            Plane::Xy => 0,
            Plane::Zx => 1,
            Plane::Yz => 2,
        }] += 1;
        turning += usize::from(arc.full_turns > 0);
    }
    (planes, turning)
}

/// Half a unit of the last decimal the program writes its X words with, as a distance in space
/// (three axes rounded at once), in program units.
pub(crate) fn rounding(text: &str) -> f64 {
    let decimals = text
        .lines()
        .flat_map(|l| l.split(['(', ';']).next().unwrap_or("").split_whitespace())
        .filter_map(|w| w.strip_prefix('X'))
        .filter_map(|v| v.split_once('.').map(|(_, f)| f.len()))
        .max()
        .unwrap_or(0);
    0.5 * 10f64.powi(-(decimals as i32)) * 3f64.sqrt()
}

/// The CL point farthest from a feed path, and how far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Off {
    /// The distance to the nearest feed motion.
    pub(crate) distance: f64,
    /// The point's index.
    pub(crate) point: usize,
    /// The program line of that motion.
    pub(crate) line: Option<usize>,
}

/// The largest distance from `points` (the CL file's, in path order) to the feed motions of
/// `motions`, exact for every point farther than `allowed`.
///
/// The points are walked with a cursor on the motions as `tests::compare` walks them (from
/// [`WINDOW`] before the previous point's motion to [`WINDOW`] past the best; at an equal
/// distance not back), and where the window holds no motion within `allowed` every feed motion
/// is searched and the walk goes on from the nearest: a path that comes back near a place it
/// passed before (a pass of a roughing cycle a step deeper, a retract at the same X Y) cannot
/// lose the walk, and no point is reported farther than it is.
pub(crate) fn farthest_point(points: &[[f64; 3]], motions: &[Motion], allowed: f64) -> Option<Off> {
    let feeds: Vec<&Motion> = motions.iter().filter(|m| m.is_feed()).collect();
    let nearer = |(k, d): (usize, f64), best: (usize, f64), cursor: usize| {
        d < best.1 || (d == best.1 && best.0 < cursor && k >= cursor)
    };
    let mut cursor: usize = 0;
    let mut farthest: Option<Off> = None;
    for (i, &p) in points.iter().enumerate() {
        let start = cursor.saturating_sub(WINDOW);
        let mut best = (start, f64::INFINITY);
        for (k, motion) in feeds.iter().enumerate().skip(start) {
            let d = motion.distance_to_point(p);
            if nearer((k, d), best, cursor) {
                best = (k, d);
            }
            if k >= cursor + WINDOW && k - best.0 >= WINDOW {
                break;
            }
        }
        if best.1 > allowed {
            for (k, motion) in feeds.iter().enumerate() {
                let d = motion.distance_to_point(p);
                if nearer((k, d), best, cursor) {
                    best = (k, d);
                }
            }
        }
        cursor = best.0;
        if farthest.is_none_or(|f| best.1 > f.distance) {
            farthest = Some(Off { distance: best.1, point: i, line: feeds.get(best.0).map(|m| m.line) });
        }
    }
    farthest
}

/// The solved position (X, Y, Z of the linear axes, mm, in the program's frame) of the CL point
/// on each CL line: `postpro solve FILE --machine MACHINE --csv`, its `cl` rows.
pub(crate) fn solved_positions(cl: &Path, machine: &str) -> std::collections::BTreeMap<usize, [f64; 3]> {
    let file = cl.to_string_lossy();
    let o = postpro(&["solve", &file, "--machine", machine, "--csv"], &repo());
    assert!(o.status.success(), "postpro solve {file} --machine {machine}: {}", stderr(&o));
    let csv = String::from_utf8_lossy(&o.stdout).into_owned();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a CSV header").split(',').collect();
    let column =
        |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no {name} in {header:?}"));
    let (line, kind, x, y, z) = (column("line"), column("kind"), column("X_mm"), column("Y_mm"), column("Z_mm"));
    let mut positions = std::collections::BTreeMap::new();
    for row in lines {
        let f: Vec<&str> = row.split(',').collect();
        if f[kind] == "cl" {
            let value = |k: usize| f[k].parse::<f64>().unwrap_or_else(|_| panic!("`{row}`"));
            positions.entry(f[line].parse().expect("a line")).or_insert([value(x), value(y), value(z)]);
        }
    }
    positions
}

/// The Python with the PyPI package nc-gcode-interpreter: `POSTPRO_NC_PYTHON`, else where `.ci/run
/// interpreters` installs it, else `python3`; `None` with a "skipped" line when none has it (a
/// failure under CI).
pub(crate) fn nc_python() -> Option<PathBuf> {
    let works = |p: &Path| {
        std::process::Command::new(p)
            .args(["-c", "import nc_gcode_interpreter"])
            .stdin(std::process::Stdio::null())
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if let Some(path) = std::env::var_os("POSTPRO_NC_PYTHON").filter(|v| !v.is_empty()) {
        let path = PathBuf::from(path);
        assert!(works(&path), "POSTPRO_NC_PYTHON={} has no nc_gcode_interpreter", path.display());
        return Some(path);
    }
    let mut candidates: Vec<PathBuf> = tests::ci_tools().map(|t| t.join("venv/bin/python")).into_iter().collect();
    candidates.push(PathBuf::from("python3"));
    if let Some(found) = candidates.into_iter().find(|p| works(p)) {
        return Some(found);
    }
    let hint = "run `bash .ci/run interpreters`, or set POSTPRO_NC_PYTHON";
    assert!(
        std::env::var_os("CI").is_none_or(|v| v.is_empty()),
        "nc-gcode-interpreter is not installed, and CI must validate the programs: {hint}"
    );
    let _ = std::io::Write::write_fmt(
        &mut std::io::stderr(),
        format_args!("skipped: nc-gcode-interpreter not installed ({hint})\n"),
    );
    None
}

/// What nc-gcode-interpreter makes of a Siemens program (`tests/interpreters/siemens.py`): per
/// program line, the values of the axes `axes` names after it (`None` before an axis has one).
pub(crate) fn siemens_rows(python: &Path, program: &Path, axes: &str) -> Result<Vec<Vec<Option<f64>>>, String> {
    let table = siemens_table(python, program, axes)?;
    Ok(table.iter().map(|row| axes.chars().map(|a| row.values.get(&a).copied()).collect()).collect())
}

/// nc-gcode-interpreter's table of a Siemens program (`tests/interpreters/siemens.py`), as the
/// harness's Siemens reader takes it (`tests::golden::siemens`): per program line, its motion
/// mode, the F it programs, the axes it programs, and the values of the axes `axes` names (one
/// letter each; `I`, `J`, `K` for arc centres) after it. An error is the interpreter's message.
pub(crate) fn siemens_table(python: &Path, program: &Path, axes: &str) -> Result<Vec<siemens::Row>, String> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/interpreters/siemens.py");
    let o = std::process::Command::new(python)
        .arg(&script)
        .arg(program)
        .arg(axes)
        .stdin(std::process::Stdio::null())
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    if !o.status.success() {
        return Err(format!(
            "nc-gcode-interpreter rejected {}: {}",
            program.display(),
            String::from_utf8_lossy(&o.stderr).trim()
        ));
    }
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    // Columns: row, motion, feed type, F, the axes programmed, then the axes' values.
    let letters: Vec<char> = axes.chars().collect();
    Ok(stdout
        .lines()
        .skip(1)
        .map(|row| {
            let f: Vec<&str> = row.split(',').collect();
            let field = |k: usize| f.get(k).copied().unwrap_or("");
            siemens::Row {
                motion: Some(field(1)).filter(|m| !m.is_empty()).map(str::to_string),
                feed: field(3).parse().ok(),
                programmed: field(4).to_string(),
                values: letters
                    .iter()
                    .enumerate()
                    .filter_map(|(k, &a)| field(5 + k).parse::<f64>().ok().map(|v| (a, v)))
                    .collect(),
            }
        })
        .collect())
}
