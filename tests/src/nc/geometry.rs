//! The geometry of motions: straight segments and arcs (circular, helical, and the slight
//! spiral a controller accepts when the end radius differs from the start radius: the radius
//! then changes in proportion to the angle, as LinuxCNC interpolates it).

use std::f64::consts::{PI, TAU};

use super::{Arc, Motion};

pub(super) fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

pub(super) fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

/// The distance from `p` to the segment from `a` to `b`.
pub(super) fn segment_distance(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let w = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if dd == 0.0 {
        return distance(a, p);
    }
    let t = ((w[0] * d[0] + w[1] * d[1] + w[2] * d[2]) / dd).clamp(0.0, 1.0);
    distance(lerp(a, b, t), p)
}

/// An arc motion in its plane's coordinates: `u`, `v` the plane's axes, `w` its normal.
pub(super) struct ArcPath {
    axes: [usize; 3],
    /// Centre in (u, v) and the start's w.
    center: [f64; 2],
    start_w: f64,
    start_radius: f64,
    end_radius: f64,
    start_angle: f64,
    /// +1 counter-clockwise about the normal, −1 clockwise.
    sense: f64,
    /// Positive, full turns included.
    sweep: f64,
    rise: f64,
}

impl ArcPath {
    pub(super) fn new(motion: &Motion, arc: &Arc) -> ArcPath {
        let [u, v, w] = arc.plane.axes();
        let center = [arc.center[u], arc.center[v]];
        let (su, sv) = (motion.from[u] - center[0], motion.from[v] - center[1]);
        let (eu, ev) = (motion.to[u] - center[0], motion.to[v] - center[1]);
        let start_radius = su.hypot(sv);
        let end_radius = eu.hypot(ev);
        let start_angle = sv.atan2(su);
        let sense = if arc.clockwise { -1.0 } else { 1.0 };
        // Start and end coincide in the plane: a full circle (as LinuxCNC reads it).
        let closed = (eu - su).hypot(ev - sv) <= 1e-9 * start_radius.max(1.0);
        let partial = if closed { TAU } else { (sense * (ev.atan2(eu) - start_angle)).rem_euclid(TAU) };
        ArcPath {
            axes: [u, v, w],
            center,
            start_w: motion.from[w],
            start_radius,
            end_radius,
            start_angle,
            sense,
            sweep: partial + TAU * f64::from(arc.full_turns),
            rise: motion.to[w] - motion.from[w],
        }
    }

    pub(super) fn sweep(&self) -> f64 {
        self.sweep
    }

    pub(super) fn point_at(&self, t: f64) -> [f64; 3] {
        let angle = self.start_angle + self.sense * self.sweep * t;
        let radius = self.start_radius + (self.end_radius - self.start_radius) * t;
        let mut p = [0.0; 3];
        p[self.axes[0]] = self.center[0] + radius * angle.cos();
        p[self.axes[1]] = self.center[1] + radius * angle.sin();
        p[self.axes[2]] = self.start_w + self.rise * t;
        p
    }

    /// Along the helix: √((r θ)² + h²); with a spiral, the closed form of
    /// ∫ √((r(t) θ)² + Δr² + h²) dt for a radius linear in t.
    pub(super) fn length(&self) -> f64 {
        let dr = self.end_radius - self.start_radius;
        if dr.abs() <= 1e-12 * self.start_radius.max(1.0) || self.sweep == 0.0 {
            return (self.start_radius * self.sweep).hypot(self.rise);
        }
        let k = dr.hypot(self.rise);
        let primitive = |u: f64| 0.5 * (u * u.hypot(k) + k * k * (u / k).asinh());
        (primitive(self.end_radius * self.sweep) - primitive(self.start_radius * self.sweep)) / (dr * self.sweep)
    }

    pub(super) fn distance_to_point(&self, p: [f64; 3]) -> f64 {
        let flat = self.rise == 0.0 && self.end_radius == self.start_radius;
        if flat { self.planar_distance(p) } else { self.minimised_distance(p) }
    }

    /// A circular arc in its plane: the nearest point is on the ray from the centre through the
    /// point's projection when that ray crosses the arc, else an end point.
    fn planar_distance(&self, p: [f64; 3]) -> f64 {
        let (pu, pv) = (p[self.axes[0]] - self.center[0], p[self.axes[1]] - self.center[1]);
        let off_plane = p[self.axes[2]] - self.start_w;
        let rho = pu.hypot(pv);
        let within = self.sweep >= TAU || rho == 0.0 || {
            let angle = (self.sense * (pv.atan2(pu) - self.start_angle)).rem_euclid(TAU);
            angle <= self.sweep
        };
        if within {
            (rho - self.start_radius).hypot(off_plane)
        } else {
            distance(self.point_at(0.0), p).min(distance(self.point_at(1.0), p))
        }
    }

    /// Helices and spirals: the squared distance sampled every π/16 of the sweep, each sampled
    /// local minimum refined by golden-section search between its neighbours, the ends included.
    /// The squared distance to a helix or a spiral has one local minimum per turn at most, so
    /// each sampled local minimum brackets a true one.
    fn minimised_distance(&self, p: [f64; 3]) -> f64 {
        let f = |t: f64| {
            let q = self.point_at(t);
            (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)
        };
        let n = ((self.sweep / (PI / 16.0)).ceil() as usize).max(8);
        let samples: Vec<f64> = (0..=n).map(|i| f(i as f64 / n as f64)).collect();
        let mut best = samples[0].min(samples[n]);
        for i in 0..=n {
            let left = if i == 0 { f64::INFINITY } else { samples[i - 1] };
            let right = if i == n { f64::INFINITY } else { samples[i + 1] };
            if samples[i] <= left && samples[i] <= right {
                let lo = i.saturating_sub(1) as f64 / n as f64;
                let hi = (i + 1).min(n) as f64 / n as f64;
                best = best.min(golden_section_minimum(&f, lo, hi));
            }
        }
        best.sqrt()
    }
}

/// The minimum of `f` on [lo, hi], where `f` has one minimum, to 1e-12 of the interval's
/// parameter scale.
fn golden_section_minimum(f: &impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let mut a = hi - ratio * (hi - lo);
    let mut b = lo + ratio * (hi - lo);
    let (mut fa, mut fb) = (f(a), f(b));
    while hi - lo > 1e-12 {
        if fa <= fb {
            hi = b;
            b = a;
            fb = fa;
            a = hi - ratio * (hi - lo);
            fa = f(a);
        } else {
            lo = a;
            a = b;
            fa = fb;
            b = lo + ratio * (hi - lo);
            fb = f(b);
        }
    }
    fa.min(fb).min(f(lo)).min(f(hi))
}
