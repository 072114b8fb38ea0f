//! Readers of the NC programs other posts wrote, and the pairs of CL file and program they came
//! with (`../shared/data/peers`): the golden references of the comparators in
//! [`crate::compare`]. They read our programs in the same dialects too.
//!
//! - [`fanuc`]: Fanuc/Haas G-code, as Siemens NX's own Haas UMC-750 post writes it
//!   (`userFour__MECH491-postprocessor/*/expected/`).
//! - [`heidenhain`]: Heidenhain conversational (Klartext), as clsplit writes it
//!   (`aamorim1913__AptPostProcessor/*/*/expected/*.h`).
//! - [`siemens`]: Siemens 840D as postpro writes it, the positions from nc-gcode-interpreter's
//!   table (no peer writes Siemens programs).
//!
//! Both follow the machine: positions in the work frame, modal values carried, canned cycles
//! expanded into their moves (with a [`EventKind::Hole`] each), machine-frame moves kept as
//! events that leave their axes unknown until programmed again. What they cannot read is an
//! error naming the file, line and column; what they read but do not model (spindle, coolant,
//! clamps, smoothing, comments) is listed in `docs/validation-harness.md`.

pub mod fanuc;
pub mod heidenhain;
pub mod siemens;

use std::path::PathBuf;

use crate::Error;
use crate::nc::{Event, EventKind, Motion, MotionKind, Program, Rotary, Units};

/// A pair from a peer: the CL file another post read and the programs it wrote from it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Case {
    /// The case's folder, relative to `../shared/data/peers`.
    pub name: String,
    /// The CL file.
    pub input: PathBuf,
    /// The programs written from it, sorted.
    pub expected: Vec<PathBuf>,
}

/// The five pairs of NX CLSF and the program Siemens NX's Haas UMC-750 post wrote from it
/// (`userFour__MECH491-postprocessor/<case>/{input,expected}/`).
pub fn nx_haas_cases() -> Vec<Case> {
    cases("userFour__MECH491-postprocessor", 1, |_| true)
}

/// The pairs of SOLIDWORKS CAM `.apt` file and clsplit's Heidenhain programs
/// (`aamorim1913__AptPostProcessor/<year>/<part>/{input,expected}/`): `NN.h` per set-up,
/// `NNsetup.h` with its datum shift, `0TREF.h` the probing program.
pub fn clsplit_cases() -> Vec<Case> {
    cases("aamorim1913__AptPostProcessor", 2, |name| name.ends_with(".apt"))
}

/// The cases `depth` folders below `peers/<peer>`, with the input files `is_input` keeps.
fn cases(peer: &str, depth: usize, is_input: impl Fn(&str) -> bool) -> Vec<Case> {
    let root = crate::shared_peers_dir();
    let mut folders = vec![root.join(peer)];
    for _ in 0..depth {
        folders = folders
            .iter()
            .flat_map(|f| std::fs::read_dir(f).into_iter().flatten().flatten().map(|e| e.path()))
            .filter(|p| p.is_dir())
            .collect();
    }
    let files = |dir: PathBuf| -> Vec<PathBuf> {
        let mut files: Vec<PathBuf> =
            std::fs::read_dir(dir).into_iter().flatten().flatten().map(|e| e.path()).filter(|p| p.is_file()).collect();
        files.sort();
        files
    };
    let mut cases: Vec<Case> = folders
        .into_iter()
        .filter_map(|folder| {
            let input = files(folder.join("input"))
                .into_iter()
                .find(|p| p.file_name().is_some_and(|n| is_input(&n.to_string_lossy())))?;
            let expected = files(folder.join("expected"));
            let name = folder.strip_prefix(&root).unwrap_or(&folder).to_string_lossy().replace('\\', "/");
            (!expected.is_empty()).then_some(Case { name, input, expected })
        })
        .collect();
    cases.sort_by(|a, b| a.name.cmp(&b.name));
    cases
}

/// The state both readers share: the position in the work frame (an axis `None` after a
/// machine-frame move until programmed again), the rotary axes, and the motions and events.
struct Builder {
    file: String,
    /// The program's units, once set.
    units: Option<Units>,
    position: [Option<f64>; 3],
    rotary: Rotary,
    /// The tool vector in force (TCP with vectors), as written.
    vector: Option<[f64; 3]>,
    motions: Vec<Motion>,
    events: Vec<Event>,
}

impl Builder {
    fn new(file: &str) -> Builder {
        Builder {
            file: file.to_string(),
            units: None,
            position: [None; 3],
            rotary: Rotary::default(),
            vector: None,
            motions: Vec::new(),
            events: Vec::new(),
        }
    }

    fn error(&self, line: usize, column: usize, message: impl Into<String>) -> Error {
        Error::Parse { file: self.file.clone(), line, column, message: message.into() }
    }

    fn event(&mut self, line: usize, kind: EventKind) {
        self.events.push(Event { line, before: self.motions.len(), kind });
    }

    /// A move in the machine frame: the axes it moves (0–2 X Y Z, 3–5 A B C) are unknown in
    /// the work frame afterwards.
    fn machine_move(&mut self, line: usize, code: &str, axes: &[usize]) {
        for &k in axes {
            match k {
                0..=2 => self.position[k] = None,
                3 => self.rotary.a = None,
                4 => self.rotary.b = None,
                _ => self.rotary.c = None,
            }
        }
        let axes = axes.iter().map(|&k| ['X', 'Y', 'Z', 'A', 'B', 'C'][k]).collect();
        self.event(line, EventKind::MachineFrameMove { code: code.to_string(), axes });
    }

    /// A straight move or an arc to `target`. A move whose end is not fully known, or a feed
    /// from a start not fully known, is kept as a [`EventKind::Positioning`]; a rapid from a
    /// start not fully known to a known end is a motion with `from_known` false.
    fn move_to(
        &mut self,
        line: usize,
        kind: MotionKind,
        target: [Option<f64>; 3],
        feed: Option<f64>,
    ) -> Result<(), String> {
        let rapid = matches!(kind, MotionKind::Rapid);
        let start_known = self.position.iter().all(Option::is_some);
        let (Some(x), Some(y), Some(z)) = (target[0], target[1], target[2]) else {
            self.position = target;
            self.event(line, EventKind::Positioning { rapid, to: target });
            return Ok(());
        };
        if !rapid && !start_known {
            self.position = target;
            self.event(line, EventKind::Positioning { rapid, to: target });
            return Ok(());
        }
        let to = [x, y, z];
        let from = [0, 1, 2].map(|k| self.position[k].unwrap_or(to[k]));
        let feed = if rapid { None } else { Some(feed.ok_or("a feed move without a feed rate (no F yet)")?) };
        let motion =
            Motion { kind, from, from_known: start_known, to, rotary: self.rotary, vector: self.vector, feed, line };
        self.motions.push(motion);
        self.position = target;
        Ok(())
    }

    fn finish(self) -> Result<Program, Error> {
        let units = self.units.ok_or_else(|| self.error(1, 1, "no units: expected G20/G21 or BEGIN PGM … MM|INCH"))?;
        Ok(Program { name: self.file, units, motions: self.motions, events: self.events })
    }
}

/// What a drilling cycle does at one hole, along Z (the tool axis), in program units: the
/// reader of each dialect turns its cycle into this, [`Builder::drill`] into moves.
#[derive(Clone, Debug, PartialEq)]
struct Drill {
    /// The cycle's name, for the [`EventKind::Hole`].
    cycle: String,
    /// Where the feed starts (R plane, set-up clearance), reached at rapid.
    start: f64,
    /// The bottom.
    bottom: f64,
    /// Feed into the hole.
    feed: f64,
    /// The depths below `start` at which each peck ends, the last being the bottom; one entry
    /// without pecking.
    pecks: Vec<f64>,
    /// After each peck but the last.
    between: Between,
    /// Dwell at the bottom, seconds.
    dwell: Option<f64>,
    /// Out of the hole to `start` at this feed, else straight to `retract` at rapid.
    feed_out: Option<f64>,
    /// Where the tool goes last, at rapid (initial level, 2nd set-up clearance); not below
    /// `start`.
    retract: f64,
}

/// What a pecking cycle does between pecks.
#[derive(Clone, Debug, PartialEq)]
enum Between {
    /// Nothing: no pecking.
    None,
    /// Back by `break_distance` at rapid (chip breaking) `chip_breaks` times, then out to the
    /// start (at rapid, or at `retract_feed`) and at rapid back in to `clearance` above the
    /// depth reached; and again.
    Pecking {
        /// Above the depth reached, after a full retract.
        clearance: f64,
        /// The feed of the full retract; rapid when `None`.
        retract_feed: Option<f64>,
        /// Chip breaks before each full retract (`usize::MAX`: never a full retract).
        chip_breaks: usize,
        /// How far a chip break backs off.
        break_distance: f64,
    },
}

impl Between {
    /// Full retract after every peck (G83, TNC cycles 1 and 200).
    fn full_retract(clearance: f64) -> Between {
        Between::Pecking { clearance, retract_feed: None, chip_breaks: 0, break_distance: 0.0 }
    }

    /// Chip breaking after every peck, never a full retract (G73).
    fn chip_break(distance: f64) -> Between {
        Between::Pecking { clearance: 0.0, retract_feed: None, chip_breaks: usize::MAX, break_distance: distance }
    }
}

impl Builder {
    /// Drills one hole at the current X Y: rapid to the start height, the pecks, the dwell, out.
    fn drill(&mut self, line: usize, drill: &Drill) -> Result<(), String> {
        let [Some(x), Some(y), Some(_)] = self.position else {
            return Err("a hole at a position not known in the work frame".to_string());
        };
        self.event(line, EventKind::Hole { cycle: drill.cycle.clone(), at: [x, y, drill.start], bottom: drill.bottom });
        let at = |z: f64| [Some(x), Some(y), Some(z)];
        self.rapid_along_z(line, drill.start)?;
        let mut breaks = 0;
        for (i, &depth) in drill.pecks.iter().enumerate() {
            self.move_to(line, MotionKind::Feed, at(depth), Some(drill.feed))?;
            if i + 1 == drill.pecks.len() {
                break;
            }
            let Between::Pecking { clearance, retract_feed, chip_breaks, break_distance } = drill.between else {
                continue;
            };
            if breaks < chip_breaks {
                breaks += 1;
                self.rapid_along_z(line, depth + break_distance)?;
                continue;
            }
            breaks = 0;
            match retract_feed {
                Some(feed) => self.move_to(line, MotionKind::Feed, at(drill.start), Some(feed))?,
                None => self.rapid_along_z(line, drill.start)?,
            }
            self.rapid_along_z(line, depth + clearance)?;
        }
        if let Some(seconds) = drill.dwell {
            self.event(line, EventKind::Dwell { seconds });
        }
        if let Some(feed) = drill.feed_out {
            self.move_to(line, MotionKind::Feed, at(drill.start), Some(feed))?;
        }
        self.rapid_along_z(line, drill.retract)
    }

    /// A rapid along Z to `z`, unless the tool is there.
    fn rapid_along_z(&mut self, line: usize, z: f64) -> Result<(), String> {
        if self.position[2] == Some(z) {
            return Ok(());
        }
        self.move_to(line, MotionKind::Rapid, [self.position[0], self.position[1], Some(z)], None)
    }
}

/// The depths at which pecks of `peck` end from `start` down to `bottom` (one step without a
/// peck, or a peck at least as deep as the hole).
fn peck_depths(start: f64, bottom: f64, peck: Option<f64>) -> Vec<f64> {
    let total = start - bottom;
    match peck {
        Some(p) if p > 0.0 && p < total => {
            let mut depths: Vec<f64> = (1..).map(|k| start - p * k as f64).take_while(|&z| z > bottom).collect();
            depths.push(bottom);
            depths
        }
        _ => vec![bottom],
    }
}

#[cfg(test)]
mod tests;
