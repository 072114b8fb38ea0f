//! The B-spline a Siemens CNC interpolates in `BSPLINE` output: a clamped cubic through the
//! joint positions of a run of feed moves (global interpolation, The NURBS Book §9.2.1: parameters
//! by the part-space chord length of the tool tip, knots by averaging), whose control points and
//! knot intervals the CNC takes as `X… Y… … PL=…` blocks after `BSPLINE SD=3`. Following paper
//! 003's example, the first and the last block carry `PL=0` and each block in between the length
//! of one knot span.
//!
//! The spline is checked against the programmed path: evaluated inside every span, through the
//! forward kinematics, the tool tip must stay within the tolerance of the programmed segment;
//! where it does not, the segment's midpoint is added to the data (its parameter halfway along
//! the segment's) and the spline is solved again around it: only the control points of a window
//! of points around each midpoint, those outside held, the window widened until the control
//! points at its edges have not moved (by more than 1e-13 of the largest axis value, so that the
//! points outside are still interpolated to that), and
//! only the spans the window reaches are checked again. Outside the windows the spline is
//! unchanged to the last bit, so its earlier check still holds.
//!
//! Cost: linear in the run's length. Spans are found by walking from the last one ([`Cursor`]:
//! O(1) per evaluation in increasing order, O(log n) anywhere), the banded system is solved once
//! and each refit costs its window.

use std::ops::Range;

use crate::linearize::{distance_to_segment, nearest_solution, slerp};
use crate::{Joints, Kinematics, MAX_AXES, Pose, Solutions};

/// Degree of the spline (`SD=3`).
pub const DEGREE: usize = 3;

/// Fits and checks of a run before it is given up (written as G1): the first and five refits.
const ROUNDS: usize = 6;
/// Points on each side of a midpoint whose control points are solved again at first.
const WINDOW: usize = 20;
/// How far (relative to the run's largest axis value) a control point at a window's edge may
/// move for the window to be wide enough: the points outside it are still interpolated to that.
const SETTLED: f64 = 1e-13;

/// Counters of the work done, kept in the unit tests only: linearity is tested by counting
/// work, never by timing.
#[cfg(test)]
mod work {
    use std::cell::Cell;

    thread_local! {
        /// Knot comparisons while searching spans.
        pub(super) static SPAN_STEPS: Cell<u64> = const { Cell::new(0) };
        /// Evaluations of the basis functions (with or without derivatives) or of de Boor.
        pub(super) static EVALUATIONS: Cell<u64> = const { Cell::new(0) };
        /// Rows of the interpolation system solved.
        pub(super) static ROWS: Cell<u64> = const { Cell::new(0) };
    }
}

/// One unit of work of the `work` counter named (nothing outside the unit tests).
macro_rules! tally {
    ($counter:ident) => {
        #[cfg(test)]
        work::$counter.with(|c| c.set(c.get() + 1));
    };
}

/// A fitted spline: its control points (the first is the start point) and its knot spans.
#[derive(Clone, Debug, PartialEq)]
pub struct Spline {
    /// Control points; `control[0]` is the start (the current position).
    pub control: Vec<Joints>,
    /// The full clamped knot vector.
    pub knots: Vec<f64>,
}

impl Spline {
    /// The `PL` of control point `k` (1-based, as written after the start point).
    pub fn pl(&self, k: usize) -> f64 {
        let m = self.control.len() - 1;
        if k <= 1 || k >= m { 0.0 } else { self.knots[k + 2] - self.knots[k + 1] }
    }

    /// The spline a CNC builds from a written `BSPLINE`: the control points (the start point
    /// first, then one per written block) and the `PL` of each written block as [`Spline::pl`]
    /// writes them (0 on the first and the last, one knot span each in between); the parameter
    /// starts at 0.
    pub fn from_written(control: Vec<Joints>, pl: &[f64]) -> Spline {
        let spans = pl.get(1..pl.len().saturating_sub(1)).unwrap_or_default();
        let total: f64 = spans.iter().sum();
        let mut knots = vec![0.0; DEGREE + 1];
        let mut t = 0.0;
        for s in spans.iter().take(spans.len().saturating_sub(1)) {
            t += s;
            knots.push(t);
        }
        knots.extend(std::iter::repeat_n(total, DEGREE + 1));
        Spline { control, knots }
    }

    /// The parameter range.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[DEGREE], self.knots[self.control.len()])
    }

    /// A cursor for many evaluations, each searching its span from the last one's.
    pub fn cursor(&self) -> Cursor<'_> {
        self.cursor_from(DEGREE)
    }

    /// A cursor whose first search starts at span `span`.
    fn cursor_from(&self, span: usize) -> Cursor<'_> {
        Cursor { spline: self, span, taylor: None }
    }

    /// The joint values at parameter `u` (de Boor), `u` clamped to the domain; O(log n). Many
    /// evaluations in order: [`Spline::cursor`].
    pub fn at(&self, u: f64) -> Joints {
        self.cursor().at(u)
    }

    /// The joint values and their first three derivatives with respect to the parameter at `u`
    /// (The NURBS Book A2.3 and eq. 3.3): what the prediction needs for `q_s`, `q_ss`, `q_sss`;
    /// O(log n). Many evaluations in order: [`Spline::cursor`].
    pub fn derivatives(&self, u: f64) -> [Joints; DEGREE + 1] {
        self.cursor().derivatives(u)
    }
}

/// Evaluates a spline at parameters one after the other, searching each span from the last one
/// found (galloping, then bisection): O(1) per evaluation at increasing or nearby parameters,
/// O(log n) for a jump across n spans. The values are those of [`Spline::at`] (de Boor) and
/// [`Spline::derivatives`] (each span's cubic in Taylor form about its first knot, computed once
/// per span: the basis functions' derivatives once, not at every parameter).
#[derive(Clone, Debug)]
pub struct Cursor<'a> {
    spline: &'a Spline,
    span: usize,
    /// The span whose polynomial [`Self::derivatives`] last took, and its Taylor coefficients
    /// about the span's first knot (the derivatives there, divided by their factorials).
    taylor: Option<(usize, [[f64; MAX_AXES]; DEGREE + 1])>,
}

impl Cursor<'_> {
    /// The joint values at parameter `u` (de Boor), `u` clamped to the domain.
    pub fn at(&mut self, u: f64) -> Joints {
        let (u, span) = self.locate(u);
        de_boor(self.spline, span, u)
    }

    /// The joint values and their first three derivatives at `u`, `u` clamped to the domain:
    /// the span's cubic, in Taylor form about its first knot, computed once per span.
    pub fn derivatives(&mut self, u: f64) -> [Joints; DEGREE + 1] {
        self.orders(u)
    }

    /// The joint values at `u`, `u` clamped to the domain, from the span's cubic in Taylor form
    /// (computed once per span): [`Self::at`]'s to rounding, at a fraction of de Boor's cost
    /// where many parameters fall in one span.
    pub fn value(&mut self, u: f64) -> Joints {
        let [value] = self.orders(u);
        value
    }

    /// The joint values and their first derivative at `u`: the first two of
    /// [`Self::derivatives`], the same numbers, without the higher orders.
    pub fn tangent(&mut self, u: f64) -> [Joints; 2] {
        self.orders(u)
    }

    /// The first `N` (at most `DEGREE + 1`) of [`Self::derivatives`].
    fn orders<const N: usize>(&mut self, u: f64) -> [Joints; N] {
        let (u, span) = self.locate(u);
        let axes = self.spline.control[0].len();
        let (start, c) = self.coefficients(span);
        let t = u - start;
        let mut out = [[0.0; MAX_AXES]; N];
        for a in 0..axes {
            let d = cubic([c[0][a], c[1][a], c[2][a], c[3][a]], t);
            for (order, value) in out.iter_mut().zip(d) {
                order[a] = value;
            }
        }
        out.map(|values| Joints::from_array(values, axes))
    }

    /// Per axis, the largest magnitudes of its first, second and third derivatives over
    /// `from..=to`, a stretch within one knot span (the span of its middle; both clamped to
    /// the domain): exact for the span's cubic, whose first derivative peaks at an end or at its
    /// parabola's vertex, the second at an end, and whose third is constant.
    pub fn derivative_bounds(&mut self, from: f64, to: f64) -> [[f64; DEGREE]; MAX_AXES] {
        let (_, span) = self.locate(0.5 * (from + to));
        let ((lo, hi), axes) = (self.spline.domain(), self.spline.control[0].len());
        let (start, c) = self.coefficients(span);
        let (t0, t1) = (from.clamp(lo, hi) - start, to.clamp(lo, hi) - start);
        let mut out = [[0.0; DEGREE]; MAX_AXES];
        for (a, bounds) in out.iter_mut().enumerate().take(axes) {
            let coefficients = [c[0][a], c[1][a], c[2][a], c[3][a]];
            let [_, first0, second0, third] = cubic(coefficients, t0);
            let [_, first1, second1, _] = cubic(coefficients, t1);
            let mut first = first0.abs().max(first1.abs());
            let [_, _, c2, c3] = coefficients;
            if c3 != 0.0 {
                let vertex = -c2 / (3.0 * c3);
                if t0 < vertex && vertex < t1 {
                    first = first.max(cubic(coefficients, vertex)[1].abs());
                }
            }
            *bounds = [first, second0.abs().max(second1.abs()), third.abs()];
        }
        out
    }

    /// The first knot of span `span` and the Taylor coefficients of its cubic about it, computed
    /// once per span.
    fn coefficients(&mut self, span: usize) -> (f64, &[[f64; MAX_AXES]; DEGREE + 1]) {
        let start = self.spline.knots[span];
        if self.taylor.as_ref().is_some_and(|(cached, _)| *cached != span) {
            self.taylor = None;
        }
        let spline = self.spline;
        let (_, c) = self.taylor.get_or_insert_with(|| (span, taylor(spline, span, start)));
        (start, c)
    }

    /// `u` clamped to the domain and its span, which the cursor keeps for the next search.
    fn locate(&mut self, u: f64) -> (f64, usize) {
        let (lo, hi) = self.spline.domain();
        let u = u.clamp(lo, hi);
        self.span = find_span(&self.spline.knots, self.spline.control.len(), u, self.span);
        (u, self.span)
    }
}

/// The value and first three derivatives at `t` of the cubic `c0 + c1 t + c2 t² + c3 t³`.
fn cubic([c0, c1, c2, c3]: [f64; DEGREE + 1], t: f64) -> [f64; DEGREE + 1] {
    [c0 + t * (c1 + t * (c2 + t * c3)), c1 + t * (2.0 * c2 + t * 3.0 * c3), 2.0 * c2 + t * 6.0 * c3, 6.0 * c3]
}

/// The span of `u` among the `n` control points: the last `k` in `DEGREE..n` with
/// `knots[k] <= u` (`DEGREE` when none is), searched from `hint` by steps doubling away from it,
/// then by bisection: O(1 + log |answer − hint|).
fn find_span(knots: &[f64], n: usize, u: f64, hint: usize) -> usize {
    let last = n - 1;
    let below = |k: usize| {
        tally!(SPAN_STEPS);
        knots[k] <= u
    };
    // `lo` is below `u` (or is `DEGREE`), `hi` is not (or is past `last`).
    let start = hint.clamp(DEGREE, last);
    let (mut lo, mut hi);
    let mut step = 1;
    if below(start) {
        lo = start;
        loop {
            let k = lo + step;
            if k > last {
                hi = last + 1;
                break;
            }
            if !below(k) {
                hi = k;
                break;
            }
            lo = k;
            step *= 2;
        }
    } else {
        hi = start;
        loop {
            if hi - DEGREE <= step {
                lo = DEGREE;
                break;
            }
            let k = hi - step;
            if below(k) {
                lo = k;
                break;
            }
            hi = k;
            step *= 2;
        }
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The spline at `u` in span `k` (de Boor), on whole arrays (each value as `Joints::lerp`
/// computes it).
fn de_boor(spline: &Spline, k: usize, u: f64) -> Joints {
    tally!(EVALUATIONS);
    let knots = &spline.knots;
    let mut d: [[f64; MAX_AXES]; DEGREE + 1] = std::array::from_fn(|j| spline.control[j + k - DEGREE].array());
    for r in 1..=DEGREE {
        for j in (r..=DEGREE).rev() {
            let i = j + k - DEGREE;
            let den = knots[i + DEGREE + 1 - r] - knots[i];
            let a = if den > 0.0 { (u - knots[i]) / den } else { 0.0 };
            let prev = d[j - 1];
            for (cur, prev) in d[j].iter_mut().zip(prev) {
                *cur = prev + (*cur - prev) * a;
            }
        }
    }
    Joints::from_array(d[DEGREE], spline.control[0].len())
}

/// The Taylor coefficients of span `span`'s cubic about `start` (its first knot): its `k`-th
/// derivative there divided by `k!`, per axis.
fn taylor(spline: &Spline, span: usize, start: f64) -> [[f64; MAX_AXES]; DEGREE + 1] {
    weighted(spline, span, &basis_derivatives(&spline.knots, span, start), [1.0, 1.0, 2.0, 6.0])
}

/// Span `span`'s control points weighted by the basis functions' derivatives `ders`, per order
/// `k` and axis, each term divided by `divisors[k]`.
fn weighted(
    spline: &Spline,
    span: usize,
    ders: &[[f64; DEGREE + 1]; DEGREE + 1],
    divisors: [f64; DEGREE + 1],
) -> [[f64; MAX_AXES]; DEGREE + 1] {
    let mut out = [[0.0; MAX_AXES]; DEGREE + 1];
    for (k, row) in ders.iter().enumerate() {
        for (j, b) in row.iter().enumerate() {
            let c = spline.control[span - DEGREE + j].array();
            for (o, c) in out[k].iter_mut().zip(c) {
                *o += b * c / divisors[k];
            }
        }
    }
    out
}

/// `ders[k][j]`: the `k`-th derivative of the basis function `span − DEGREE + j` at `u`
/// (The NURBS Book A2.3), zero over repeated knots.
fn basis_derivatives(knots: &[f64], span: usize, u: f64) -> [[f64; DEGREE + 1]; DEGREE + 1] {
    tally!(EVALUATIONS);
    const P: usize = DEGREE;
    let div = |x: f64, y: f64| if y != 0.0 { x / y } else { 0.0 };
    let mut ndu = [[0.0; P + 1]; P + 1];
    ndu[0][0] = 1.0;
    let (mut left, mut right) = ([0.0; P + 1], [0.0; P + 1]);
    for j in 1..=P {
        left[j] = u - knots[span + 1 - j];
        right[j] = knots[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = div(ndu[r][j - 1], ndu[j][r]);
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    let mut ders = [[0.0; P + 1]; P + 1];
    for j in 0..=P {
        ders[0][j] = ndu[j][P];
    }
    for r in 0..=P {
        let mut a = [[0.0; P + 1]; 2];
        let (mut s1, mut s2) = (0, 1);
        a[0][0] = 1.0;
        for k in 1..=P {
            let mut d = 0.0;
            let rk = r as isize - k as isize;
            let pk = P - k;
            if r >= k {
                a[s2][0] = div(a[s1][0], ndu[pk + 1][r - k]);
                d = a[s2][0] * ndu[r - k][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if r as isize - 1 <= pk as isize { k - 1 } else { P - r };
            for j in j1..=j2 {
                let i = (rk + j as isize) as usize;
                a[s2][j] = div(a[s1][j] - a[s1][j - 1], ndu[pk + 1][i]);
                d += a[s2][j] * ndu[i][pk];
            }
            if r <= pk {
                a[s2][k] = div(-a[s1][k - 1], ndu[pk + 1][r]);
                d += a[s2][k] * ndu[r][pk];
            }
            ders[k][r] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    let mut factor = P as f64;
    for (k, row) in ders.iter_mut().enumerate().skip(1) {
        for d in row.iter_mut() {
            *d *= factor;
        }
        factor *= (P - k) as f64;
    }
    ders
}

/// The clamped cubic through `points` at parameters `params` (strictly increasing), or `None`
/// with fewer than four points.
pub fn interpolate(points: &[Joints], params: &[f64]) -> Option<Spline> {
    let n = points.len();
    if n < DEGREE + 1 || params.len() != n {
        return None;
    }
    let mut spline = Spline { control: points.to_vec(), knots: averaged_knots(params) };
    solve(&spline.knots, params, points, &mut spline.control, 0..n).then_some(spline)
}

/// The clamped knot vector by averaging (The NURBS Book eq. 9.8): each interior knot the mean
/// of `DEGREE` consecutive parameters.
fn averaged_knots(params: &[f64]) -> Vec<f64> {
    let n = params.len();
    let mut knots = Vec::with_capacity(n + DEGREE + 1);
    knots.extend(std::iter::repeat_n(params[0], DEGREE + 1));
    for j in 1..n - DEGREE {
        knots.push(params[j..j + DEGREE].iter().sum::<f64>() / DEGREE as f64);
    }
    knots.extend(std::iter::repeat_n(params[n - 1], DEGREE + 1));
    knots
}

/// Makes the spline take `points[i]` at `params[i]` for the points `rows` by solving for the
/// control points `rows`, the others held at their values in `control` (they go to the right-hand
/// side); false when the system is singular. The collocation matrix is banded (at most `DEGREE`
/// nonzeros each side of the diagonal) and totally positive, and so is each of its diagonal
/// blocks: Gaussian elimination without pivoting on a dense band, O(rows).
fn solve(knots: &[f64], params: &[f64], points: &[Joints], control: &mut [Joints], rows: Range<usize>) -> bool {
    let n = control.len();
    let (first, m) = (rows.start, rows.len());
    let axes = points[first].len();
    let width = 2 * DEGREE + 1;
    let mut band = vec![0.0; m * width]; // row i, column c ↦ band[i * width + (c + DEGREE - i)]
    let mut rhs: Vec<Joints> = points[rows.clone()].to_vec();
    let mut span = first + 1; // the span of a point's parameter is next to its index
    for (i, &u) in params[rows.clone()].iter().enumerate() {
        tally!(ROWS);
        span = find_span(knots, n, u, span);
        for (r, b) in basis(knots, span, u).iter().enumerate() {
            let c = span - DEGREE + r;
            if !rows.contains(&c) {
                let held = control[c];
                for a in 0..axes {
                    rhs[i][a] -= b * held[a];
                }
                continue;
            }
            let slot = c - first + DEGREE;
            if slot >= i && slot - i < width {
                band[i * width + slot - i] = *b;
            }
        }
    }
    let at = |i: usize, c: usize| i * width + (c + DEGREE - i);
    for k in 0..m {
        let pivot = band[at(k, k)];
        if pivot.abs() < 1e-14 {
            return false;
        }
        for i in k + 1..(k + DEGREE + 1).min(m) {
            let f = band[at(i, k)] / pivot;
            if f == 0.0 {
                continue;
            }
            for c in k..(k + DEGREE + 1).min(m) {
                band[at(i, c)] -= f * band[at(k, c)];
            }
            let (rk, ri) = (rhs[k], rhs[i]);
            for a in 0..axes {
                rhs[i][a] = ri[a] - f * rk[a];
            }
        }
    }
    let solution = &mut control[rows];
    for k in (0..m).rev() {
        let mut v = rhs[k];
        for c in k + 1..(k + DEGREE + 1).min(m) {
            for a in 0..axes {
                v[a] -= band[at(k, c)] * solution[c][a];
            }
        }
        for a in 0..axes {
            v[a] /= band[at(k, k)];
        }
        solution[k] = v;
    }
    true
}

/// The nonzero basis functions at `u` in `span` (The NURBS Book A2.2).
fn basis(knots: &[f64], span: usize, u: f64) -> [f64; DEGREE + 1] {
    tally!(EVALUATIONS);
    let mut n = [0.0; DEGREE + 1];
    let (mut left, mut right) = ([0.0; DEGREE + 1], [0.0; DEGREE + 1]);
    n[0] = 1.0;
    for j in 1..=DEGREE {
        left[j] = u - knots[span + 1 - j];
        right[j] = knots[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            let den = right[r + 1] + left[j - r];
            let temp = if den != 0.0 { n[r] / den } else { 0.0 };
            n[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        n[j] = saved;
    }
    n
}

/// A run of feed positions and their poses.
pub struct Run<'a> {
    /// Joint positions, the first being the start point.
    pub joints: &'a [Joints],
    /// The programmed poses (tool tip and axis in the part frame).
    pub poses: &'a [Pose],
}

/// A run fitted within the tolerance: the spline and the points it goes through (the run's, and
/// the midpoints the fit added).
#[derive(Clone, Debug)]
pub struct Fit {
    /// The spline: one control point per point interpolated.
    pub spline: Spline,
    /// The poses interpolated.
    pub poses: Vec<Pose>,
    /// The spline's parameter at each of `poses`: the tip's chord length from the start (with a
    /// floor of 1e-6 mm per segment of the run); a midpoint's halfway along its segment's.
    pub params: Vec<f64>,
    /// `index[i]`: the position of `run.joints[i]` among the points interpolated, which is also
    /// the index of its control point (the midpoints added before it shift it on).
    pub index: Vec<usize>,
}

/// Fits a run within `tolerance` (mm of tool tip from the programmed segments), adding the
/// midpoints of the segments where the spline strays (the midpoints' joints the inverse
/// kinematics nearest the joints' midpoint, a free axis held within `singular_cone`); `None`
/// when it cannot (fewer than four points, a singular system, a midpoint out of reach, or still
/// off after five refits: the run is then written as G1). O(n) for a run of n points.
pub fn fit_indexed(kin: &dyn Kinematics, run: &Run<'_>, tolerance: f64, singular_cone: f64) -> Option<Fit> {
    let n = run.joints.len();
    if n < DEGREE + 1 || run.poses.len() != n {
        return None;
    }
    let mut joints = run.joints.to_vec();
    let mut fit = Fit {
        spline: Spline { control: joints.clone(), knots: Vec::new() },
        poses: run.poses.to_vec(),
        params: chord_params(run.poses),
        index: (0..n).collect(),
    };
    fit.spline.knots = averaged_knots(&fit.params);
    if !solve(&fit.spline.knots, &fit.params, &joints, &mut fit.spline.control, 0..n) {
        return None;
    }
    let mut failing = Vec::new();
    check(kin, &fit, tolerance, 0..n - 1, &mut failing);
    let largest = joints.iter().flat_map(|j| j.as_slice()).fold(0.0_f64, |m, v| m.max(v.abs()));
    let settled = SETTLED * (1.0 + largest);
    let mut sols = Solutions::new();
    for _ in 1..ROUNDS {
        if failing.is_empty() {
            break;
        }
        // Midpoint t goes in after point failing[t]: it becomes point failing[t] + t + 1.
        let mut mids = Vec::with_capacity(failing.len());
        for &s in &failing {
            let (p, q) = (fit.poses[s], fit.poses[s + 1]);
            let pose = Pose { tip: p.tip + (q.tip - p.tip) * 0.5, axis: slerp(&p.axis, &q.axis, 0.5) };
            let near = joints[s].lerp(&joints[s + 1], 0.5);
            mids.push((nearest_solution(kin, &pose, &near, singular_cone, &mut sols)?, pose));
        }
        joints = spliced(&joints, &failing, |t| mids[t].0);
        fit.poses = spliced(&fit.poses, &failing, |t| mids[t].1);
        fit.params = spliced(&fit.params, &failing, |t| {
            let s = failing[t];
            fit.params[s] + (fit.params[s + 1] - fit.params[s]) * 0.5
        });
        let before = std::mem::take(&mut fit.spline.control);
        fit.spline.control = spliced(&before, &failing, |t| before[failing[t]].lerp(&before[failing[t] + 1], 0.5));
        fit.spline.knots = averaged_knots(&fit.params);
        let mut shift = 0;
        for i in &mut fit.index {
            while shift < failing.len() && failing[shift] < *i {
                shift += 1;
            }
            *i += shift;
        }
        let inserted: Vec<usize> = failing.iter().enumerate().map(|(t, s)| s + t + 1).collect();
        let reference = Reference { control: &before, inserted: &inserted, settled };
        let windows = refit((&fit.spline.knots, &fit.params), &joints, &mut fit.spline.control, &reference)?;
        // The spans a window's control points reach, and the segments of the data they cross.
        failing.clear();
        let segments = fit.poses.len() - 1;
        for w in windows {
            let from = w.start.saturating_sub(DEGREE);
            check(kin, &fit, tolerance, from..(w.end + DEGREE - 1).min(segments), &mut failing);
        }
    }
    failing.is_empty().then_some(fit)
}

/// `items` with item `extra(t)` inserted after `items[after[t]]` (`after` increasing).
fn spliced<T: Copy>(items: &[T], after: &[usize], extra: impl Fn(usize) -> T) -> Vec<T> {
    let mut out = Vec::with_capacity(items.len() + after.len());
    let mut from = 0;
    for (t, &s) in after.iter().enumerate() {
        out.extend_from_slice(&items[from..=s]);
        out.push(extra(t));
        from = s + 1;
    }
    out.extend_from_slice(&items[from..]);
    out
}

/// The control points before the midpoints went in, to tell whether a window is wide enough.
struct Reference<'a> {
    /// The control points before.
    control: &'a [Joints],
    /// The new positions of the midpoints (increasing).
    inserted: &'a [usize],
    /// How far a control point at a window's edge may have moved.
    settled: f64,
}

impl Reference<'_> {
    /// Whether the control points at the edges of `window` (those the points outside it use)
    /// are where they were.
    fn settled(&self, control: &[Joints], window: &Range<usize>) -> bool {
        let left = (window.start > 0).then(|| window.start..window.start + DEGREE);
        let right = (window.end < control.len()).then(|| window.end - DEGREE..window.end);
        left.into_iter().chain(right).flatten().all(|c| {
            // An edge is never a midpoint: midpoints are `WINDOW` points inside their window.
            let was = self.control[c - self.inserted.partition_point(|&p| p < c)];
            (0..was.len()).all(|a| (control[c][a] - was[a]).abs() <= self.settled)
        })
    }
}

/// Solves the control points around the midpoints `reference.inserted` again: each cluster of
/// midpoints in a window of `WINDOW` points either side, doubled until its edges are settled
/// (windows that come near one another merge). Returns the windows solved, increasing and
/// apart; once the rows solved exceed four times the run, the whole run is solved instead.
/// `None` when a system is singular.
fn refit(
    (knots, params): (&[f64], &[f64]),
    joints: &[Joints],
    control: &mut [Joints],
    reference: &Reference<'_>,
) -> Option<Vec<Range<usize>>> {
    let n = control.len();
    // Windows closer than this share rows whose basis reaches into both: they merge.
    let near = |a: &Range<usize>, b: &Range<usize>| b.start <= a.end + 2 * DEGREE;
    let mut pending = reference.inserted.iter().map(|&p| p.saturating_sub(WINDOW)..(p + WINDOW + 1).min(n)).peekable();
    let mut done: Vec<Range<usize>> = Vec::new();
    let mut rows = 0;
    while let Some(mut window) = pending.next() {
        loop {
            while let Some(next) = pending.next_if(|next| near(&window, next)) {
                window.end = window.end.max(next.end);
            }
            while let Some(last) = done.pop_if(|last| near(last, &window)) {
                window.start = window.start.min(last.start);
            }
            rows += window.len();
            if rows > 4 * n {
                let whole = 0..n;
                return solve(knots, params, joints, control, whole.clone()).then(|| Vec::from([whole]));
            }
            if !solve(knots, params, joints, control, window.clone()) {
                return None;
            }
            if reference.settled(control, &window) {
                break;
            }
            let grow = window.len();
            window = window.start.saturating_sub(grow)..(window.end + grow).min(n);
        }
        done.push(window);
    }
    Some(done)
}

/// Adds to `failing` the segments among `segments` (segment s: from point s to point s + 1)
/// where the spline, evaluated at seven parameters inside, takes the tool tip farther than
/// `tolerance` from the programmed segment, or to a distance that is not a number (a tip the
/// forward kinematics could not compute is not within anything).
fn check(kin: &dyn Kinematics, fit: &Fit, tolerance: f64, segments: Range<usize>, failing: &mut Vec<usize>) {
    let (poses, params) = (&fit.poses, &fit.params);
    let mut cursor = fit.spline.cursor_from(segments.start + 1);
    for s in segments {
        let (a, b) = (&poses[s].tip, &poses[s + 1].tip);
        let within = (1..8)
            .map(|k| params[s] + (params[s + 1] - params[s]) * f64::from(k) / 8.0)
            .all(|u| distance_to_segment(&kin.forward(&cursor.value(u)).tip, a, b) <= tolerance);
        if !within {
            failing.push(s);
        }
    }
}

/// Cumulative chord length of the tool tip, with a floor so parameters strictly increase: the
/// spline's parameter at each point of a run.
pub fn chord_params(poses: &[Pose]) -> Vec<f64> {
    let mut params = Vec::with_capacity(poses.len());
    let mut u = 0.0;
    params.push(u);
    for w in poses.windows(2) {
        u += (w[1].tip - w[0].tip).norm().max(1e-6);
        params.push(u);
    }
    params
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point3, Unit, Vector3};
    use postpro_machine::model::{ClosedForm, SolverKind};

    use super::*;
    use crate::{TableTableClosedForm, testing};

    fn mikron() -> TableTableClosedForm {
        let form = ClosedForm::MikronUcp710;
        TableTableClosedForm::new(testing::mikron(SolverKind::ClosedForm(form)), form).expect("shape")
    }

    /// `n` points, 0.5 mm apart, of a smooth 5-axis finishing path (a spiral over a saddle, the
    /// tool tilted 10–40° and swinging), except that every 500th segment jumps 8 mm along the
    /// curve (a CAM system's coarser stretch): the spline bulges off that chord and the fit
    /// must refine it. The joints are the nearest inverse solutions along the way.
    fn five_axis_run(kin: &dyn Kinematics, n: usize) -> (Vec<Joints>, Vec<Pose>) {
        let (r0, pitch) = (20.0, 3.0);
        let (mut theta, mut joints, mut poses) = (0.0_f64, Vec::with_capacity(n), Vec::with_capacity(n));
        let mut sols = Solutions::new();
        for k in 0..n {
            let r = r0 + pitch * theta / std::f64::consts::TAU;
            let (x, y) = (r * theta.cos(), r * theta.sin());
            let tilt = (25.0 + 15.0 * (k as f64 * 0.0021).sin()).to_radians();
            let azimuth = 0.8 * (k as f64 * 0.0017).sin() + 0.2 * theta.sin();
            let axis =
                Unit::new_normalize(Vector3::new(tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), tilt.cos()));
            let pose = Pose { tip: Point3::new(x, y, (y * y - x * x) / 800.0), axis };
            let near = joints.last().copied().unwrap_or(Joints::zeros(5));
            joints.push(nearest_solution(kin, &pose, &near, 0.5_f64.to_radians(), &mut sols).expect("reachable"));
            poses.push(pose);
            let step = if k % 500 == 499 { 8.0 } else { 0.5 };
            theta += step / r.hypot(pitch / std::f64::consts::TAU);
        }
        (joints, poses)
    }

    fn counted() -> [u64; 3] {
        [&work::SPAN_STEPS, &work::EVALUATIONS, &work::ROWS].map(|c| c.with(|c| c.replace(0)))
    }

    #[test]
    fn interpolation_passes_through_the_points() {
        let points: Vec<Joints> =
            (0..12).map(|k| Joints::from_slice(&[f64::from(k), (f64::from(k) * 0.7).sin() * 10.0, 3.0])).collect();
        let params: Vec<f64> = (0..12).map(|k| f64::from(k) * 1.3 + f64::from(k * k) * 0.01).collect();
        let spline = interpolate(&points, &params).expect("fits");
        for (p, u) in points.iter().zip(&params) {
            let q = spline.at(*u);
            for a in 0..3 {
                assert!((p[a] - q[a]).abs() < 1e-9, "{p:?} vs {q:?} at {u}");
            }
        }
        assert_eq!(spline.control[0], points[0]);
        assert_eq!(spline.pl(1), 0.0);
        assert_eq!(spline.pl(11), 0.0);
        // The derivatives are those of the curve (central differences).
        for &u in &[0.3, 2.0, 5.55, 9.9, 14.0] {
            let d = spline.derivatives(u);
            let h = 1e-4;
            let (m, p) = (spline.derivatives(u - h), spline.derivatives(u + h));
            for a in 0..3 {
                assert!((d[0][a] - spline.at(u)[a]).abs() < 1e-9);
                for k in 1..4 {
                    let fd = (p[k - 1][a] - m[k - 1][a]) / (2.0 * h);
                    assert!(
                        (d[k][a] - fd).abs() < 1e-4 * (1.0 + fd.abs()),
                        "order {k} axis {a} at {u}: {} vs {fd}",
                        d[k][a]
                    );
                }
            }
        }
        // Read back from what is written (control points and PL), it is the same curve.
        let written: Vec<f64> = (1..spline.control.len()).map(|k| spline.pl(k)).collect();
        let back = Spline::from_written(spline.control.clone(), &written);
        for &u in &[0.0, 0.3, 5.55, 14.0] {
            let (p, q) = (spline.at(u + params[0]), back.at(u));
            for a in 0..3 {
                assert!((p[a] - q[a]).abs() < 1e-9, "at {u}: {p:?} vs {q:?}");
            }
        }
        let spans: f64 = (1..=11).map(|k| spline.pl(k)).sum();
        assert!((spans - (params[11] - params[0])).abs() < 1e-9, "the PL add up to the parameter range");
    }

    /// From any hint, the span search finds what a scan from the start finds: the last span
    /// starting at or before `u`, over repeated knots too (a written `PL=0` between others).
    #[test]
    fn spans_are_found_from_any_hint() {
        let control = vec![Joints::zeros(2); 9];
        let spline = Spline::from_written(control, &[0.0, 1.0, 0.0, 0.0, 2.0, 0.5, 1.5, 0.0]);
        let (knots, n) = (&spline.knots, spline.control.len());
        let scan = |u: f64| (DEGREE..n).rev().find(|&k| knots[k] <= u).unwrap_or(DEGREE);
        let mut probes: Vec<f64> = knots.clone();
        probes.extend((-4..=24).map(|k| f64::from(k) * 0.25));
        for &u in &probes {
            for hint in 0..n + 4 {
                assert_eq!(find_span(knots, n, u, hint), scan(u), "u = {u}, hint {hint}, knots {knots:?}");
            }
        }
    }

    /// A fit that had to refine: within the tolerance on every segment (the unchanged ones not
    /// checked again included), through every point of the run, and the spline the whole system
    /// solved at once gives (the local refits differ from it by rounding only).
    #[test]
    fn a_refined_fit_is_the_global_fit_within_tolerance() {
        let kin = mikron();
        let (joints, poses) = five_axis_run(&kin, 2000);
        let tolerance = 0.01;
        let run = Run { joints: &joints, poses: &poses };
        let fit = fit_indexed(&kin, &run, tolerance, 0.5_f64.to_radians()).expect("fits");
        assert!(fit.poses.len() > joints.len() + 3, "the coarse stretches were refined: {}", fit.poses.len());
        let mut failing = Vec::new();
        check(&kin, &fit, tolerance, 0..fit.poses.len() - 1, &mut failing);
        assert_eq!(failing, Vec::<usize>::new(), "segments off the tolerance");
        for (i, j) in joints.iter().enumerate() {
            assert_eq!(fit.poses[fit.index[i]], poses[i]);
            let at = fit.spline.at(fit.params[fit.index[i]]);
            for a in 0..5 {
                assert!((at[a] - j[a]).abs() < 1e-9, "point {i} axis {a}: {} vs {}", at[a], j[a]);
            }
        }
        let values: Vec<Joints> = fit.params.iter().map(|&u| fit.spline.at(u)).collect();
        let global = interpolate(&values, &fit.params).expect("solves");
        assert_eq!(global.knots, fit.spline.knots);
        for (g, c) in global.control.iter().zip(&fit.spline.control) {
            for a in 0..5 {
                assert!((g[a] - c[a]).abs() < 1e-9, "{g:?} vs {c:?}");
            }
        }
    }

    /// A machine whose forward kinematics cannot compute the tip where the first axis is
    /// beyond `from`: the tip is then not a number.
    struct Blind<'a> {
        inner: &'a dyn Kinematics,
        from: f64,
    }

    impl Kinematics for Blind<'_> {
        fn machine(&self) -> &postpro_machine::model::Machine {
            self.inner.machine()
        }
        fn forward(&self, joints: &Joints) -> Pose {
            let pose = self.inner.forward(joints);
            if joints[0] > self.from { Pose { tip: Point3::new(f64::NAN, f64::NAN, f64::NAN), ..pose } } else { pose }
        }
        fn inverse(&self, pose: &Pose, out: &mut Solutions) {
            self.inner.inverse(pose, out);
        }
        fn inverse_holding(&self, pose: &Pose, free_axis: usize, value: f64) -> Option<Joints> {
            self.inner.inverse_holding(pose, free_axis, value)
        }
        fn place(&self, pose: &Pose, rotaries: &Joints) -> Joints {
            self.inner.place(pose, rotaries)
        }
    }

    #[test]
    fn a_stretch_whose_tip_cannot_be_computed_is_not_taken_for_within() {
        let kin = mikron();
        let (joints, poses) = five_axis_run(&kin, 200);
        let (tolerance, cone) = (0.01, 0.5_f64.to_radians());
        let run = Run { joints: &joints, poses: &poses };
        let fit = fit_indexed(&kin, &run, tolerance, cone).expect("fits");
        let mut failing = Vec::new();
        check(&kin, &fit, tolerance, 0..fit.poses.len() - 1, &mut failing);
        assert_eq!(failing, Vec::<usize>::new());

        // Blind past the middle of the run's X range: the segments there are off, the rest not.
        let xs = || joints.iter().map(|j| j[0]);
        let from = 0.5 * (xs().fold(f64::INFINITY, f64::min) + xs().fold(f64::NEG_INFINITY, f64::max));
        let blind = Blind { inner: &kin, from };
        check(&blind, &fit, tolerance, 0..fit.poses.len() - 1, &mut failing);
        let params = &fit.params;
        let blinded = |s: usize| {
            (1..8).any(|k| fit.spline.at(params[s] + (params[s + 1] - params[s]) * f64::from(k) / 8.0)[0] > from)
        };
        let expected: Vec<usize> = (0..fit.poses.len() - 1).filter(|&s| blinded(s)).collect();
        assert!(!expected.is_empty() && expected.len() < fit.poses.len() - 1, "{}", expected.len());
        assert_eq!(failing, expected);
        // Such a run is not fitted at all: its midpoints are never within either.
        assert!(fit_indexed(&blind, &run, tolerance, cone).is_none());
    }

    /// The derivatives straight from the basis functions' derivatives at `u` (The NURBS Book
    /// A2.3), what the Taylor form of each span must equal.
    fn derivatives_at(spline: &Spline, u: f64) -> [[f64; MAX_AXES]; DEGREE + 1] {
        derivatives_in(spline, find_span(&spline.knots, spline.control.len(), u, DEGREE), u)
    }

    /// The same, of the cubic of span `span` (at its end knot: that span's, not the next one's).
    fn derivatives_in(spline: &Spline, span: usize, u: f64) -> [[f64; MAX_AXES]; DEGREE + 1] {
        weighted(spline, span, &basis_derivatives(&spline.knots, span, u), [1.0; DEGREE + 1])
    }

    proptest::proptest! {
        /// The cursor's derivatives (each span's cubic in Taylor form, computed once per span)
        /// are the curve's: those of the basis functions at `u`, to rounding, at knots, between
        /// them and outside the domain, in any order (the cursor going back and forth between
        /// spans), on uneven knots.
        #[test]
        fn the_derivatives_of_each_span_are_the_curve_s(
            steps in proptest::collection::vec(0.01..5.0_f64, 4..40),
            coords in proptest::collection::vec(-500.0..500.0_f64, 3 * 40),
            at in proptest::collection::vec(-0.1..1.1_f64, 30),
        ) {
            let n = steps.len();
            let params: Vec<f64> = steps.iter().scan(0.0, |u, s| { *u += s; Some(*u) }).collect();
            let points: Vec<Joints> =
                (0..n).map(|i| Joints::from_slice(&coords[3 * i..3 * i + 3])).collect();
            let spline = interpolate(&points, &params).expect("fits");
            let (lo, hi) = spline.domain();
            let knots_inside = spline.knots[DEGREE..=spline.control.len()].to_vec();
            let scale = spline.control.iter().flat_map(|c| c.as_slice().to_vec()).fold(1.0, |m: f64, v| m.max(v.abs()));
            // Each order's values scale with the control points over the knot spacing's power.
            let spacing = steps.iter().cloned().fold(f64::INFINITY, f64::min);
            let mut cursor = spline.cursor();
            for (i, &f) in at.iter().enumerate() {
                // Every third parameter is a knot itself.
                let u = if i % 3 == 0 { knots_inside[i % knots_inside.len()] } else { lo + (hi - lo) * f };
                let (got, want) = (cursor.derivatives(u), derivatives_at(&spline, u.clamp(lo, hi)));
                // The value and slope alone, the value alone: the same numbers; de Boor's value
                // to rounding.
                let tangent = cursor.tangent(u);
                proptest::prop_assert_eq!((tangent[0], tangent[1]), (got[0], got[1]));
                let (value, de_boor) = (cursor.value(u), cursor.at(u));
                proptest::prop_assert_eq!(value, got[0]);
                for a in 0..3 {
                    proptest::prop_assert!((value[a] - de_boor[a]).abs() <= 1e-11 * scale, "axis {a} at {u}");
                }
                for k in 0..=DEGREE {
                    let tolerance = 1e-11 * scale / spacing.powi(k as i32);
                    for a in 0..3 {
                        proptest::prop_assert!(
                            (got[k][a] - want[k][a]).abs() <= tolerance,
                            "order {k} axis {a} at {u}: {} vs {}", got[k][a], want[k][a]
                        );
                    }
                }
            }
        }
    }

    proptest::proptest! {
        /// The bounds of a stretch within one span are the largest magnitudes of its
        /// derivatives: not below any value at dense samples (the first derivative's peak between
        /// the ends included), and above the largest by no more than the samples can miss.
        #[test]
        fn the_derivative_bounds_of_a_stretch_are_its_largest_magnitudes(
            steps in proptest::collection::vec(0.01..5.0_f64, 4..20),
            coords in proptest::collection::vec(-500.0..500.0_f64, 3 * 20),
            span in 0..20_usize,
            ends in (0.0..1.0_f64, 0.0..1.0_f64),
        ) {
            let n = steps.len();
            let params: Vec<f64> = steps.iter().scan(0.0, |u, s| { *u += s; Some(*u) }).collect();
            let points: Vec<Joints> =
                (0..n).map(|i| Joints::from_slice(&coords[3 * i..3 * i + 3])).collect();
            let spline = interpolate(&points, &params).expect("fits");
            let spans: Vec<usize> =
                (DEGREE..spline.control.len()).filter(|&k| spline.knots[k + 1] > spline.knots[k]).collect();
            let k = spans[span % spans.len()];
            let (a, b) = (spline.knots[k], spline.knots[k + 1]);
            let (from, to) = (a + (b - a) * ends.0.min(ends.1), a + (b - a) * ends.0.max(ends.1));
            let bounds = spline.cursor().derivative_bounds(from, to);
            const SAMPLES: usize = 2000;
            let mut sampled = [[0.0_f64; 3]; DEGREE];
            for i in 0..=SAMPLES {
                let u = (from + (to - from) * i as f64 / SAMPLES as f64).clamp(a, b);
                let d = derivatives_in(&spline, k, u);
                for order in 0..DEGREE {
                    for axis in 0..3 {
                        sampled[order][axis] = sampled[order][axis].max(d[order + 1][axis].abs());
                    }
                }
            }
            // Between samples h apart the first derivative, a parabola of leading coefficient
            // q_sss / 2, falls at most q_sss / 2 × (h / 2)² below its peak.
            let h = (to - from) / SAMPLES as f64;
            for axis in 0..3 {
                let miss = [0.5 * bounds[axis][2] * (0.5 * h).powi(2), 0.0, 0.0];
                for order in 0..DEGREE {
                    let (got, want) = (bounds[axis][order], sampled[order][axis]);
                    let rounding = 1e-9 * want.max(1.0);
                    proptest::prop_assert!(
                        got >= want - rounding && got <= want + miss[order] + rounding,
                        "order {} axis {axis} over {from}..{to}: {got} vs sampled {want}", order + 1
                    );
                }
            }
        }
    }

    /// Linearity, by counting work: a run four times as long costs at most ~4.5 times the span
    /// steps, evaluations and rows solved (a span search from the start of the run would cost
    /// ~16 times), and the refits solve a few rows per midpoint, not the whole run again.
    #[test]
    fn the_fit_works_in_linear_time() {
        let kin = mikron();
        let mut work = Vec::new();
        for n in [10_000, 40_000] {
            let (joints, poses) = five_axis_run(&kin, n);
            counted();
            let run = Run { joints: &joints, poses: &poses };
            let fit = fit_indexed(&kin, &run, 0.01, 0.5_f64.to_radians()).expect("fits");
            let fit_work = counted();
            let midpoints = fit.poses.len() - n;
            assert!(midpoints >= n / 500, "{n} points: {midpoints} midpoints");
            let refit_rows = fit_work[2] - n as u64;
            // All the refits together solve fewer rows than one solve of the whole run.
            assert!(refit_rows < n as u64, "{n} points: {refit_rows} rows refitted for {midpoints} midpoints");
            // And what evaluates the spline: values and derivatives at increasing parameters.
            let mut cursor = fit.spline.cursor();
            for w in fit.params.windows(2) {
                for k in 0..4 {
                    let u = w[0] + (w[1] - w[0]) * f64::from(k) / 4.0;
                    let _ = (cursor.at(u), cursor.derivatives(u));
                }
            }
            let evaluation_work = counted();
            work.push((n, fit_work, evaluation_work));
        }
        let [(_, short, short_eval), (_, long, long_eval)] = work[..] else { unreachable!() };
        for (what, s, l) in [
            ("span steps", short[0], long[0]),
            ("evaluations", short[1], long[1]),
            ("rows solved", short[2], long[2]),
            ("span steps evaluating", short_eval[0], long_eval[0]),
            ("evaluations evaluating", short_eval[1], long_eval[1]),
        ] {
            let ratio = l as f64 / s as f64;
            assert!(ratio <= 4.5, "{what}: {s} for 10 k points, {l} for 40 k ({ratio:.2}×)");
        }
    }
}
