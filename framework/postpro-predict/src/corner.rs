//! Corner rounding at a block transition (paper 000, `DOMAIN.md` §4).
//!
//! Where two blocks meet with a tangent discontinuity the CNC rounds the corner with an arc that
//! stays within the contour tolerance `e` of it. For an interior angle `α` between the blocks
//! (π on a straight line, 0 on a reversal) the arc's radius is
//! `R = e · sin(α/2) / (1 − sin(α/2))`, and the corner is crossed at `V = sqrt(R · A_c)` with
//! `A_c = Amax · (1 − share)`, `share` being the part of the acceleration the CNC keeps for the
//! path direction (Siemens `CURV_EFFECT_ON_PATH_ACCEL`).

use nalgebra::Vector3;
use postpro_machine::model::{AxisKind, Machine};

/// The interior angle (rad) between a block arriving along `incoming` and one leaving along
/// `outgoing`: π when they are collinear, 0 when the second goes back along the first. `None`
/// if either has no direction.
pub fn interior_angle(incoming: &Vector3<f64>, outgoing: &Vector3<f64>) -> Option<f64> {
    let (a, b) = (incoming.try_normalize(0.0)?, outgoing.try_normalize(0.0)?);
    // The turn is the angle between the directions; the interior angle is its supplement.
    Some(std::f64::consts::PI - a.dot(&b).clamp(-1.0, 1.0).acos())
}

/// The radius (mm) of the arc that rounds a corner of interior angle `alpha` (rad) within
/// `tolerance` (mm): infinite on a straight line, 0 on a reversal.
pub fn blend_radius(tolerance: f64, alpha: f64) -> f64 {
    radius_of_half_sine(tolerance, (alpha / 2.0).sin())
}

/// [`blend_radius`] from `s = sin(α/2)`.
fn radius_of_half_sine(tolerance: f64, s: f64) -> f64 {
    if s >= 1.0 { f64::INFINITY } else { tolerance * s / (1.0 - s) }
}

/// The speed (mm/s) at which the CNC crosses the corner between `incoming` and `outgoing`:
/// `sqrt(R · amax · (1 − share))`, infinite when there is no corner (collinear blocks, or one
/// without a direction), 0 on a reversal.
pub fn corner_speed(incoming: &Vector3<f64>, outgoing: &Vector3<f64>, tolerance: f64, amax: f64, share: f64) -> f64 {
    let (Some(a), Some(b)) = (incoming.try_normalize(0.0), outgoing.try_normalize(0.0)) else {
        return f64::INFINITY;
    };
    // The interior angle α is π less the turn θ, so sin(α/2) = cos(θ/2) = √((1 + cos θ)/2): no
    // trigonometry (a corner a block).
    let half_sine = ((1.0 + a.dot(&b).clamp(-1.0, 1.0)) / 2.0).sqrt();
    (radius_of_half_sine(tolerance, half_sine) * amax * (1.0 - share)).sqrt()
}

/// The acceleration the CNC rounds corners with: its tangential (path) acceleration, or the
/// weakest linear axis's when the machine file gives none.
pub fn path_acceleration(machine: &Machine) -> f64 {
    machine.cnc.tangential_accel.unwrap_or_else(|| {
        machine.axes.iter().filter(|a| a.kind == AxisKind::Linear).map(|a| a.amax).fold(f64::INFINITY, f64::min)
    })
}

/// The tip speed (mm/s) a circular arc of radius `radius` (mm) allows: the centripetal
/// acceleration `v²/R` within the acceleration the CNC keeps for curvature (the corner's
/// `A_c = A · (1 − share)`), and its jerk `v³/R²` within the weakest linear axis's jerk.
pub fn arc_speed(machine: &Machine, radius: f64) -> f64 {
    if !(radius.is_finite() && radius > 0.0) {
        return f64::INFINITY;
    }
    let acceleration = path_acceleration(machine) * (1.0 - machine.cnc.curvature_accel_share);
    let jerk = machine.cnc.tangential_jerk.unwrap_or_else(|| {
        machine.axes.iter().filter(|a| a.kind == AxisKind::Linear).map(|a| a.jmax).fold(f64::INFINITY, f64::min)
    });
    (acceleration * radius).sqrt().min((jerk * radius * radius).cbrt())
}

/// The cap on a path parameter's speed where a block moving the axes by `a.0` over a parameter
/// length `a.1` meets one moving them by `b.0` over `b.1`, the tip turning from `incoming` to
/// `outgoing` and covering at most `tip_per_unit` mm per unit of the parameter: the tip's corner
/// speed ([`corner_speed`]) and, for every axis, paper 001's deviation `e = Δv² / Amax`, i.e. a
/// velocity jump of at most `sqrt(e · Amax)` (`e` the contour tolerance read in the axis's NC
/// unit: mm, or degrees for a rotary axis). Infinite when nothing turns.
pub fn junction_cap(
    machine: &Machine,
    incoming: &Vector3<f64>,
    outgoing: &Vector3<f64>,
    tip_per_unit: f64,
    a: (&[f64], f64),
    b: (&[f64], f64),
) -> f64 {
    let cnc = &machine.cnc;
    let mut cap = f64::INFINITY;
    let tip =
        corner_speed(incoming, outgoing, cnc.contour_tolerance, path_acceleration(machine), cnc.curvature_accel_share);
    if tip.is_finite() && tip_per_unit > 0.0 {
        cap = tip / tip_per_unit;
    }
    for (axis, (x, y)) in machine.axes.iter().zip(a.0.iter().zip(b.0)) {
        let jump = (y / b.1 - x / a.1).abs();
        if jump > 0.0 {
            let tolerance = match axis.kind {
                AxisKind::Linear => cnc.contour_tolerance,
                AxisKind::Rotary => cnc.contour_tolerance.to_radians(),
            };
            cap = cap.min((tolerance * axis.amax).sqrt() / jump);
        }
    }
    cap
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn the_arc_stays_within_the_tolerance_of_the_corner() {
        // Independently: the arc's centre lies R / sin(α/2) from the corner on the bisector, so
        // the arc passes R / sin(α/2) − R from it; that gap is the tolerance.
        for degrees in [10.0_f64, 45.0, 90.0, 135.0, 170.0, 179.0] {
            let alpha = degrees.to_radians();
            let r = blend_radius(0.01, alpha);
            let gap = r / (alpha / 2.0).sin() - r;
            assert!((gap - 0.01).abs() < 1e-12, "{degrees}°: gap {gap}");
        }
        assert_eq!(blend_radius(0.01, PI), f64::INFINITY);
        assert_eq!(blend_radius(0.01, 0.0), 0.0);
    }

    #[test]
    fn a_right_angle_corner_is_crossed_at_11_mm_per_s() {
        // e = 0.01 mm, 90°: R = 0.01 · 0.7071 / 0.2929 = 0.02414 mm; with 10 m/s² of which half is
        // left to the curvature, V = sqrt(0.02414 · 5000) = 10.99 mm/s (0.66 m/min).
        let v = corner_speed(&Vector3::x(), &Vector3::y(), 0.01, 10_000.0, 0.5);
        assert!((v - 10.987).abs() < 1e-3, "{v}");
    }

    #[test]
    fn the_corner_speed_is_that_of_the_blend_radius_of_the_interior_angle() {
        for degrees in [0.5_f64, 10.0, 45.0, 90.0, 135.0, 170.0, 179.5] {
            let out = Vector3::new(degrees.to_radians().cos(), degrees.to_radians().sin(), 0.3);
            let alpha = interior_angle(&Vector3::x(), &out).expect("both have a direction");
            let expected = (blend_radius(0.01, alpha) * 10_000.0 * 0.5).sqrt();
            let v = corner_speed(&Vector3::x(), &out, 0.01, 10_000.0, 0.5);
            assert!((v - expected).abs() <= 1e-9 * expected, "{degrees}°: {v} against {expected}");
        }
    }

    #[test]
    fn the_sharper_the_corner_the_slower() {
        let turn = |degrees: f64| {
            let out = Vector3::new(degrees.to_radians().cos(), degrees.to_radians().sin(), 0.0);
            corner_speed(&Vector3::x(), &out, 0.01, 10_000.0, 0.5)
        };
        let speeds: Vec<f64> = [0.0, 1.0, 5.0, 30.0, 90.0, 150.0, 180.0].into_iter().map(turn).collect();
        assert_eq!(speeds[0], f64::INFINITY, "a straight line is no corner");
        assert!(speeds.windows(2).all(|w| w[0] > w[1]), "{speeds:?}");
        assert!(speeds[6].abs() < 1e-6, "a reversal stops: {}", speeds[6]);
        assert_eq!(interior_angle(&Vector3::x(), &Vector3::zeros()), None);
        assert!(
            (interior_angle(&Vector3::x(), &Vector3::y()).expect("both have a direction") - FRAC_PI_2).abs() < 1e-12
        );
    }
}
