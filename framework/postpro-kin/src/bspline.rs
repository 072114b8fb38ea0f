//! The B-spline a Siemens CNC interpolates in `BSPLINE` output: a clamped cubic through the
//! joint positions of a run of feed moves (global interpolation, The NURBS Book §9.2.1: parameters by the part-space chord
//! length of the tool tip, knots by averaging), whose control points and knot intervals the CNC
//! takes as `X… Y… … PL=…` blocks after `BSPLINE SD=3`. Following paper 003's example, the first
//! and the last block carry `PL=0` and each block in between the length of one knot span.
//!
//! The spline is checked against the programmed path: evaluated inside every span, through the
//! forward kinematics, the tool tip must stay within the tolerance of the programmed segment;
//! where it does not, the segment's midpoint is added to the data and the run is fitted again.

use crate::{Joints, Kinematics, Pose, Solutions};

/// Degree of the spline (`SD=3`).
pub const DEGREE: usize = 3;

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

    /// The joint values at parameter `u` (de Boor).
    pub fn at(&self, u: f64) -> Joints {
        let n = self.control.len();
        let (lo, hi) = self.domain();
        let u = u.clamp(lo, hi);
        let mut k = DEGREE;
        while k + 1 < n && self.knots[k + 1] <= u {
            k += 1;
        }
        let mut d: [Joints; DEGREE + 1] = std::array::from_fn(|j| self.control[j + k - DEGREE]);
        for r in 1..=DEGREE {
            for j in (r..=DEGREE).rev() {
                let i = j + k - DEGREE;
                let den = self.knots[i + DEGREE + 1 - r] - self.knots[i];
                let a = if den > 0.0 { (u - self.knots[i]) / den } else { 0.0 };
                let (prev, cur) = (d[j - 1], d[j]);
                d[j] = prev.lerp(&cur, a);
            }
        }
        d[DEGREE]
    }
}

impl Spline {
    /// The joint values and their first three derivatives with respect to the parameter at `u`
    /// (The NURBS Book A2.3 and eq. 3.3): what the prediction needs for `q_s`, `q_ss`, `q_sss`.
    pub fn derivatives(&self, u: f64) -> [Joints; DEGREE + 1] {
        let n = self.control.len();
        let (lo, hi) = self.domain();
        let u = u.clamp(lo, hi);
        let span = find_span(&self.knots, n, u);
        let ders = basis_derivatives(&self.knots, span, u);
        let axes = self.control[0].len();
        let mut out = [Joints::zeros(axes); DEGREE + 1];
        for (k, row) in ders.iter().enumerate() {
            for (j, b) in row.iter().enumerate() {
                let c = &self.control[span - DEGREE + j];
                for a in 0..axes {
                    out[k][a] += b * c[a];
                }
            }
        }
        out
    }
}

/// `ders[k][j]`: the `k`-th derivative of the basis function `span − DEGREE + j` at `u`
/// (The NURBS Book A2.3), zero over repeated knots.
fn basis_derivatives(knots: &[f64], span: usize, u: f64) -> [[f64; DEGREE + 1]; DEGREE + 1] {
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
    let mut knots = vec![params[0]; DEGREE + 1];
    for j in 1..n - DEGREE {
        knots.push(params[j..j + DEGREE].iter().sum::<f64>() / DEGREE as f64);
    }
    knots.extend(std::iter::repeat_n(params[n - 1], DEGREE + 1));
    // The collocation matrix is banded (at most DEGREE nonzeros around the diagonal) and totally
    // positive: Gaussian elimination without pivoting on a dense band.
    let width = 2 * DEGREE + 1;
    let mut band = vec![0.0; n * width]; // row i, column c ↦ band[i * width + (c + DEGREE - i)]
    for (i, &u) in params.iter().enumerate() {
        let span = find_span(&knots, n, u);
        let basis = basis(&knots, span, u);
        for (r, b) in basis.iter().enumerate() {
            let c = span - DEGREE + r;
            let slot = c + DEGREE;
            if slot >= i && slot - i < width {
                band[i * width + slot - i] = *b;
            }
        }
    }
    let axes = points[0].len();
    let mut rhs: Vec<Joints> = points.to_vec();
    let at = |i: usize, c: usize| i * width + (c + DEGREE - i);
    for k in 0..n {
        let pivot = band[at(k, k)];
        if pivot.abs() < 1e-14 {
            return None;
        }
        for i in k + 1..(k + DEGREE + 1).min(n) {
            let f = band[at(i, k)] / pivot;
            if f == 0.0 {
                continue;
            }
            for c in k..(k + DEGREE + 1).min(n) {
                band[at(i, c)] -= f * band[at(k, c)];
            }
            let (rk, ri) = (rhs[k], rhs[i]);
            for a in 0..axes {
                rhs[i][a] = ri[a] - f * rk[a];
            }
        }
    }
    let mut control = rhs.clone();
    for k in (0..n).rev() {
        let mut v = rhs[k];
        for c in k + 1..(k + DEGREE + 1).min(n) {
            for a in 0..axes {
                v[a] -= band[at(k, c)] * control[c][a];
            }
        }
        for a in 0..axes {
            v[a] /= band[at(k, k)];
        }
        control[k] = v;
    }
    Some(Spline { control, knots })
}

fn find_span(knots: &[f64], n: usize, u: f64) -> usize {
    if u >= knots[n] {
        return n - 1;
    }
    let mut k = DEGREE;
    while k + 1 < n && knots[k + 1] <= u {
        k += 1;
    }
    k
}

/// The nonzero basis functions at `u` in `span` (The NURBS Book A2.2).
fn basis(knots: &[f64], span: usize, u: f64) -> [f64; DEGREE + 1] {
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

/// Fits a run within `tolerance` (mm of tool tip from the programmed segments), adding the
/// midpoints of the segments where the spline strays; `None` when it cannot (too few points,
/// or still off after several refinements: the run is then written as G1).
pub fn fit(kin: &dyn Kinematics, run: &Run<'_>, tolerance: f64, singular_cone: f64) -> Option<(Spline, Vec<Pose>)> {
    fit_indexed(kin, run, tolerance, singular_cone).map(|(spline, poses, _)| (spline, poses))
}

/// [`fit`], also telling where each point of the run went: `index[i]` is the position of
/// `run.joints[i]` among the points interpolated, which is also the index of its control point
/// (global interpolation has one control point per point, the midpoints added before it shifting
/// it on).
pub fn fit_indexed(
    kin: &dyn Kinematics,
    run: &Run<'_>,
    tolerance: f64,
    singular_cone: f64,
) -> Option<(Spline, Vec<Pose>, Vec<usize>)> {
    let mut joints = run.joints.to_vec();
    let mut poses = run.poses.to_vec();
    let mut index: Vec<usize> = (0..joints.len()).collect();
    let mut sols = Solutions::new();
    for _ in 0..6 {
        let params = chord_params(&poses);
        let spline = interpolate(&joints, &params)?;
        let mut worst: Vec<usize> = Vec::new();
        for s in 0..joints.len() - 1 {
            let (a, b) = (&poses[s].tip, &poses[s + 1].tip);
            let off = (1..8)
                .map(|k| params[s] + (params[s + 1] - params[s]) * f64::from(k) / 8.0)
                .map(|u| distance_to_segment(&kin.forward(&spline.at(u)).tip, a, b))
                .fold(0.0, f64::max);
            if off > tolerance {
                worst.push(s);
            }
        }
        if worst.is_empty() {
            return Some((spline, poses, index));
        }
        // A midpoint goes in after point `s`: each point after it moves on by the midpoints before it.
        for i in index.iter_mut() {
            *i += worst.partition_point(|&s| s < *i);
        }
        for &s in worst.iter().rev() {
            let (p, q) = (poses[s], poses[s + 1]);
            let pose =
                Pose { tip: p.tip + (q.tip - p.tip) * 0.5, axis: crate::linearize::slerp(&p.axis, &q.axis, 0.5) };
            let near = joints[s].lerp(&joints[s + 1], 0.5);
            let mid = crate::linearize::nearest_solution(kin, &pose, &near, singular_cone, &mut sols)?;
            joints.insert(s + 1, mid);
            poses.insert(s + 1, pose);
        }
    }
    None
}

/// Cumulative chord length of the tool tip, with a floor so parameters strictly increase: the
/// spline's parameter at each point.
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

fn distance_to_segment(p: &nalgebra::Point3<f64>, a: &nalgebra::Point3<f64>, b: &nalgebra::Point3<f64>) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
