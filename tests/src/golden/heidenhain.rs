//! Heidenhain conversational (Klartext) programs, as clsplit writes them for SOLIDWORKS CAM
//! files and as the TNC reads them: `BEGIN PGM … MM|INCH`, `L` lines (X Y Z, IX IY IZ, A B C,
//! `F`/`FMAX`/`FAUTO`, `R0`), `CC` centres and `C … DR±` arcs in the XY plane, `CP` polar arcs
//! and helices (`PA`/`IPA`, `PR`/`IPR`, `Z`/`IZ`), `CYCL DEF 7` datum shifts, drilling cycles
//! (`CYCL DEF 1` pecking, 200 drilling, 203 universal drilling) called by `CYCL CALL` or `M99`,
//! `CYCL DEF 9` dwells, `CYCL DEF 247` presets, `TOOL DEF`/`TOOL CALL` (`TOOL CALL S…` a speed), `M91`/`M92` machine-frame moves, `M128`/`M129`
//! and `FUNCTION TCPM`; and as postpro writes TCP and 3+2 programs: `LN` blocks (X Y Z, the
//! normal NX NY NZ and the tool vector TX TY TZ, every one in every block as the TNC wants),
//! `PLANE VECTOR BX BY BZ NX NY NZ STAY|MOVE|TURN` and `PLANE RESET` (the coordinates that follow
//! are the plane's, its zero the datum; the position is not known in the new frame until
//! programmed again).
//!
//! As the TNC: `FMAX` holds for its block only, `F` is modal; a `CC` without coordinates is the
//! current position; positions after a datum shift are converted back into the frame the
//! program starts in. In `INCH` programs `F` is in 0.1 inch/min.
//!
//! Q parameters are not evaluated (clsplit's probing programs read machine data into them): a
//! block whose coordinates use one is kept as an [`EventKind::Unresolved`] and its axes become
//! unknown; a conditional jump (`FN 9 … GOTO LBL n`) must not skip a motion before its label.
//! `nan` is an error (clsplit writes it for a set-up whose axis is −Z).

use crate::Error;
use crate::nc::{Arc, EventKind, Frame, MotionKind, Plane, Program, Units};

use super::{Between, Builder, Drill, peck_depths};

/// Reads a Heidenhain conversational program named `name` (for errors).
pub fn read(name: &str, text: &str) -> Result<Program, Error> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut reader = Reader::new(name);
    for (i, raw) in text.lines().enumerate() {
        reader.line(i + 1, raw)?;
        if reader.ended {
            break;
        }
    }
    if let Some(label) = reader.jump {
        return Err(reader.b.error(reader.jump_line, 1, format!("a jump to LBL {label}, which never comes")));
    }
    reader.b.finish()
}

/// A coordinate value: a number, or a Q parameter (not evaluated).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Value {
    Number(f64),
    Parameter,
}

/// One token of a block: its word (`X`, `IX`, `PA`, `F`, `M`, `DR`…), value and column.
#[derive(Clone, Debug, PartialEq)]
struct Token {
    word: String,
    value: Option<Value>,
    /// The sign written after a word without a number (`DR+`, `R+`).
    sign: Option<char>,
    column: usize,
}

/// An error located at a token, or at the block.
type Located<'t> = (Option<&'t Token>, String);

/// A drilling cycle defined and waiting for its call.
#[derive(Clone, Debug, PartialEq)]
enum CycleDef {
    /// Cycle 1 PECKING: set-up clearance, depth (signed), plunging depth, dwell, feed.
    Pecking { values: [Option<f64>; 5] },
    /// Cycle 200 or 203 with its Q parameters.
    Drilling { number: u32, q: Vec<(u32, f64)> },
}

struct Reader {
    b: Builder,
    /// The datum shift (`CYCL DEF 7`): program coordinates + shift = the start frame's.
    shift: [Option<f64>; 3],
    /// The index of the last datum-shift event, updated by its 7.1–7.3 lines.
    shift_event: Option<usize>,
    /// A tilted working plane (`PLANE VECTOR`) in force: coordinates are the plane's, not
    /// shifted.
    tilted: bool,
    center: Option<[Option<f64>; 2]>,
    feed: Option<f64>,
    /// `FAUTO`: the feed of the `TOOL CALL`.
    tool_feed: Option<f64>,
    cycle: Option<CycleDef>,
    /// Reading the Q lines of a `CYCL DEF 200/203`.
    in_cycle_def: bool,
    /// Reading the Q line of a `CYCL DEF 247` (its preset number): passed over.
    in_datum_setting: bool,
    /// A pending conditional jump: its label and line.
    jump: Option<String>,
    jump_line: usize,
    ended: bool,
}

impl Reader {
    fn new(name: &str) -> Reader {
        Reader {
            b: Builder::new(name),
            shift: [Some(0.0); 3],
            shift_event: None,
            tilted: false,
            center: None,
            feed: None,
            tool_feed: None,
            cycle: None,
            in_cycle_def: false,
            in_datum_setting: false,
            jump: None,
            jump_line: 0,
            ended: false,
        }
    }

    fn line(&mut self, n: usize, raw: &str) -> Result<(), Error> {
        // Without its block number, comment and end-of-block marks; `column0` counts what was
        // cut from the front.
        let trimmed = raw.trim_start();
        let digits = trimmed.len() - trimmed.trim_start_matches(|c: char| c.is_ascii_digit()).len();
        let body = if digits > 0 && trimmed[digits..].starts_with([' ', '\t']) || digits == trimmed.len() {
            trimmed[digits..].trim_start()
        } else {
            trimmed
        };
        let column0 = raw.len() - body.len();
        let code = body.split(';').next().unwrap_or("").trim_end().trim_end_matches(['*', '~']).trim_end();
        if code.is_empty() {
            return Ok(());
        }
        let upper = code.to_ascii_uppercase();
        if self.in_cycle_def || self.in_datum_setting {
            if let Some((number, value)) = cycle_parameter(&upper) {
                if let (false, Some(CycleDef::Drilling { q, .. })) = (self.in_datum_setting, &mut self.cycle) {
                    q.push((number, value));
                }
                return Ok(());
            }
            self.in_cycle_def = false;
            self.in_datum_setting = false;
        }
        let first = upper.split_whitespace().next().unwrap_or("");
        let error = |b: &Builder, message: String| b.error(n, column0 + 1, message);
        match first {
            "BEGIN" => {
                let units = if upper.ends_with(" MM") {
                    Units::Mm
                } else if upper.ends_with(" INCH") {
                    Units::Inch
                } else {
                    return Err(error(&self.b, "expected `BEGIN PGM name MM|INCH`".to_string()));
                };
                self.b.units = Some(units);
            }
            "END" => {
                self.b.event(n, EventKind::End);
                self.ended = true;
            }
            "BLK" => {}
            "L" | "LN" | "C" | "CC" | "CP" | "M" => self.path_block(n, column0, code)?,
            "PLANE" => self.plane(n, column0, code)?,
            _ if first.starts_with('M') && first[1..].chars().all(|c| c.is_ascii_digit()) => {
                self.path_block(n, column0, &format!("M {code}"))?;
            }
            "TOOL" => self.tool(n, column0, &upper)?,
            "CYCL" | "CYCLE" => self.cycle_line(n, column0, code)?,
            "STOP" => {
                self.b.event(n, EventKind::Stop { optional: false });
                let rest = code[4..].trim();
                if !rest.is_empty() {
                    self.path_block(n, column0, &format!("M {rest}"))?;
                }
            }
            _ if first.starts_with("LBL") => {
                let label = upper[3..].trim().to_string();
                if self.jump.as_ref() == Some(&label) {
                    self.jump = None;
                }
            }
            "FUNCTION" if upper.contains("TCPM") => {
                let on = !upper.contains("RESET");
                self.b.event(n, EventKind::Tcp { on });
            }
            _ if first.starts_with("FN") || first.starts_with('Q') => {
                // Q parameters are not evaluated; a conditional jump is followed to its label.
                if let Some((_, label)) = upper.split_once("GOTO LBL") {
                    self.jump = Some(label.trim().to_string());
                    self.jump_line = n;
                }
            }
            _ => {
                return Err(error(
                    &self.b,
                    format!(
                        "`{first}`: expected a block this reader knows (L, C, CC, CP, CYCL DEF, CYCL CALL, TOOL CALL …)"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// L, C, CC, CP and M-only blocks.
    fn path_block(&mut self, n: usize, column0: usize, code: &str) -> Result<(), Error> {
        let (kind, rest) = code.split_once(char::is_whitespace).unwrap_or((code, ""));
        let kind = kind.to_ascii_uppercase();
        let offset = column0 + code.len() - rest.len();
        let tokens = tokens(rest, offset).map_err(|(column, m)| self.b.error(n, column, m))?;
        let error = |b: &Builder, t: Option<&Token>, m: String| b.error(n, t.map_or(column0 + 1, |t| t.column), m);
        let mut rapid = false;
        let mut machine_frame = None;
        let mut call_cycle = false;
        let normal = kind == "LN";
        for t in &tokens {
            match t.word.as_str() {
                "X" | "Y" | "Z" | "IX" | "IY" | "IZ" | "A" | "B" | "C" | "DR" | "PA" | "IPA" | "PR" | "IPR" => {}
                "NX" | "NY" | "NZ" | "TX" | "TY" | "TZ" if normal => {}
                "FMAX" => rapid = true,
                "FAUTO" => {
                    let feed = self
                        .tool_feed
                        .ok_or_else(|| error(&self.b, Some(t), "FAUTO without a TOOL CALL feed".into()))?;
                    self.feed = Some(feed);
                }
                "F" => {
                    let f = number(t).map_err(|m| error(&self.b, Some(t), m))?;
                    self.feed = Some(self.feed_value(f));
                }
                "FU" | "FZ" => {
                    return Err(error(&self.b, Some(t), "feeds per revolution or per tooth are not read".into()));
                }
                "R" if t.value == Some(Value::Number(0.0)) => {}
                "R" | "RL" | "RR" => {
                    return Err(error(&self.b, Some(t), "radius compensation: the path is not the tool's".into()));
                }
                "M" => match t.value {
                    Some(Value::Number(v)) => match v as u32 {
                        91 | 92 => machine_frame = Some(format!("M{}", v as u32)),
                        99 => call_cycle = true,
                        89 => return Err(error(&self.b, Some(t), "the modal cycle call M89 is not read".into())),
                        0 => self.b.event(n, EventKind::Stop { optional: false }),
                        1 => self.b.event(n, EventKind::Stop { optional: true }),
                        2 | 30 => {
                            self.b.event(n, EventKind::End);
                            self.ended = true;
                        }
                        128 => self.b.event(n, EventKind::Tcp { on: true }),
                        129 => {
                            self.b.event(n, EventKind::Tcp { on: false });
                            self.b.vector = None;
                        }
                        // Spindle, coolant and the rest: no motion.
                        _ => {}
                    },
                    _ => return Err(error(&self.b, Some(t), "expected an M number".into())),
                },
                other => {
                    return Err(error(&self.b, Some(t), format!("`{other}` is not a word this reader knows")));
                }
            }
        }
        let coordinate = |word: &str| tokens.iter().find(|t| t.word == word);
        let axes: Vec<&Token> =
            tokens.iter().filter(|t| matches!(t.word.as_str(), "X" | "Y" | "Z" | "IX" | "IY" | "IZ")).collect();
        let moved: Vec<usize> = axes.iter().map(|t| axis(&t.word)).collect();
        let parameters = tokens.iter().any(|t| t.value == Some(Value::Parameter));
        let rotary: Vec<&Token> = tokens.iter().filter(|t| matches!(t.word.as_str(), "A" | "B" | "C")).collect();
        let moves = !axes.is_empty() || !rotary.is_empty() || matches!(kind.as_str(), "C" | "CP") || call_cycle;
        if let (true, Some(label)) = (moves && kind != "CC", &self.jump) {
            let message = format!("a motion between a conditional jump (line {}) and its LBL {label}", self.jump_line);
            return Err(error(&self.b, None, message));
        }
        if normal {
            self.normal_vectors(&tokens).map_err(|(t, m)| error(&self.b, t, m))?;
        }
        match kind.as_str() {
            "CC" => {
                if axes.iter().any(|t| t.word.ends_with('Z')) || axes.len() == 1 {
                    let message = "a circle centre other than in X and Y is not read".to_string();
                    return Err(error(&self.b, axes.first().copied(), message));
                }
                let target = if axes.is_empty() { self.b.position } else { self.target(&axes) };
                self.center = Some([target[0], target[1]]);
                return Ok(());
            }
            "L" | "LN" | "M" => {
                if let Some(code) = machine_frame {
                    self.b.machine_move(n, &code, &moved);
                } else if parameters {
                    self.unresolved(n, &moved, code);
                } else if !axes.is_empty() || !rotary.is_empty() {
                    for t in &rotary {
                        let v = number(t).map_err(|m| error(&self.b, Some(t), m))?;
                        self.b.rotary.set(t.word.chars().next().unwrap_or('A'), v);
                    }
                    let target = self.target(&axes);
                    let kind = if rapid { MotionKind::Rapid } else { MotionKind::Feed };
                    self.b.move_to(n, kind, target, self.feed).map_err(|m| error(&self.b, axes.first().copied(), m))?;
                }
            }
            _ => {
                if rapid {
                    return Err(error(&self.b, None, "an arc at FMAX".into()));
                }
                if parameters {
                    self.unresolved(n, &[0, 1, 2], code);
                } else {
                    let arc = if kind == "C" { self.circle(&tokens, &axes) } else { self.polar(&tokens, coordinate) };
                    let (target, arc) = arc.map_err(|(t, m)| error(&self.b, t, m))?;
                    self.b.move_to(n, MotionKind::Arc(arc), target, self.feed).map_err(|m| error(&self.b, None, m))?;
                }
            }
        }
        if call_cycle {
            self.call_cycle(n, column0)?;
        }
        Ok(())
    }

    /// What an absolute coordinate along axis `k` adds to be in the program's start frame: the
    /// datum shift, or nothing in a tilted working plane (whose zero is the datum).
    fn datum(&self, k: usize) -> Option<f64> {
        if self.tilted { Some(0.0) } else { self.shift[k] }
    }

    /// An `LN` block's vectors: X Y Z and the normal NX NY NZ are all there (the TNC wants every
    /// coordinate and normal component in each LN block, changed or not), the tool vector TX TY TZ
    /// all or none (it becomes the tool vector in force), no rotary axis.
    fn normal_vectors<'t>(&mut self, tokens: &'t [Token]) -> Result<(), Located<'t>> {
        let get = |word: &str| tokens.iter().find(|t| t.word == word);
        if let Some(t) = tokens.iter().find(|t| matches!(t.word.as_str(), "A" | "B" | "C" | "IX" | "IY" | "IZ")) {
            return Err((Some(t), format!("`{}` in an LN block: its tool orientation is TX TY TZ", t.word)));
        }
        let missing: Vec<&str> = ["X", "Y", "Z", "NX", "NY", "NZ"].into_iter().filter(|w| get(w).is_none()).collect();
        if !missing.is_empty() {
            let message = format!(
                "an LN block without {}: the TNC wants every coordinate and normal component in each LN block",
                missing.join(" ")
            );
            return Err((None, message));
        }
        let tool: Vec<&Token> = ["TX", "TY", "TZ"].into_iter().filter_map(get).collect();
        match tool.len() {
            0 => Ok(()),
            3 => {
                let mut v = [0.0; 3];
                for (k, t) in tool.iter().enumerate() {
                    v[k] = number(t).map_err(|m| (Some(*t), m))?;
                }
                self.b.vector = Some(v);
                Ok(())
            }
            _ => Err((Some(tool[0]), "TX TY TZ: all three or none".into())),
        }
    }

    /// `PLANE VECTOR BX.. BY.. BZ.. NX.. NY.. NZ.. STAY|MOVE|TURN …` and `PLANE RESET
    /// STAY|MOVE|TURN …`: a working plane about the datum, or none. `MOVE` and `TURN` turn the
    /// rotary axes (to values the machine chooses: unknown here), `STAY` leaves them.
    fn plane(&mut self, n: usize, column0: usize, code: &str) -> Result<(), Error> {
        let error = |b: &Builder, column: usize, m: String| b.error(n, column, m);
        let upper = code.to_ascii_uppercase();
        let words: Vec<&str> = upper.split_whitespace().collect();
        let kind = words.get(1).copied().unwrap_or("");
        if !matches!(kind, "VECTOR" | "RESET") {
            let message = format!("PLANE {kind} is not read (PLANE VECTOR and PLANE RESET are)");
            return Err(error(&self.b, column0 + 1, message));
        }
        let after = upper.find(kind).map_or(code.len(), |at| at + kind.len());
        let tokens = tokens(&code[after..], column0 + after).map_err(|(c, m)| self.b.error(n, c, m))?;
        let positioning = tokens.iter().position(|t| matches!(t.word.as_str(), "STAY" | "MOVE" | "TURN"));
        let Some(p) = positioning else {
            return Err(error(&self.b, column0 + 1, "a PLANE without STAY, MOVE or TURN".into()));
        };
        let frame = if kind == "RESET" {
            if let Some(t) = tokens[..p].first() {
                return Err(error(&self.b, t.column, format!("`{}` in PLANE RESET", t.word)));
            }
            None
        } else {
            let mut values = [None; 6];
            for t in &tokens[..p] {
                let k = ["BX", "BY", "BZ", "NX", "NY", "NZ"].iter().position(|w| *w == t.word);
                let Some(k) = k.filter(|&k| values[k].is_none()) else {
                    return Err(error(&self.b, t.column, format!("`{}` in PLANE VECTOR", t.word)));
                };
                values[k] = Some(number(t).map_err(|m| error(&self.b, t.column, m))?);
            }
            let Some(v) = values.iter().copied().collect::<Option<Vec<f64>>>() else {
                return Err(error(&self.b, column0 + 1, "PLANE VECTOR without all of BX BY BZ NX NY NZ".into()));
            };
            let (Some(x), Some(y), Some(z)) = (self.shift[0], self.shift[1], self.shift[2]) else {
                return Err(error(&self.b, column0 + 1, "a working plane about a datum not known".into()));
            };
            let frame = Frame::from_vectors([x, y, z], [v[0], v[1], v[2]], [v[3], v[4], v[5]])
                .map_err(|m| error(&self.b, column0 + 1, m))?;
            Some(frame)
        };
        self.tilted = frame.is_some();
        let name = format!("PLANE {kind}");
        self.b.event(n, EventKind::WorkingPlane { code: name.clone(), frame });
        if tokens[p].word != "STAY" {
            self.b.rotary = Default::default();
            self.b.event(n, EventKind::ToolAxisToPlane { code: name });
        }
        self.b.position = [None; 3];
        Ok(())
    }

    /// A block the reader cannot place (Q parameters): kept, its axes unknown.
    fn unresolved(&mut self, n: usize, axes: &[usize], code: &str) {
        for &k in axes {
            self.b.position[k] = None;
        }
        self.b.event(n, EventKind::Unresolved { text: code.to_string() });
    }

    /// The target of absolute (shifted) and incremental coordinates; the others stay.
    fn target(&self, axes: &[&Token]) -> [Option<f64>; 3] {
        let mut target = self.b.position;
        for t in axes {
            let k = axis(&t.word);
            let Some(Value::Number(v)) = t.value else { continue };
            target[k] = if t.word.starts_with('I') { target[k].map(|p| p + v) } else { self.datum(k).map(|s| v + s) };
        }
        target
    }

    fn arc_center(&self) -> Result<[f64; 2], String> {
        match self.center {
            Some([Some(x), Some(y)]) => Ok([x, y]),
            Some(_) => Err("the circle centre is not known in the work frame".into()),
            None => Err("an arc before any CC".into()),
        }
    }

    fn direction(tokens: &[Token]) -> Result<bool, Located<'_>> {
        match tokens.iter().find(|t| t.word == "DR") {
            Some(t) if t.sign == Some('-') => Ok(true),
            Some(t) if t.sign == Some('+') => Ok(false),
            Some(t) => Err((Some(t), "expected DR+ or DR-".into())),
            None => Err((None, "an arc without DR+ or DR-".into())),
        }
    }

    /// `C X.. Y.. DR±`: to the end point about the centre.
    fn circle<'t>(&self, tokens: &'t [Token], axes: &[&'t Token]) -> Result<([Option<f64>; 3], Arc), Located<'t>> {
        if let Some(z) = axes.iter().find(|t| t.word.ends_with('Z')) {
            return Err((Some(*z), "Z on a C block: a helix is CP with IPA".into()));
        }
        let clockwise = Self::direction(tokens)?;
        let [cx, cy] = self.arc_center().map_err(|m| (None, m))?;
        let target = self.target(axes);
        let (Some(sx), Some(sy), Some(sz)) = (self.b.position[0], self.b.position[1], self.b.position[2]) else {
            return Err((None, "an arc from a position not known in the work frame".into()));
        };
        let (Some(ex), Some(ey)) = (target[0], target[1]) else {
            return Err((None, "an arc to a position not known in the work frame".into()));
        };
        let (r0, r1) = ((sx - cx).hypot(sy - cy), (ex - cx).hypot(ey - cy));
        let tolerance = if self.b.units == Some(Units::Inch) { 0.0005 } else { 0.005 };
        if (r1 - r0).abs() > tolerance && (r1 - r0).abs() > 0.001 * r0 {
            return Err((None, format!("the end point is {r1} from CC, the start {r0}: not on one circle")));
        }
        Ok((target, Arc { center: [cx, cy, sz], plane: Plane::Xy, clockwise, full_turns: 0 }))
    }

    /// `CP PA|IPA.. [PR|IPR..] [Z|IZ..] DR±`: a polar arc or helix about the centre.
    fn polar<'t>(
        &self,
        tokens: &'t [Token],
        coordinate: impl Fn(&str) -> Option<&'t Token>,
    ) -> Result<([Option<f64>; 3], Arc), Located<'t>> {
        let clockwise = Self::direction(tokens)?;
        let [cx, cy] = self.arc_center().map_err(|m| (None, m))?;
        let (Some(sx), Some(sy), Some(sz)) = (self.b.position[0], self.b.position[1], self.b.position[2]) else {
            return Err((None, "an arc from a position not known in the work frame".into()));
        };
        let value = |t: &'t Token| number(t).map_err(|m| (Some(t), m));
        let start_angle = (sy - cy).atan2(sx - cx).to_degrees();
        let start_radius = (sx - cx).hypot(sy - cy);
        let sense = if clockwise { -1.0 } else { 1.0 };
        let sweep = match (coordinate("PA"), coordinate("IPA")) {
            (Some(t), None) => {
                let s = (sense * (value(t)? - start_angle)).rem_euclid(360.0);
                if s == 0.0 { 360.0 } else { s }
            }
            (None, Some(t)) => {
                let s = value(t)?;
                if s == 0.0 || s.signum() != sense {
                    return Err((Some(t), "IPA must be non-zero with the sign of DR".into()));
                }
                s.abs()
            }
            _ => return Err((None, "expected PA or IPA".into())),
        };
        let radius = match (coordinate("PR"), coordinate("IPR")) {
            (Some(t), _) => value(t)?,
            (None, Some(t)) => start_radius + value(t)?,
            (None, None) => start_radius,
        };
        let end_angle = (start_angle + sense * sweep).to_radians();
        let z = match (coordinate("Z"), coordinate("IZ")) {
            (Some(t), _) => {
                let z = value(t)?;
                self.datum(2).map(|s| s + z)
            }
            (None, Some(t)) => Some(sz + value(t)?),
            (None, None) => Some(sz),
        };
        let turns = sweep / 360.0;
        let whole = turns.round();
        let full_turns = if (turns - whole).abs() < 1e-9 { whole - 1.0 } else { turns.floor() };
        let target = [Some(cx + radius * end_angle.cos()), Some(cy + radius * end_angle.sin()), z];
        // A whole number of turns ends where it starts (exactly, so the sweep is read as such).
        let target =
            if (turns - whole).abs() < 1e-9 && radius == start_radius { [Some(sx), Some(sy), z] } else { target };
        Ok((target, Arc { center: [cx, cy, sz], plane: Plane::Xy, clockwise, full_turns: full_turns as u32 }))
    }

    fn tool(&mut self, n: usize, column0: usize, upper: &str) -> Result<(), Error> {
        let words: Vec<&str> = upper.split_whitespace().collect();
        let error = |b: &Builder, m: &str| b.error(n, column0 + 1, m);
        // `TOOL CALL S…` / `TOOL CALL F…`: the spindle speed or the feed of the tool in the
        // spindle changed, no tool change.
        if words.get(1) == Some(&"CALL") && words.get(2).is_some_and(|w| w.starts_with(['S', 'F'])) {
            if let Some(feed) = words[2..].iter().find_map(|w| w.strip_prefix('F').and_then(|v| v.parse::<f64>().ok()))
            {
                self.tool_feed = Some(feed);
            }
            return Ok(());
        }
        let tool =
            words.get(2).and_then(|t| t.parse::<u32>().ok()).ok_or_else(|| error(&self.b, "expected a tool number"))?;
        let value =
            |prefix: &str| words.iter().find_map(|w| w.strip_prefix(prefix).and_then(|v| v.parse::<f64>().ok()));
        match words.get(1).copied() {
            Some("DEF") => {
                let kind = EventKind::ToolDefinition { tool, length: value("L"), radius: value("R") };
                self.b.event(n, kind);
            }
            Some("CALL") => {
                if words.get(3).is_some_and(|w| w.len() == 1 && *w != "Z") {
                    return Err(error(&self.b, "a tool axis other than Z is not read"));
                }
                self.tool_feed = value("F");
                self.b.event(n, EventKind::ToolChange { tool });
            }
            _ => return Err(error(&self.b, "expected TOOL DEF or TOOL CALL")),
        }
        Ok(())
    }

    fn cycle_line(&mut self, n: usize, column0: usize, code: &str) -> Result<(), Error> {
        let error = |b: &Builder, m: String| b.error(n, column0 + 1, m);
        let upper = code.to_ascii_uppercase();
        let words: Vec<&str> = upper.split_whitespace().collect();
        match words.get(1).copied() {
            Some("CALL") if words.len() == 2 || words[2].starts_with('M') => {
                self.call_cycle(n, column0)?;
                if words.len() > 2 {
                    self.path_block(n, column0, &format!("M {}", words[2..].join(" ")))?;
                }
                Ok(())
            }
            Some("DEF") => {
                let number = words.get(2).copied().unwrap_or("");
                let (cycle, part) = number.split_once('.').unwrap_or((number, ""));
                // What follows the cycle number, with its column.
                let after = upper.find(number).map_or(code.len(), |at| at + number.len());
                let rest = &code[after..];
                let last = words.last().copied().unwrap_or("");
                match (cycle, part) {
                    ("7", _) if self.tilted => {
                        return Err(error(&self.b, "a datum shift in a tilted working plane is not read".into()));
                    }
                    ("7", "0") => {
                        self.shift = [Some(0.0); 3];
                        self.shift_event = Some(self.b.events.len());
                        self.b.event(n, EventKind::WorkOffset { name: "CYCL DEF 7".into(), offset: Some(self.shift) });
                    }
                    ("7", "1" | "2" | "3") => {
                        let tokens = tokens(rest, column0 + after).map_err(|(c, m)| self.b.error(n, c, m))?;
                        for t in &tokens {
                            let k = axis(&t.word);
                            if !matches!(t.word.as_str(), "X" | "Y" | "Z" | "IX" | "IY" | "IZ") {
                                return Err(error(&self.b, format!("`{}` in a datum shift", t.word)));
                            }
                            self.shift[k] = match t.value {
                                Some(Value::Number(v)) if t.word.starts_with('I') => self.shift[k].map(|s| s + v),
                                Some(Value::Number(v)) => Some(v),
                                _ => None,
                            };
                        }
                        if let Some(EventKind::WorkOffset { offset, .. }) =
                            self.shift_event.and_then(|i| self.b.events.get_mut(i)).map(|e| &mut e.kind)
                        {
                            *offset = Some(self.shift);
                        }
                    }
                    ("9", "0") => {}
                    ("9", "1") => {
                        let seconds =
                            trailing_number(last).ok_or_else(|| error(&self.b, "expected the dwell time".into()))?;
                        self.b.event(n, EventKind::Dwell { seconds });
                    }
                    ("1", "0") => self.cycle = Some(CycleDef::Pecking { values: [None; 5] }),
                    ("1", k @ ("1" | "2" | "3" | "4" | "5")) => {
                        let Some(CycleDef::Pecking { values }) = &mut self.cycle else {
                            return Err(error(&self.b, "a CYCL DEF 1 line without its 1.0".into()));
                        };
                        let index = k.parse::<usize>().unwrap_or(1) - 1;
                        values[index] = trailing_number(last);
                        if values[index].is_none() {
                            return Err(error(&self.b, format!("expected a number at the end of `{}`", rest.trim())));
                        }
                    }
                    // DATUM SETTING: the preset of Q339 becomes the work frame, as G54 does.
                    ("247", "") => {
                        self.b.event(n, EventKind::WorkOffset { name: "CYCL DEF 247".into(), offset: None });
                        self.in_datum_setting = true;
                    }
                    ("200" | "203", "") => {
                        self.cycle = Some(CycleDef::Drilling { number: cycle.parse().unwrap_or(200), q: Vec::new() });
                        self.in_cycle_def = true;
                    }
                    _ => return Err(error(&self.b, format!("cycle {number} is not read"))),
                }
                Ok(())
            }
            _ => Err(error(&self.b, "expected CYCL DEF or CYCL CALL".into())),
        }
    }

    /// The defined drilling cycle at the current position.
    fn call_cycle(&mut self, n: usize, column0: usize) -> Result<(), Error> {
        let error = |b: &Builder, m: String| b.error(n, column0 + 1, m);
        let Some(def) = self.cycle.clone() else {
            return Err(error(&self.b, "a cycle call without a drilling cycle".into()));
        };
        let Some(z) = self.b.position[2] else {
            return Err(error(&self.b, "a cycle call at an unknown height".into()));
        };
        let to_units = Units::Mm.factor(self.b.units.unwrap_or(Units::Mm));
        let drill = match def {
            CycleDef::Pecking { values } => {
                let [Some(clearance), Some(depth), Some(plunge), dwell, Some(feed)] = values else {
                    return Err(error(&self.b, "CYCL DEF 1 lacks a value (1.1 to 1.5)".into()));
                };
                if depth >= 0.0 {
                    return Err(error(&self.b, "a hole depth that is not negative".into()));
                }
                // The cycle starts where the tool is, the set-up clearance above the surface.
                let surface = z - clearance;
                let bottom = surface + depth;
                // The advanced stop distance the TNC computes: 0.6 mm up to 30 mm deep, else depth/50, at most 7 mm.
                let depth_mm = -depth / to_units;
                let stop = if depth_mm <= 30.0 { 0.6 } else { (depth_mm / 50.0).min(7.0) } * to_units;
                Drill {
                    cycle: "CYCL DEF 1".into(),
                    start: z,
                    bottom,
                    feed: self.feed_value(feed),
                    pecks: peck_depths(surface, bottom, Some(plunge)),
                    between: Between::full_retract(stop),
                    dwell: dwell.filter(|&d| d > 0.0),
                    feed_out: None,
                    retract: z,
                }
            }
            CycleDef::Drilling { number, q } => {
                let get = |k: u32| q.iter().rev().find(|(p, _)| *p == k).map(|(_, v)| *v);
                let need = |k: u32| get(k).ok_or_else(|| error(&self.b, format!("CYCL DEF {number} lacks Q{k}")));
                let (clearance, depth, feed, plunge) = (need(200)?, need(201)?, need(206)?, need(202)?);
                let surface = need(203)?
                    + self.datum(2).ok_or_else(|| error(&self.b, "the datum shift in Z is not known".into()))?;
                let second = get(204).unwrap_or(0.0);
                if depth >= 0.0 {
                    return Err(error(&self.b, format!("Q201 = {depth}: a hole depth that is not negative")));
                }
                let bottom = surface + depth;
                let feed = self.feed_value(feed);
                let (pecks, between, feed_out) = if number == 200 {
                    (peck_depths(surface, bottom, Some(plunge)), Between::full_retract(clearance), None)
                } else {
                    let retract_feed = match get(208) {
                        Some(f) if f > 0.0 => self.feed_value(f),
                        _ => feed,
                    };
                    let pecks =
                        decreasing_pecks(surface, bottom, plunge, get(212).unwrap_or(0.0), get(205).unwrap_or(0.0));
                    let between = Between::Pecking {
                        clearance,
                        retract_feed: Some(retract_feed),
                        chip_breaks: get(213).unwrap_or(0.0).max(0.0) as usize,
                        break_distance: get(256).unwrap_or(0.2 * to_units),
                    };
                    (pecks, between, Some(retract_feed))
                };
                Drill {
                    cycle: format!("CYCL DEF {number}"),
                    start: surface + clearance,
                    bottom,
                    feed,
                    pecks,
                    between,
                    dwell: get(211).filter(|&d| d > 0.0),
                    feed_out,
                    retract: surface + clearance.max(second),
                }
            }
        };
        self.b.drill(n, &drill).map_err(|m| error(&self.b, m))
    }

    /// A feed written in the program (0.1 inch/min in INCH programs) per minute.
    fn feed_value(&self, f: f64) -> f64 {
        if self.b.units == Some(Units::Inch) { f * 0.1 } else { f }
    }
}

/// Pecks of `plunge`, each `decrement` less than the one before but not below `minimum`.
fn decreasing_pecks(surface: f64, bottom: f64, plunge: f64, decrement: f64, minimum: f64) -> Vec<f64> {
    if plunge <= 0.0 {
        return vec![bottom];
    }
    let mut depths = Vec::new();
    let (mut z, mut step) = (surface, plunge);
    while z - step > bottom {
        z -= step;
        depths.push(z);
        let next = (step - decrement).max(minimum);
        if next > 0.0 {
            step = next;
        }
    }
    depths.push(bottom);
    depths
}

/// The axis index of `X`, `IY`…
fn axis(word: &str) -> usize {
    match word.trim_start_matches('I') {
        "X" => 0,
        "Y" => 1,
        _ => 2,
    }
}

/// A token's number (a Q parameter or a missing value is an error here).
fn number(t: &Token) -> Result<f64, String> {
    match t.value {
        Some(Value::Number(v)) => Ok(v),
        Some(Value::Parameter) => Err(format!("`{}` from a Q parameter is not evaluated", t.word)),
        None => Err(format!("expected a number after `{}`", t.word)),
    }
}

/// The number a word ends with (`DIST25.000` → 25, `DEPTH-24.620` → −24.62, `F671`).
fn trailing_number(word: &str) -> Option<f64> {
    let start = word.find(|c: char| c.is_ascii_digit() || matches!(c, '+' | '-' | '.'))?;
    word[start..].parse().ok().filter(|v: &f64| v.is_finite())
}

/// A `Q200=+2` line of a cycle definition.
fn cycle_parameter(upper: &str) -> Option<(u32, f64)> {
    let (name, value) = upper.strip_prefix('Q')?.split_once('=')?;
    let value = value.split_whitespace().next()?;
    Some((name.trim().parse().ok()?, value.parse().ok().filter(|v: &f64| v.is_finite())?))
}

/// The tokens of a block after its keyword: a word (letters) with its signed value, a number
/// standing apart from its word (`Z 25.000`) joined to it, `DR+` kept with its sign. `offset`
/// is the column before `text`.
fn tokens(text: &str, offset: usize) -> Result<Vec<Token>, (usize, String)> {
    let mut tokens: Vec<Token> = Vec::new();
    let mut position = 0;
    for piece in text.split_whitespace() {
        let at = position + text[position..].find(piece).unwrap_or(0);
        position = at + piece.len();
        let column = offset + at + 1;
        let upper = piece.to_ascii_uppercase();
        if upper.ends_with("NAN") {
            return Err((column, format!("not a number: `{piece}`")));
        }
        let letters = upper.chars().take_while(char::is_ascii_alphabetic).count();
        let (word, value) = upper.split_at(letters);
        // A value standing alone belongs to the word before it (`Z 25.000`).
        if word.is_empty() {
            let last = tokens.last_mut().filter(|t| t.value.is_none() && t.sign.is_none());
            let Some(last) = last else { return Err((column, format!("`{piece}` without its word"))) };
            last.value =
                Some(parse_value(value).ok_or_else(|| (column, format!("expected a number, found `{piece}`")))?);
            continue;
        }
        let token = match value {
            "" => Token { word: word.to_string(), value: None, sign: None, column },
            "+" | "-" => Token { word: word.to_string(), value: None, sign: value.chars().next(), column },
            v => {
                let parsed =
                    parse_value(v).ok_or_else(|| (column, format!("expected a number after `{word}`, found `{v}`")))?;
                Token { word: word.to_string(), value: Some(parsed), sign: None, column }
            }
        };
        tokens.push(token);
    }
    Ok(tokens)
}

/// `+25.000`, `-.5`, `+Q12`, `Q3`: a number or a Q parameter; `nan` and the like are `None`.
fn parse_value(text: &str) -> Option<Value> {
    let unsigned = text.trim_start_matches(['+', '-']);
    if let Some(q) = unsigned.strip_prefix('Q') {
        return q.chars().all(|c| c.is_ascii_digit()).then_some(Value::Parameter);
    }
    text.parse::<f64>().ok().filter(|v| v.is_finite()).map(Value::Number)
}
