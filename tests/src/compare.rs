//! Comparators for golden and back-simulation tests: whether another post's motions appear in
//! ours in order, whether its arcs are ours, the length of a feed path, and how far a list of
//! points (the CL file's) lies from a feed path.
//!
//! Both programs must be in the same units ([`Program::in_units`](crate::nc::Program::in_units)).

use std::fmt;

use crate::nc::{Motion, Rotary};

/// The outcome of a comparison of two motion lists: how many of theirs were found in ours and,
/// when one was not, the first such with both lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Their motions that were compared (all of them, or the arcs).
    pub compared: usize,
    /// Of those, found in ours before the first mismatch.
    pub matched: usize,
    /// The first of theirs not found, when one was not.
    pub mismatch: Option<Mismatch>,
}

impl Comparison {
    /// True when every one of theirs was found.
    pub fn is_match(&self) -> bool {
        self.mismatch.is_none()
    }
}

/// Their motion that was not found in ours.
#[derive(Clone, Debug, PartialEq)]
pub struct Mismatch {
    /// Its line in their program.
    pub theirs_line: usize,
    /// Its end point (and its rotary values).
    pub theirs_to: [f64; 3],
    /// Its rotary values.
    pub theirs_rotary: Rotary,
    /// The line of our motion after our last match: where theirs was expected (`None` when
    /// ours had ended).
    pub ours_line: Option<usize>,
    /// Our nearest end point among the motions searched (from the expected place on), its line
    /// and its distance (largest per-axis difference).
    pub nearest: Option<(usize, [f64; 3], f64)>,
    /// Why the nearest was not taken (out of tolerance, other rotary values, other sense…).
    pub reason: String,
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} of {} found in order", self.matched, self.compared)?;
        let Some(m) = &self.mismatch else { return Ok(()) };
        write!(f, "; their line {} (to {}", m.theirs_line, show(m.theirs_to))?;
        for (letter, value) in [('A', m.theirs_rotary.a), ('B', m.theirs_rotary.b), ('C', m.theirs_rotary.c)] {
            if let Some(v) = value {
                write!(f, " {letter}{v}")?;
            }
        }
        write!(f, ") is not in ours")?;
        match m.ours_line {
            Some(line) => write!(f, " from our line {line} on")?,
            None => write!(f, ": ours had ended")?,
        }
        if let Some((line, to, d)) = m.nearest {
            write!(f, "; nearest: our line {line} to {} ({d:.6} off)", show(to))?;
        }
        write!(f, ": {}", m.reason)
    }
}

fn show(p: [f64; 3]) -> String {
    format!("X{} Y{} Z{}", p[0], p[1], p[2])
}

/// The largest per-axis difference of two points.
fn gap(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max)
}

/// Every motion of `theirs` is found in `ours`, in order (ours may have more in between), with
/// the same end point within `tol_linear` per axis and, for each rotary axis both give, the same
/// value within `tol_angle` degrees. The earliest match is taken each time, which finds an
/// order-preserving match whenever one exists.
pub fn motions_in_order(ours: &[Motion], theirs: &[Motion], tol_linear: f64, tol_angle: f64) -> Comparison {
    let rotary_gap = |a: &Rotary, b: &Rotary| {
        [(a.a, b.a), (a.b, b.b), (a.c, b.c)].into_iter().filter_map(|(x, y)| Some((x? - y?).abs())).fold(0.0, f64::max)
    };
    subsequence(ours, theirs.iter().collect(), |o, t| {
        let (d, r) = (gap(o.to, t.to), rotary_gap(&o.rotary, &t.rotary));
        if d > tol_linear {
            Err(format!("the end point is {d:.6} off, beyond {tol_linear}"))
        } else if r > tol_angle {
            Err(format!("the rotary axes differ by {r:.6}°, beyond {tol_angle}°"))
        } else {
            Ok(())
        }
    })
}

/// Every arc of `theirs` has an arc in `ours`, in order, with the same end point and centre
/// within `tol_linear` per axis, in the same plane and the same sense. (An arc we split ends
/// where theirs does in its last piece.)
pub fn arcs_match(ours: &[Motion], theirs: &[Motion], tol_linear: f64) -> Comparison {
    let ours: Vec<Motion> = ours.iter().filter(|m| m.arc().is_some()).copied().collect();
    subsequence(&ours, theirs.iter().filter(|m| m.arc().is_some()).collect(), |o, t| {
        let (Some(a), Some(b)) = (o.arc(), t.arc()) else { return Err("not an arc".to_string()) };
        let d = gap(o.to, t.to);
        if d > tol_linear {
            Err(format!("the end point is {d:.6} off, beyond {tol_linear}"))
        } else if a.plane != b.plane {
            Err(format!("our arc turns in {:?}, theirs in {:?}", a.plane, b.plane))
        } else if a.clockwise != b.clockwise {
            let sense = |cw| if cw { "clockwise" } else { "counter-clockwise" };
            Err(format!("our arc runs {}, theirs {}", sense(a.clockwise), sense(b.clockwise)))
        } else if gap(a.center, b.center) > tol_linear {
            Err(format!("the centre is {:.6} off, beyond {tol_linear}", gap(a.center, b.center)))
        } else {
            Ok(())
        }
    })
}

/// Finds `theirs` in `ours` in order, taking the earliest `ours` each `accept`s; stops at the
/// first not found and reports the nearest end point from where it was expected on.
fn subsequence(
    ours: &[Motion],
    theirs: Vec<&Motion>,
    accept: impl Fn(&Motion, &Motion) -> Result<(), String>,
) -> Comparison {
    let mut next = 0;
    for (matched, t) in theirs.iter().enumerate() {
        match ours[next..].iter().position(|o| accept(o, t).is_ok()) {
            Some(k) => next += k + 1,
            None => {
                let nearest = ours[next..]
                    .iter()
                    .min_by(|a, b| gap(a.to, t.to).total_cmp(&gap(b.to, t.to)))
                    .map(|o| (o, gap(o.to, t.to)));
                let reason = match nearest {
                    Some((o, _)) => accept(o, t).err().unwrap_or_default(),
                    None => "no motion of ours is left".to_string(),
                };
                return Comparison {
                    compared: theirs.len(),
                    matched,
                    mismatch: Some(Mismatch {
                        theirs_line: t.line,
                        theirs_to: t.to,
                        theirs_rotary: t.rotary,
                        ours_line: ours.get(next).map(|o| o.line),
                        nearest: nearest.map(|(o, d)| (o.line, o.to, d)),
                        reason,
                    }),
                };
            }
        }
    }
    Comparison { compared: theirs.len(), matched: theirs.len(), mismatch: None }
}

/// The length of the feed path: straight feeds and arcs (helices and full turns included),
/// rapids left out.
pub fn feed_path_length(motions: &[Motion]) -> f64 {
    motions.iter().filter(|m| m.is_feed()).map(Motion::length).fold(0.0, |sum, l| sum + l)
}

/// The point farthest from a feed path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Farthest {
    /// Its distance to the nearest feed motion near its place along the path.
    pub distance: f64,
    /// Its index in the points.
    pub point: usize,
    /// The line of that nearest feed motion (`None` when there is no feed motion).
    pub line: Option<usize>,
}

/// How many feed motions past the best so far the search for a point's nearest motion looks
/// before it stops, and how far back from the previous point's.
pub const WINDOW: usize = 64;

/// The largest distance from `points` (in path order, e.g. the CL file's feed points) to the feed
/// motions of `motions` (rapids left out); `None` without points.
///
/// The points are walked in order with a cursor on the motions: each point's nearest motion is
/// searched from [`WINDOW`] motions before the previous point's nearest to at least [`WINDOW`]
/// after it, and on for as long as the distance keeps improving within [`WINDOW`] motions; at an
/// equal distance, a motion at or after the previous point's is taken over one before it. A point the path passes near only far
/// from where the walk is would be reported farther than it is, never nearer: the figure is an
/// upper bound, exact when both follow one order. O((n + m) · WINDOW).
pub fn max_distance_of_points_to_feed_path(points: &[[f64; 3]], motions: &[Motion]) -> Option<Farthest> {
    let feeds: Vec<&Motion> = motions.iter().filter(|m| m.is_feed()).collect();
    let mut farthest: Option<Farthest> = None;
    let mut cursor: usize = 0;
    for (i, &p) in points.iter().enumerate() {
        let start = cursor.saturating_sub(WINDOW);
        let mut best = (start, f64::INFINITY);
        for (k, motion) in feeds.iter().enumerate().skip(start) {
            let d = motion.distance_to_point(p);
            // At an equal distance the walk does not go back: a motion at or after the previous
            // point's wins over one before it (a retract the path makes again further on).
            if d < best.1 || (d == best.1 && best.0 < cursor && k >= cursor) {
                best = (k, d);
            }
            // At least WINDOW past the previous point's motion, and WINDOW past the best.
            if k >= cursor + WINDOW && k - best.0 >= WINDOW {
                break;
            }
        }
        cursor = best.0;
        let line = feeds.get(best.0).map(|m| m.line);
        if farthest.is_none_or(|f| best.1 > f.distance) {
            farthest = Some(Farthest { distance: best.1, point: i, line });
        }
    }
    farthest
}

#[cfg(test)]
mod tests;
