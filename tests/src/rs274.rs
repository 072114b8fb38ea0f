//! Back-simulation with LinuxCNC's standalone G-code interpreter, `rs274`: it reads a program as
//! the controller does and prints the canonical machining calls it makes; this module runs it
//! and reads those calls into a [`Program`].
//!
//! What was established by running it (the unit tests below pin each point):
//!
//! - `STRAIGHT_TRAVERSE(x, y, z, a, b, c)` and `STRAIGHT_FEED(…)` give the end point in the work
//!   frame of the tool tip (work offset and tool length offset taken out), in the program's
//!   current units, four decimals.
//! - `ARC_FEED(first_end, second_end, first_centre, second_centre, rotation, axis_end, a, b, c)`:
//!   for `SELECT_PLANE(CANON_PLANE_XY)` first/second/axis are X/Y/Z, for `…_XZ` (G18) Z/X/Y, for
//!   `…_YZ` (G19) Y/Z/X. `rotation` > 0 turns counter-clockwise about first × second (+Z, +Y,
//!   +X: G3), < 0 clockwise (G2); |rotation| − 1 full turns come on top (`P`). A start equal to
//!   the end is a full circle. The lengths rs274 gives inverse-time arcs agree (`nc` tests).
//! - `SET_FEED_RATE(f)` is units per minute, also in G93: the interpreter turns inverse-time `F`
//!   into the rate of each block (a `COMMENT("interpreter: feed mode set to …")` says the mode).
//! - Canned cycles (G73, G81–G89) come expanded into traverses, feeds and `DWELL`s.
//! - `SELECT_TOOL(n)` names the tool; `CHANGE_TOOL(k)` gives its slot in the table, not its
//!   number. `USE_TOOL_LENGTH_OFFSET(x y z, a b c, u v w)` gives the offset applied;
//!   `SET_G5X_OFFSET(k, x, y, z, a, b, c)` the work offset k (1 = G54 … 9 = G59.3).
//! - The standalone `rs274` reads its tool table in inches: `Z10` is a 254 mm tool.
//! - It keeps the tool table in a file shared by every process, `$HOME/.tool.mmap`: two runs at
//!   once read each other's tools or die of SIGBUS. Each run here has a `HOME` of its own.
//! - On an error it exits with code 1 and prints the message, then the offending block, on
//!   standard error. It prints an `N` column with the block's `N` word: the program is run as a
//!   copy in which every block's `N` word is its line number, so that every call and every error
//!   names its line.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::Error;
use crate::nc::{Arc, Event, EventKind, Motion, MotionKind, Plane, Program, Rotary, Units};

/// The standalone `rs274` found on this machine.
#[derive(Clone, Debug)]
pub struct Rs274 {
    path: PathBuf,
}

impl Rs274 {
    /// `POSTPRO_RS274` when set (an error if it does not run), else where `.ci/run interpreters`
    /// installs it (`$POSTPRO_CI_TOOLS` or `~/.cache/postpro-ci`, then `linuxcnc/rs274`), else
    /// `rs274` on the `PATH`; each candidate checked by running a two-line program. `None` when
    /// none runs.
    pub fn find() -> Result<Option<Rs274>, Error> {
        if let Some(path) = std::env::var_os("POSTPRO_RS274").filter(|v| !v.is_empty()) {
            let rs274 = Rs274 { path: PathBuf::from(path) };
            rs274.run_text("probe.ngc", "G0 X1\nM2\n", &[])?;
            return Ok(Some(rs274));
        }
        let mut candidates: Vec<PathBuf> = crate::ci_tools().map(|t| t.join("linuxcnc/rs274")).into_iter().collect();
        candidates.push(PathBuf::from("rs274"));
        Ok(candidates
            .into_iter()
            .map(|path| Rs274 { path })
            .find(|r| r.run_text("probe.ngc", "G0 X1\nM2\n", &[]).is_ok()))
    }

    /// [`Rs274::find`] for a test: `None` with a "skipped" line on standard error when rs274 is
    /// not installed, a panic under CI (the variable `CI` set), where the programs must be
    /// validated.
    ///
    /// # Panics
    /// Under CI when rs274 is missing, and when `POSTPRO_RS274` names something that does not run.
    pub fn for_test() -> Option<Rs274> {
        static FOUND: OnceLock<Result<Option<Rs274>, String>> = OnceLock::new();
        match FOUND.get_or_init(|| Rs274::find().map_err(|e| e.to_string())).clone() {
            Ok(Some(rs274)) => Some(rs274),
            Ok(None) => {
                let hint =
                    "run `bash .ci/run interpreters`, which installs it in ~/.cache/postpro-ci, or set POSTPRO_RS274";
                let ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty());
                assert!(!ci, "rs274 is not installed, and CI must validate the programs: {hint}");
                let _ = writeln!(std::io::stderr(), "skipped: rs274 not installed ({hint})");
                None
            }
            Err(e) => panic!("POSTPRO_RS274 does not run rs274: {e}"),
        }
    }

    /// The interpreter's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Runs the program in `file` with a tool table of `tools` ([`tool_table`]) and reads its
    /// canonical calls.
    pub fn run(&self, file: &Path, tools: &[(u32, f64, f64)]) -> Result<Program, Error> {
        let text = std::fs::read_to_string(file).map_err(Error::io(file))?;
        self.run_text(&file.display().to_string(), &text, tools)
    }

    /// Runs the program `text` (named `name` in errors) with a tool table of `tools` and reads
    /// its canonical calls. An error of rs274 is an [`Error::Rs274`] with its message and line;
    /// a program that does not reach `M2`/`M30` is one too.
    pub fn run_text(&self, name: &str, text: &str, tools: &[(u32, f64, f64)]) -> Result<Program, Error> {
        static RUNS: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "postpro-rs274-{}-{}",
            std::process::id(),
            RUNS.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir).map_err(Error::io(&dir))?;
        let outcome = self.run_in(&dir, name, text, tools);
        let _ = std::fs::remove_dir_all(&dir);
        outcome
    }

    fn run_in(&self, dir: &Path, name: &str, text: &str, tools: &[(u32, f64, f64)]) -> Result<Program, Error> {
        let program = dir.join("program.ngc");
        let table = dir.join("tool.tbl");
        std::fs::write(&program, numbered(text)).map_err(Error::io(&program))?;
        std::fs::write(&table, tool_table(tools)).map_err(Error::io(&table))?;
        // rs274 shares its tool table with other processes through `$HOME/.tool.mmap`, and keeps
        // its parameters in the working folder: both private to this run, or concurrent runs
        // read each other's tools (or die of SIGBUS when another truncates the file).
        let out = Command::new(&self.path)
            .env("HOME", dir)
            .current_dir(dir)
            .arg("-g")
            .arg("-t")
            .arg(&table)
            .arg(&program)
            .stdin(Stdio::null())
            .output()
            .map_err(Error::io(&self.path))?;
        let lines: Vec<&str> = text.lines().collect();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let said: Vec<&str> = stderr.lines().map(str::trim).filter(|l| !l.is_empty() && *l != "executing").collect();
        if !out.status.success() || !said.is_empty() {
            // The last line repeats the offending block, with the N word we gave it.
            let line = said.last().and_then(|l| block_number(l)).filter(|&n| n >= 1 && n <= lines.len());
            let message: Vec<&str> = if line.is_some() { said[..said.len() - 1].to_vec() } else { said };
            let message = if message.is_empty() { format!("exit status {}", out.status) } else { message.join(" / ") };
            return Err(Error::Rs274 {
                file: name.to_string(),
                line,
                text: line.map(|n| lines[n - 1].trim().to_string()),
                message,
            });
        }
        read_canon(name, &String::from_utf8_lossy(&out.stdout))
    }
}

/// A LinuxCNC tool table for the standalone `rs274` from `(number, length, diameter)` in
/// millimetres, written in inches (which is how the standalone interpreter reads it), one tool
/// per line with its pocket equal to its number. Tool 0 is LinuxCNC's "no tool" and is left out.
pub fn tool_table(tools: &[(u32, f64, f64)]) -> String {
    let mut table =
        String::from(";LinuxCNC tool table written by the postpro test harness, in inches (rs274 reads it so)\n");
    for &(number, length, diameter) in tools.iter().filter(|t| t.0 != 0) {
        table.push_str(&format!(
            "T{number} P{number} Z{} D{} ;length {length} mm, diameter {diameter} mm\n",
            length / 25.4,
            diameter / 25.4
        ));
    }
    table
}

/// The program with every block's `N` word set to its 1-based line number (an existing `N`
/// word replaced; blank lines and `%` lines left as they are; a block-delete `/` kept first).
fn numbered(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + text.len() / 4);
    for (i, line) in text.lines().enumerate() {
        let body = line.trim_start();
        if body.is_empty() || body.starts_with('%') {
            out.push_str(line);
        } else {
            let (slash, rest) = match body.strip_prefix('/') {
                Some(rest) => ("/", rest.trim_start()),
                None => ("", body),
            };
            let rest = match rest.strip_prefix(['N', 'n']) {
                Some(after) if after.trim_start().starts_with(|c: char| c.is_ascii_digit()) => {
                    after.trim_start().trim_start_matches(|c: char| c.is_ascii_digit() || c == '.').trim_start()
                }
                _ => rest,
            };
            out.push_str(&format!("{slash}N{} {rest}", i + 1));
        }
        out.push('\n');
    }
    out
}

/// The number of a leading `N` word.
fn block_number(block: &str) -> Option<usize> {
    let rest = block.trim_start().trim_start_matches('/').strip_prefix(['N', 'n'])?;
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    digits.parse().ok()
}

/// Reads rs274's canonical calls (its standard output, run with `-g`) into a program: the
/// motions, with positions in the units of the first motion (later units converted), and the
/// events. `name` names the program in errors.
pub fn read_canon(name: &str, canon: &str) -> Result<Program, Error> {
    let mut state = Canon::new(name);
    for row in canon.lines() {
        let Some((line, call)) = split_row(row) else { continue };
        state.call(line, call)?;
    }
    state.finish()
}

/// One output row: `%5d N<digits or .....><padding><call>` → (line, call).
fn split_row(row: &str) -> Option<(usize, &str)> {
    let rest = row.trim_start().trim_start_matches(|c: char| c.is_ascii_digit()).trim_start();
    let rest = rest.strip_prefix('N')?;
    if let Some(call) = rest.strip_prefix(".....") {
        return Some((0, call.trim_start()));
    }
    let digits = rest.len() - rest.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    Some((rest[..digits].parse().ok()?, rest[digits..].trim_start()))
}

/// The interpreter's state as the calls change it, in the current units.
struct Canon<'a> {
    name: &'a str,
    units: Units,
    /// The units of the first motion: the program's.
    program_units: Option<Units>,
    plane: Plane,
    feed: f64,
    per_revolution: bool,
    /// X, Y, Z, A, B, C in the work frame.
    position: [f64; 6],
    /// The G5x origin, the G92 offset and the tool length offset, X Y Z A B C.
    offsets: [[f64; 6]; 3],
    selected_tool: Option<u32>,
    ended: bool,
    /// Each in the units current when it was made.
    motions: Vec<(Motion, Units)>,
    events: Vec<(Event, Units)>,
}

const G5X: usize = 0;
const G92: usize = 1;
const TOOL: usize = 2;

impl<'a> Canon<'a> {
    fn new(name: &'a str) -> Canon<'a> {
        Canon {
            name,
            units: Units::Mm,
            program_units: None,
            plane: Plane::Xy,
            feed: 0.0,
            per_revolution: false,
            position: [0.0; 6],
            offsets: [[0.0; 6]; 3],
            selected_tool: None,
            ended: false,
            motions: Vec::new(),
            events: Vec::new(),
        }
    }

    fn error(&self, line: usize, call: &str, message: impl Into<String>) -> Error {
        Error::Canon { file: self.name.to_string(), line, call: call.to_string(), message: message.into() }
    }

    fn event(&mut self, line: usize, kind: EventKind) {
        self.events.push((Event { line, before: self.motions.len(), kind }, self.units));
    }

    /// An offset replaced: the tool stays where it is, so its work-frame position moves the
    /// other way.
    fn set_offset(&mut self, which: usize, value: [f64; 6]) {
        for (k, v) in value.iter().enumerate() {
            self.position[k] -= v - self.offsets[which][k];
        }
        self.offsets[which] = value;
    }

    fn call(&mut self, line: usize, call: &str) -> Result<(), Error> {
        let (function, arguments) = call.split_once('(').unwrap_or((call, ""));
        let arguments = arguments.strip_suffix(')').unwrap_or(arguments);
        let numbers = |n: usize| -> Result<Vec<f64>, Error> {
            let values: Vec<f64> = arguments
                .split([',', ' '])
                .filter(|s| !s.is_empty())
                .map(|s| s.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| self.error(line, call, "expected numbers"))?;
            if values.len() < n {
                return Err(self.error(line, call, format!("expected {n} numbers")));
            }
            Ok(values)
        };
        match function {
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" => {
                let v = numbers(6)?;
                let rapid = function == "STRAIGHT_TRAVERSE";
                let kind = if rapid { MotionKind::Rapid } else { MotionKind::Feed };
                self.motion(line, call, kind, [v[0], v[1], v[2], v[3], v[4], v[5]])?;
            }
            "ARC_FEED" => {
                let v = numbers(9)?;
                let rotation = v[4];
                if rotation == 0.0 || rotation.fract() != 0.0 {
                    return Err(self.error(line, call, "expected a non-zero whole rotation"));
                }
                let [first, second, normal] = self.plane.axes();
                let mut to = [0.0; 6];
                to[first] = v[0];
                to[second] = v[1];
                to[normal] = v[5];
                to[3..].copy_from_slice(&v[6..9]);
                let mut center = [0.0; 3];
                center[first] = v[2];
                center[second] = v[3];
                center[normal] = self.position[normal];
                let arc = Arc {
                    center,
                    plane: self.plane,
                    clockwise: rotation < 0.0,
                    full_turns: (rotation.abs() - 1.0) as u32,
                };
                self.motion(line, call, MotionKind::Arc(arc), to)?;
            }
            "SET_FEED_RATE" => self.feed = numbers(1)?[0],
            "USE_LENGTH_UNITS" => {
                let units = match arguments {
                    "CANON_UNITS_MM" => Units::Mm,
                    "CANON_UNITS_INCHES" => Units::Inch,
                    _ => return Err(self.error(line, call, "expected millimetres or inches")),
                };
                let factor = self.units.factor(units);
                for k in 0..3 {
                    self.position[k] *= factor;
                    for offset in &mut self.offsets {
                        offset[k] *= factor;
                    }
                }
                self.feed *= factor;
                self.units = units;
            }
            "SELECT_PLANE" => {
                self.plane = match arguments {
                    "CANON_PLANE_XY" => Plane::Xy,
                    "CANON_PLANE_XZ" => Plane::Zx,
                    "CANON_PLANE_YZ" => Plane::Yz,
                    _ => return Err(self.error(line, call, "the UVW planes are not modelled")),
                };
                self.event(line, EventKind::Plane(self.plane));
            }
            "SELECT_TOOL" => self.selected_tool = Some(numbers(1)?[0] as u32),
            "CHANGE_TOOL" => {
                let tool =
                    self.selected_tool.ok_or_else(|| self.error(line, call, "a tool change without SELECT_TOOL"))?;
                self.event(line, EventKind::ToolChange { tool });
            }
            "USE_TOOL_LENGTH_OFFSET" => {
                let v = numbers(6)?;
                self.set_offset(TOOL, [v[0], v[1], v[2], v[3], v[4], v[5]]);
                self.event(line, EventKind::LengthOffset { register: None, offset: Some([v[0], v[1], v[2]]) });
            }
            "SET_G5X_OFFSET" => {
                let v = numbers(7)?;
                self.set_offset(G5X, [v[1], v[2], v[3], v[4], v[5], v[6]]);
                let name = match v[0] as usize {
                    k @ 1..=6 => format!("G{}", 53 + k),
                    k @ 7..=9 => format!("G59.{}", k - 6),
                    k => format!("G5x {k}"),
                };
                self.event(line, EventKind::WorkOffset { name, offset: Some([Some(v[1]), Some(v[2]), Some(v[3])]) });
            }
            "SET_G92_OFFSET" => {
                let v = numbers(6)?;
                self.set_offset(G92, [v[0], v[1], v[2], v[3], v[4], v[5]]);
                let offset = Some([Some(v[0]), Some(v[1]), Some(v[2])]);
                self.event(line, EventKind::WorkOffset { name: "G92".to_string(), offset });
            }
            "SET_XY_ROTATION" if numbers(1)?[0] != 0.0 => {
                return Err(self.error(line, call, "a rotated coordinate system (G10 L2 R) is not modelled"));
            }
            "DWELL" => {
                let seconds = numbers(1)?[0];
                self.event(line, EventKind::Dwell { seconds });
            }
            "COMMENT" => {
                if let Some(mode) = arguments.strip_prefix("\"interpreter: feed mode set to ") {
                    self.per_revolution = mode.starts_with("units per revolution");
                    self.event(line, EventKind::InverseTime(mode.starts_with("inverse time")));
                }
            }
            "PROGRAM_STOP" => self.event(line, EventKind::Stop { optional: false }),
            "OPTIONAL_PROGRAM_STOP" => self.event(line, EventKind::Stop { optional: true }),
            "PROGRAM_END" => {
                self.ended = true;
                self.event(line, EventKind::End);
            }
            f if f.contains("PROBE") || f.contains("TAP") || f.contains("NURBS") || f.contains("SPLINE") => {
                return Err(self.error(line, call, "a motion the harness does not model"));
            }
            f if f.ends_with("_FEED") || f.ends_with("_TRAVERSE") => {
                return Err(self.error(line, call, "a motion the harness does not read"));
            }
            // Spindle, coolant, overrides, path-control modes, messages: no motion.
            _ => {}
        }
        Ok(())
    }

    fn motion(&mut self, line: usize, call: &str, kind: MotionKind, to: [f64; 6]) -> Result<(), Error> {
        let rapid = matches!(kind, MotionKind::Rapid);
        if !rapid && self.per_revolution {
            return Err(self.error(line, call, "feeds per revolution (G95) are not modelled"));
        }
        let motion = Motion {
            kind,
            from: [self.position[0], self.position[1], self.position[2]],
            from_known: true,
            to: [to[0], to[1], to[2]],
            rotary: Rotary { a: Some(to[3]), b: Some(to[4]), c: Some(to[5]) },
            vector: None,
            feed: if rapid { None } else { Some(self.feed) },
            line,
        };
        self.position = to;
        self.program_units.get_or_insert(self.units);
        self.motions.push((motion, self.units));
        Ok(())
    }

    fn finish(self) -> Result<Program, Error> {
        if !self.ended {
            return Err(Error::Rs274 {
                file: self.name.to_string(),
                line: None,
                text: None,
                message: "the program did not reach its end (M2 or M30)".to_string(),
            });
        }
        let units = self.program_units.unwrap_or(self.units);
        let motions = self.motions.into_iter().map(|(m, u)| m.scaled(u.factor(units))).collect();
        let events = self.events.into_iter().map(|(e, u)| e.scaled(u.factor(units))).collect();
        Ok(Program { name: self.name.to_string(), units, motions, events })
    }
}

#[cfg(test)]
mod tests;
