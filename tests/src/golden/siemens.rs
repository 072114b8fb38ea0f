//! Siemens 840D programs as postpro writes them, read with a real interpreter: the axis values
//! of every line are those nc-gcode-interpreter (the PyPI package `nc-gcode-interpreter`, run by
//! the caller) holds after it, one [`Row`] per program line; what it passes over as function
//! calls or cannot parse is read from the text here: `TRAORI`/`TRAFOOF` (tool centre point
//! control), the tool vector `A3= B3= C3=` of `ORIVECT` (the interpreter has no grammar for
//! them: give it a copy without those words), `CYCLE800(…)` (a tilted working plane, axis by
//! axis, mode 57) and `CYCLE800()`, `SUPA` (machine coordinates), `G17`/`G18`/`G19`, `TURN=`,
//! `G700`/`G710`, `T… M6`, `M0`/`M1`/`M30`.
//!
//! Arcs take their centre from the `I J K` the interpreter reports on their line (incremental
//! from the start). A modal cycle call `MCALL CYCLE8x(RTP, RFP, SDIS, DP, …)` makes every line
//! that programs X or Y a hole ([`EventKind::Hole`] at RFP + SDIS down to DP, the tool back at
//! RTP after it; its moves are not expanded) until `MCALL`.

use std::collections::BTreeMap;

use crate::Error;
use crate::nc::{Arc, EventKind, Frame, MotionKind, Plane, Program, Units};

use super::Builder;

/// What the interpreter made of one program line.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row {
    /// The motion mode in force (`G0`, `G1`, `G2`, `G3`), if any.
    pub motion: Option<String>,
    /// The F the line programs, if any.
    pub feed: Option<f64>,
    /// The axis letters (and `I`, `J`, `K`) the line programs.
    pub programmed: String,
    /// The values the interpreter holds after the line, by letter (carried from line to line).
    pub values: BTreeMap<char, f64>,
}

/// Reads the Siemens program `text` (named `name` in errors) with `rows`, the interpreter's table
/// of it (one row per line).
pub fn read(name: &str, text: &str, rows: &[Row]) -> Result<Program, Error> {
    let lines: Vec<&str> = text.lines().collect();
    let mut b = Builder::new(name);
    if rows.len() != lines.len() {
        return Err(b.error(1, 1, format!("{} rows of the interpreter for {} lines", rows.len(), lines.len())));
    }
    b.units = Some(if lines.iter().any(|l| code(l).split_whitespace().any(|w| matches!(w, "G700" | "G70"))) {
        Units::Inch
    } else {
        Units::Mm
    });
    let mut plane = Plane::Xy;
    let mut feed = None;
    let mut vectors = false;
    let mut tool = None;
    // The modal cycle call: its name, RTP, RFP + SDIS and DP.
    let mut cycle: Option<(String, f64, f64, f64)> = None;
    for (i, (raw, row)) in lines.iter().zip(rows).enumerate() {
        let line = i + 1;
        let code = code(raw);
        let words: Vec<&str> = code.split_whitespace().collect();
        let has = |w: &str| words.contains(&w);
        if let Some(at) = code.find("CYCLE800(") {
            cycle800(&mut b, line, at + 1, &code[at + "CYCLE800(".len()..])?;
            continue;
        }
        if let Some(rest) = code.strip_prefix("MCALL") {
            cycle = match rest.trim() {
                "" => None,
                call => Some(cycle_call(&b, line, call)?),
            };
            continue;
        }
        if let Some(at) = code.find("CYCLE8") {
            return Err(b.error(line, at + 1, "a cycle outside a modal call (MCALL) is not read"));
        }
        if let (Some((name, rtp, start, bottom)), true) = (&cycle, row.programmed.contains(['X', 'Y'])) {
            let [x, y] = ['X', 'Y'].map(|a| row.values.get(&a).copied());
            let (Some(x), Some(y)) = (x, y) else {
                return Err(b.error(line, 1, "a hole at a position not known"));
            };
            b.event(line, EventKind::Hole { cycle: name.clone(), at: [x, y, *start], bottom: *bottom });
            b.position = [Some(x), Some(y), Some(*rtp)];
            continue;
        }
        if has("TRAORI") {
            b.event(line, EventKind::Tcp { on: true });
        }
        if has("TRAFOOF") {
            b.event(line, EventKind::Tcp { on: false });
            b.vector = None;
            vectors = false;
        }
        if has("ORIVECT") {
            vectors = true;
        }
        for (word, p) in [("G17", Plane::Xy), ("G18", Plane::Zx), ("G19", Plane::Yz)] {
            if has(word) {
                plane = p;
            }
        }
        if let Some(t) = words.iter().find_map(|w| w.strip_prefix('T').and_then(|n| n.parse::<u32>().ok())) {
            tool = Some(t);
        }
        if has("M6") || has("M06") {
            let t = tool.ok_or_else(|| b.error(line, 1, "M6 without a T"))?;
            b.event(line, EventKind::ToolChange { tool: t });
        }
        for (m, kind) in [("M0", EventKind::Stop { optional: false }), ("M1", EventKind::Stop { optional: true })] {
            if has(m) {
                b.event(line, kind);
            }
        }
        if has("M30") || has("M2") || has("M02") {
            b.event(line, EventKind::End);
            break;
        }
        if let Some(f) = row.feed {
            feed = Some(f);
        }
        // The tool vector of ORIVECT.
        let vector: Vec<(usize, f64)> = words
            .iter()
            .filter_map(|w| {
                let (letter, value) = w.split_once('=')?;
                let k = ["A3", "B3", "C3"].iter().position(|l| *l == letter)?;
                Some(value.parse::<f64>().map(|v| (k, v)).map_err(|_| w.to_string()))
            })
            .collect::<Result<_, _>>()
            .map_err(|w| b.error(line, 1, format!("expected a number in `{w}`")))?;
        if !vector.is_empty() {
            if !vectors || vector.len() != 3 {
                return Err(b.error(line, 1, "A3 B3 C3 (all three) belong to ORIVECT blocks"));
            }
            let mut v = [0.0; 3];
            for (k, value) in vector {
                v[k] = value;
            }
            b.vector = Some(v);
        }
        let axes: Vec<usize> = ['X', 'Y', 'Z', 'A', 'B', 'C']
            .iter()
            .enumerate()
            .filter(|(_, a)| row.programmed.contains(**a))
            .map(|(k, _)| k)
            .collect();
        if code.contains("SUPA") {
            b.machine_move(line, "SUPA", &axes);
            continue;
        }
        if axes.is_empty() && !(vectors && b.vector.is_some() && code.contains("A3=")) {
            continue;
        }
        for (k, letter) in [(3, 'A'), (4, 'B'), (5, 'C')] {
            if axes.contains(&k) {
                let value = row.values.get(&letter).copied();
                let value = value.ok_or_else(|| b.error(line, 1, format!("no value of {letter}")))?;
                b.rotary.set(letter, value);
            }
        }
        let mut target = b.position;
        for (k, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            if axes.contains(&k) {
                target[k] = Some(row.values.get(&letter).copied().ok_or_else(|| b.error(line, 1, "no value"))?);
            }
        }
        let kind = match row.motion.as_deref() {
            Some("G0") => MotionKind::Rapid,
            Some("G1") => MotionKind::Feed,
            Some(g @ ("G2" | "G3")) => {
                let (Some(sx), Some(sy), Some(sz)) = (b.position[0], b.position[1], b.position[2]) else {
                    return Err(b.error(line, 1, "an arc from a position not known"));
                };
                let [u, v, w] = plane.axes();
                let offset = |letter: char| {
                    if row.programmed.contains(letter) { row.values.get(&letter).copied().unwrap_or(0.0) } else { 0.0 }
                };
                let offsets = [offset('I'), offset('J'), offset('K')];
                let mut center = [sx, sy, sz];
                center[u] += offsets[u];
                center[v] += offsets[v];
                center[w] = [sx, sy, sz][w];
                let turns =
                    words.iter().find_map(|w| w.strip_prefix("TURN=").and_then(|t| t.parse::<u32>().ok())).unwrap_or(0);
                MotionKind::Arc(Arc { center, plane, clockwise: g == "G2", full_turns: turns })
            }
            other => return Err(b.error(line, 1, format!("axis words in motion mode {other:?}"))),
        };
        b.move_to(line, kind, target, feed).map_err(|m| b.error(line, 1, m))?;
    }
    b.finish()
}

/// `CYCLE8x(RTP, RFP, SDIS, DP, …)`: the cycle's name, RTP, RFP + SDIS and DP.
fn cycle_call(b: &Builder, line: usize, call: &str) -> Result<(String, f64, f64, f64), Error> {
    let error = |m: String| b.error(line, 1, m);
    let (name, arguments) = call.split_once('(').ok_or_else(|| error(format!("`MCALL {call}`: no arguments")))?;
    let values: Vec<Option<f64>> =
        arguments.trim_end_matches(')').split(',').map(|a| a.trim().parse::<f64>().ok()).collect();
    let [Some(rtp), Some(rfp), Some(sdis), Some(dp)] = values.get(..4).unwrap_or(&[]).try_into().unwrap_or([None; 4])
    else {
        return Err(error(format!("`{name}` without its RTP, RFP, SDIS and DP")));
    };
    Ok((name.trim().to_string(), rtp, rfp + sdis, dp))
}

/// The code of a line: without its comment.
fn code(line: &str) -> &str {
    line.split(';').next().unwrap_or("").trim()
}

/// `CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0, _Z0, _A, _B, _C, _X1, _Y1, _Z1, _DIR, _FR_I,
/// _DMODE)` in mode 57 (axis by axis: about X, the new Y, the new Z): the plane whose zero is
/// (X0 Y0 Z0) + R·(X1 Y1 Z1); with a direction (`_DIR` ≠ 0) the cycle turns the rotary axes.
/// `CYCLE800()` resets it.
fn cycle800(b: &mut Builder, line: usize, column: usize, arguments: &str) -> Result<(), Error> {
    let inner = arguments.trim_end().strip_suffix(')').ok_or_else(|| b.error(line, column, "CYCLE800 without `)`"))?;
    b.position = [None; 3];
    if inner.trim().is_empty() {
        b.event(line, EventKind::WorkingPlane { code: "CYCLE800()".into(), frame: None });
        return Ok(());
    }
    let parameters: Vec<&str> = inner.split(',').map(str::trim).collect();
    if parameters.len() < 14 {
        return Err(b.error(line, column, format!("CYCLE800 with {} parameters, not 14 to 16", parameters.len())));
    }
    let number = |k: usize| -> Result<f64, Error> {
        let p = parameters[k];
        if p.is_empty() {
            return Ok(0.0);
        }
        p.parse::<f64>().map_err(|_| b.error(line, column, format!("CYCLE800 parameter {} is `{p}`", k + 1)))
    };
    let mode = number(3)?;
    if mode != 57.0 {
        return Err(b.error(line, column, format!("CYCLE800 mode {mode} is not read (57: axis by axis, X Y Z)")));
    }
    let before = [number(4)?, number(5)?, number(6)?];
    let angles = [number(7)?, number(8)?, number(9)?];
    let after = [number(10)?, number(11)?, number(12)?];
    let swivels = number(13)? != 0.0;
    let mut frame = Frame::euler_xyz(before, angles);
    let shift = frame.outer_direction(after);
    frame.origin = [0, 1, 2].map(|k| before[k] + shift[k]);
    b.event(line, EventKind::WorkingPlane { code: "CYCLE800".into(), frame: Some(frame) });
    if swivels {
        b.event(line, EventKind::ToolAxisToPlane { code: "CYCLE800".into() });
    }
    Ok(())
}
