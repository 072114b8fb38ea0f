//! Fanuc/Haas G-code, as Siemens NX's own Haas UMC-750 post writes it: block numbers, modal
//! G0/G1/G2/G3 with incremental I J K centres (or R), G17/G18/G19, G20/G21, G90/G91, B and C
//! words, G43 H length offsets, G234 (Haas) and G43.4/G43.5 (Fanuc) tool centre point control
//! (the tool vector of G43.5 in I J K), G53 and G28 moves in the machine frame, G81–G89 and G73
//! cycles with G98/G99; and as postpro writes 3+2 set-ups: Fanuc's tilted working plane (G68.2
//! X Y Z I J K, G53.1, G69) and Haas's dynamic work offset (G254, G255), after which the
//! position is not known until programmed again (the machine's kinematics relate the frames).
//!
//! The program is what lies between the first two `%` lines (NX's Information-window header and
//! footer are outside them); without a `%` line, the whole text. A line starting with `O` is the
//! program's number or name. Comments are `( … )` and `;` to the end of the line; `/` blocks are
//! read (block delete off). Numbers without a decimal point are whole units, as Haas reads them.

use crate::Error;
use crate::nc::{Arc, EventKind, Frame, MotionKind, Plane, Program, Units};

use super::{Between, Builder, Drill, peck_depths};

/// How far above the depth reached G83 rapids back in, and how far G73 backs off: LinuxCNC's
/// 0.010 in (a Haas takes both from its settings).
const PECK_CLEARANCE_INCH: f64 = 0.010;

/// Reads a Fanuc/Haas program named `name` (for errors).
pub fn read(name: &str, text: &str) -> Result<Program, Error> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines: Vec<&str> = text.lines().collect();
    let percent: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].trim_start().starts_with('%')).collect();
    let range = match percent[..] {
        [] => 0..lines.len(),
        [first] => first + 1..lines.len(),
        [first, second, ..] => first + 1..second,
    };
    let mut reader = Reader::new(name);
    for i in range {
        let line = lines[i];
        if line.trim_start().starts_with(['O', 'o']) {
            continue;
        }
        let words = words(line).map_err(|(column, message)| reader.b.error(i + 1, column, message))?;
        if !words.is_empty() {
            reader.block(i + 1, &words)?;
        }
        if reader.ended {
            break;
        }
    }
    reader.b.finish()
}

/// One word of a block: its letter, value and 1-based column.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Word {
    letter: char,
    value: f64,
    column: usize,
}

/// The words of a line, comments left out; an error is (column, message).
fn words(line: &str) -> Result<Vec<Word>, (usize, String)> {
    let chars: Vec<char> = line.chars().collect();
    let mut words = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        match c {
            ' ' | '\t' | '\r' => i += 1,
            '/' if words.is_empty() => i += 1,
            ';' => break,
            '(' => match chars[i..].iter().position(|&c| c == ')') {
                Some(k) => i += k + 1,
                None => return Err((i + 1, "a comment without its `)`".to_string())),
            },
            c if c.is_ascii_alphabetic() => {
                let start = i + 1;
                let number: String =
                    chars[start..].iter().take_while(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | '+')).collect();
                let value = number
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| (i + 1, format!("expected a number after `{c}`, found `{number}`")))?;
                words.push(Word { letter: c.to_ascii_uppercase(), value, column: i + 1 });
                i = start + number.chars().count();
            }
            other => return Err((i + 1, format!("expected a word (letter and number), found `{other}`"))),
        }
    }
    Ok(words)
}

/// The G-code as tenths (`G54.1` → 541) for matching.
fn code(value: f64) -> i64 {
    (value * 10.0).round() as i64
}

/// The motion mode of group 01.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Rapid,
    Feed,
    Arc { clockwise: bool },
}

/// A canned cycle's modal values, in program units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct CycleWords {
    z: Option<f64>,
    r: Option<f64>,
    q: Option<f64>,
    p: Option<f64>,
}

struct Reader {
    b: Builder,
    mode: Option<Mode>,
    /// The active canned cycle (73, 81…89), over the motion mode until G80 or a G0–G3.
    cycle: Option<i64>,
    cycle_words: CycleWords,
    /// The Z where the cycles started (G98 returns there).
    initial_z: Option<f64>,
    return_to_initial: bool,
    plane: Plane,
    absolute: bool,
    /// The units of the words (G20/G21), which may differ from the program's.
    units: Option<Units>,
    feed: Option<f64>,
    tool: Option<u32>,
    tcp: bool,
    /// G43.5: the tool vector in I J K on straight moves.
    tcp_vectors: bool,
    ended: bool,
}

impl Reader {
    fn new(name: &str) -> Reader {
        Reader {
            b: Builder::new(name),
            mode: None,
            cycle: None,
            cycle_words: CycleWords::default(),
            initial_z: None,
            return_to_initial: true,
            plane: Plane::Xy,
            absolute: true,
            units: None,
            feed: None,
            tool: None,
            tcp: false,
            tcp_vectors: false,
            ended: false,
        }
    }

    /// Program units per unit of the words.
    fn scale(&self, line: usize, column: usize) -> Result<f64, Error> {
        match (self.units, self.b.units) {
            (Some(words), Some(program)) => Ok(words.factor(program)),
            _ => Err(self.b.error(line, column, "a length before the units: expected G20 or G21 first")),
        }
    }

    fn block(&mut self, line: usize, words: &[Word]) -> Result<(), Error> {
        let column = words[0].column;
        let mut letters: Vec<Word> = Vec::new();
        let mut g_codes = Vec::new();
        let mut m_codes = Vec::new();
        // `E` is G187's corner tolerance (Haas smoothing), nothing else's.
        let smoothing = words.iter().any(|w| w.letter == 'G' && code(w.value) == 1870);
        for &w in words {
            match w.letter {
                'N' => {}
                'G' => g_codes.push(w),
                'M' => m_codes.push(w),
                letter => {
                    if letters.iter().any(|o| o.letter == letter) {
                        return Err(self.b.error(line, w.column, format!("`{letter}` twice in one block")));
                    }
                    if !("XYZABCIJKRQPLFHDTS".contains(letter) || letter == 'E' && smoothing) {
                        return Err(self.b.error(
                            line,
                            w.column,
                            format!("`{letter}` is not a word this reader knows"),
                        ));
                    }
                    letters.push(w);
                }
            }
        }
        let get = |letter: char| letters.iter().find(|w| w.letter == letter).copied();

        // Units first: they apply to the block's own values.
        for g in &g_codes {
            if let c @ (200 | 210) = code(g.value) {
                let units = if c == 200 { Units::Inch } else { Units::Mm };
                self.units = Some(units);
                self.b.units.get_or_insert(units);
            }
        }
        let mut machine_frame: Option<&str> = None;
        let mut dwell = false;
        let mut tilted_plane = false;
        for g in &g_codes {
            let c = code(g.value);
            match c {
                0 | 10 | 20 | 30 => {
                    self.mode = Some(match c {
                        0 => Mode::Rapid,
                        10 => Mode::Feed,
                        other => Mode::Arc { clockwise: other == 20 },
                    });
                    self.cycle = None;
                }
                730 | 810..=890 => {
                    if self.cycle.is_none() {
                        self.initial_z = self.b.position[2];
                    }
                    self.cycle = Some(c / 10);
                }
                800 => {
                    self.cycle = None;
                    self.cycle_words = CycleWords::default();
                }
                40 => dwell = true,
                170 | 180 | 190 => {
                    self.plane = match c {
                        170 => Plane::Xy,
                        180 => Plane::Zx,
                        _ => Plane::Yz,
                    };
                    self.b.event(line, EventKind::Plane(self.plane));
                }
                200 | 210 | 90 | 400 | 610 | 640 | 940 | 1030 | 1870 => {}
                900 | 910 => self.absolute = c == 900,
                980 | 990 => self.return_to_initial = c == 980,
                540 | 550 | 560 | 570 | 580 | 590 | 541 => {
                    let name = if c == 541 {
                        let p = get('P').map_or(0.0, |p| p.value);
                        format!("G54.1 P{p}")
                    } else {
                        format!("G{}", c / 10)
                    };
                    self.b.event(line, EventKind::WorkOffset { name, offset: None });
                }
                430 => {
                    let register = get('H').map(|h| h.value as u32);
                    self.b.event(line, EventKind::LengthOffset { register, offset: None });
                }
                // Haas G234 H; Fanuc G43.4 H (joint values) and G43.5 H (I J K tool vectors, which
                // this model does not keep): the tip in the work frame from here.
                2340 | 434 | 435 => {
                    if c != 2340 {
                        let register = get('H').map(|h| h.value as u32);
                        self.b.event(line, EventKind::LengthOffset { register, offset: None });
                    }
                    self.tcp = true;
                    self.tcp_vectors = c == 435;
                    self.b.event(line, EventKind::Tcp { on: true });
                }
                490 => {
                    self.b.event(line, EventKind::LengthOffset { register: None, offset: Some([0.0; 3]) });
                    if std::mem::take(&mut self.tcp) {
                        self.b.event(line, EventKind::Tcp { on: false });
                    }
                    self.tcp_vectors = false;
                    self.b.vector = None;
                }
                // Haas's dynamic work offset: the program's coordinates are the part's, the
                // control turning them with the rotary axes.
                2540 | 2550 => {
                    self.b.event(line, EventKind::WorkOffset { name: format!("G{}", c / 10), offset: None });
                    self.b.position = [None; 3];
                }
                // Fanuc's tilted working plane: its X Y Z I J K are read below.
                682 => tilted_plane = true,
                531 => self.b.event(line, EventKind::ToolAxisToPlane { code: "G53.1".into() }),
                690 => {
                    self.b.event(line, EventKind::WorkingPlane { code: "G69".into(), frame: None });
                    self.b.position = [None; 3];
                }
                530 => machine_frame = Some("G53"),
                280 => machine_frame = Some("G28"),
                300 => machine_frame = Some("G30"),
                930 | 950 => {
                    return Err(self.b.error(line, g.column, "feeds other than per minute (G94) are not read"));
                }
                410 | 420 => {
                    return Err(self.b.error(line, g.column, "cutter radius compensation: the path is not the tool's"));
                }
                _ => {
                    return Err(self.b.error(line, g.column, format!("G{} is not read by this parser", g.value)));
                }
            }
        }
        if let Some(f) = get('F') {
            self.feed = Some(f.value * self.scale(line, f.column)?);
        }
        if let Some(t) = get('T') {
            self.tool = Some(t.value as u32);
        }
        for m in &m_codes {
            match m.value as u32 {
                6 => {
                    let tool = self.tool.ok_or_else(|| self.b.error(line, m.column, "M6 without a T"))?;
                    self.b.event(line, EventKind::ToolChange { tool });
                }
                0 | 1 => self.b.event(line, EventKind::Stop { optional: m.value as u32 == 1 }),
                2 | 30 => {
                    self.b.event(line, EventKind::End);
                    self.ended = true;
                }
                97..=99 => return Err(self.b.error(line, m.column, "subprogram calls are not followed")),
                // Spindle, coolant, clamps, and the rest: no motion.
                _ => {}
            }
        }
        if tilted_plane {
            // G68.2 X Y Z (the plane's zero) I J K (Euler angles about Z, X', Z'', degrees).
            let scale = self.scale(line, column)?;
            let origin = ['X', 'Y', 'Z'].map(|l| get(l).map_or(0.0, |w| w.value * scale));
            let angles = ['I', 'J', 'K'].map(|l| get(l).map_or(0.0, |w| w.value));
            if let Some(w) = letters.iter().find(|w| !"XYZIJK".contains(w.letter)) {
                return Err(self.b.error(line, w.column, format!("`{}` in a G68.2 block is not read", w.letter)));
            }
            let frame = Some(Frame::euler_zxz(origin, angles));
            self.b.event(line, EventKind::WorkingPlane { code: "G68.2".into(), frame });
            self.b.position = [None; 3];
            return Ok(());
        }
        if dwell {
            let seconds = get('P').or(get('X')).map_or(0.0, |p| p.value);
            self.b.event(line, EventKind::Dwell { seconds });
            return Ok(());
        }

        const AXES: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];
        let given: Vec<usize> = (0..6).filter(|&k| get(AXES[k]).is_some()).collect();
        if let Some(code) = machine_frame {
            let axes = if given.is_empty() && code != "G53" { (0..6).collect() } else { given };
            self.b.machine_move(line, code, &axes);
            return Ok(());
        }
        if let Some(cycle) = self.cycle {
            return self.cycle_block(line, column, cycle, &letters);
        }
        // A straight move's I J K in G43.5: the tool vector (components left out are 0; none at
        // all keeps it).
        let mut oriented = false;
        if matches!(self.mode, Some(Mode::Rapid | Mode::Feed))
            && let Some(w) = ['I', 'J', 'K'].iter().find_map(|&l| get(l))
        {
            if !self.tcp_vectors {
                return Err(self.b.error(line, w.column, "I J K on a straight move outside G43.5"));
            }
            self.b.vector = Some(['I', 'J', 'K'].map(|l| get(l).map_or(0.0, |w| w.value)));
            oriented = true;
        }
        if given.is_empty() && !oriented {
            return Ok(());
        }
        let scale = self.scale(line, column)?;
        let mut target = self.b.position;
        for k in 0..3 {
            if let Some(w) = get(AXES[k]) {
                let v = w.value * scale;
                target[k] = if self.absolute { Some(v) } else { target[k].map(|t| t + v) };
            }
        }
        for &letter in &AXES[3..] {
            if let Some(w) = get(letter) {
                let value = if self.absolute { Some(w.value) } else { self.b.rotary.get(letter).map(|r| r + w.value) };
                match value {
                    Some(v) => {
                        self.b.rotary.set(letter, v);
                    }
                    None => {
                        return Err(self.b.error(line, w.column, "an incremental rotary move from an unknown angle"));
                    }
                }
            }
        }
        let kind = match self.mode {
            None => return Err(self.b.error(line, column, "axis words without a motion mode (G0, G1, G2, G3)")),
            Some(Mode::Rapid) => MotionKind::Rapid,
            Some(Mode::Feed) => MotionKind::Feed,
            Some(Mode::Arc { clockwise }) => {
                for letter in ['P', 'L'] {
                    if let Some(w) = get(letter) {
                        return Err(self.b.error(line, w.column, format!("`{letter}` on an arc (turns) is not read")));
                    }
                }
                MotionKind::Arc(self.arc(line, column, clockwise, target, &letters, scale)?)
            }
        };
        self.b.move_to(line, kind, target, self.feed).map_err(|m| self.b.error(line, column, m))
    }

    /// The arc's centre from I J K (incremental from the start) or R.
    fn arc(
        &self,
        line: usize,
        column: usize,
        clockwise: bool,
        target: [Option<f64>; 3],
        letters: &[Word],
        scale: f64,
    ) -> Result<Arc, Error> {
        let error = |m: &str| self.b.error(line, column, m);
        let (Some(sx), Some(sy), Some(sz)) = (self.b.position[0], self.b.position[1], self.b.position[2]) else {
            return Err(error("an arc from a position not known in the work frame"));
        };
        let (Some(ex), Some(ey), Some(ez)) = (target[0], target[1], target[2]) else {
            return Err(error("an arc to a position not known in the work frame"));
        };
        let (start, end) = ([sx, sy, sz], [ex, ey, ez]);
        let [u, v, w] = self.plane.axes();
        let get = |letter: char| letters.iter().find(|x| x.letter == letter).map(|x| x.value * scale);
        let mut center = start;
        if let Some(r) = get('R') {
            let (du, dv) = (end[u] - start[u], end[v] - start[v]);
            let chord = du.hypot(dv);
            let half = chord / 2.0;
            if chord == 0.0 || r.abs() < half - 1e-9 * r.abs().max(1.0) {
                return Err(error("an R arc whose radius does not reach its end point"));
            }
            let h = (r * r - half * half).max(0.0).sqrt();
            // Counter-clockwise and at most half a turn (R > 0): the centre is left of the chord.
            let left = if clockwise == (r < 0.0) { 1.0 } else { -1.0 };
            center[u] = start[u] + du / 2.0 - left * h * dv / chord;
            center[v] = start[v] + dv / 2.0 + left * h * du / chord;
        } else {
            let offsets = [get('I'), get('J'), get('K')];
            if offsets[u].is_none() && offsets[v].is_none() {
                return Err(error("an arc without its centre (I J K for the plane, or R)"));
            }
            center[u] += offsets[u].unwrap_or(0.0);
            center[v] += offsets[v].unwrap_or(0.0);
        }
        center[w] = start[w];
        let r0 = (start[u] - center[u]).hypot(start[v] - center[v]);
        let r1 = (end[u] - center[u]).hypot(end[v] - center[v]);
        // LinuxCNC's tolerance: 0.0005 in or 0.005 mm, and 0.1 % of the radius.
        let tolerance = match self.b.units {
            Some(Units::Inch) => 0.0005,
            _ => 0.005,
        };
        if (r1 - r0).abs() > tolerance && (r1 - r0).abs() > 0.001 * r0 {
            return Err(error(&format!("the arc's end radius {r1} differs from its start radius {r0}")));
        }
        Ok(Arc { center, plane: self.plane, clockwise, full_turns: 0 })
    }

    /// A block in a canned cycle: the cycle's words update, and a hole at the block's X Y.
    fn cycle_block(&mut self, line: usize, column: usize, cycle: i64, letters: &[Word]) -> Result<(), Error> {
        let error = |b: &Builder, m: &str| b.error(line, column, m);
        if !self.absolute {
            return Err(error(&self.b, "incremental (G91) canned cycles are not read"));
        }
        if self.plane != Plane::Xy {
            return Err(error(&self.b, "canned cycles outside G17 are not read"));
        }
        let scale = self.scale(line, column)?;
        let get = |letter: char| letters.iter().find(|w| w.letter == letter).map(|w| w.value);
        if let Some(w) = letters.iter().find(|w| matches!(w.letter, 'K' | 'L' | 'A' | 'B' | 'C')) {
            return Err(self.b.error(line, w.column, format!("`{}` in a canned cycle is not read", w.letter)));
        }
        let words = &mut self.cycle_words;
        words.z = get('Z').map(|z| z * scale).or(words.z);
        words.r = get('R').map(|r| r * scale).or(words.r);
        words.q = get('Q').map(|q| q * scale).or(words.q);
        words.p = get('P').or(words.p);
        let words = *words;
        if get('X').is_none() && get('Y').is_none() {
            return Ok(());
        }
        let (Some(bottom), Some(r), Some(feed)) = (words.z, words.r, self.feed) else {
            return Err(error(&self.b, "a canned cycle without its Z, R and F"));
        };
        let clearance = PECK_CLEARANCE_INCH * Units::Inch.factor(self.b.units.unwrap_or(Units::Mm));
        // Up to R first when below it, then across at that height.
        if self.b.position[2].is_some_and(|z| z < r) {
            self.b.rapid_along_z(line, r).map_err(|m| error(&self.b, &m))?;
        }
        let mut target = self.b.position;
        target[0] = get('X').map(|x| x * scale).or(target[0]);
        target[1] = get('Y').map(|y| y * scale).or(target[1]);
        self.b.move_to(line, MotionKind::Rapid, target, None).map_err(|m| error(&self.b, &m))?;
        let (pecks, between) = match cycle {
            83 => (peck_depths(r, bottom, words.q), Between::full_retract(clearance)),
            73 => (peck_depths(r, bottom, words.q), Between::chip_break(clearance)),
            81 | 82 | 84 | 85 | 86 | 89 => (vec![bottom], Between::None),
            other => return Err(error(&self.b, &format!("G{other} is not read by this parser"))),
        };
        let retract = if self.return_to_initial { self.initial_z.map_or(r, |z| z.max(r)) } else { r };
        let drill = Drill {
            cycle: format!("G{cycle}"),
            start: r,
            bottom,
            feed,
            pecks,
            between,
            dwell: matches!(cycle, 82 | 89).then(|| words.p.unwrap_or(0.0)),
            feed_out: matches!(cycle, 84 | 85 | 89).then_some(feed),
            retract,
        };
        self.b.drill(line, &drill).map_err(|m| error(&self.b, &m))
    }
}
