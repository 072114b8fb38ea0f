//! The jerk-limited (7-phase) motion from rest to rest over a distance (`DOMAIN.md` §4).
//!
//! Jerk is `+J, 0, −J, 0, −J, 0, +J` over the phases: jerk up, constant acceleration, jerk down to
//! cruise, cruise, and the mirror image to stop. The fastest such motion under `V`, `A`, `J`
//! reaches the largest peak speed the distance allows; phases that do not fit shrink to zero.
//! This is the motion of one block between two stops, and the reference the look-ahead planner
//! is checked against.

/// A rest-to-rest jerk-limited motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    /// The jerk magnitude (units/s³).
    jerk: f64,
    /// Phase durations (s): jerk up, constant acceleration, jerk down, cruise, then the mirror.
    phases: [f64; 7],
}

/// Position, velocity, acceleration and jerk at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Position (units).
    pub s: f64,
    /// Velocity (units/s).
    pub v: f64,
    /// Acceleration (units/s²).
    pub a: f64,
    /// Jerk (units/s³).
    pub j: f64,
}

impl Profile {
    /// The fastest motion over `distance` (≥ 0) under the positive limits `vmax`, `amax`, `jmax`.
    pub fn rest_to_rest(distance: f64, vmax: f64, amax: f64, jmax: f64) -> Profile {
        let distance = distance.max(0.0);
        let (ramp_distance, _) = speed_change(0.0, vmax, amax, jmax);
        let (peak, cruise) = if 2.0 * ramp_distance <= distance {
            (vmax, (distance - 2.0 * ramp_distance) / vmax)
        } else {
            // No cruise: the peak speed whose two ramps cover the distance exactly.
            let without_constant_accel = (distance * distance * jmax / 4.0).cbrt();
            let peak = if without_constant_accel * jmax <= amax * amax {
                without_constant_accel
            } else {
                let b = amax * amax / jmax;
                (-b + (b * b + 4.0 * amax * distance).sqrt()) / 2.0
            };
            (peak, 0.0)
        };
        // The phases reaching `peak` from rest: jerk phases of A/J around a constant acceleration,
        // or two jerk phases of √(v/J) when Amax is not reached.
        let (t_jerk, t_accel) = if peak * jmax >= amax * amax {
            (amax / jmax, (peak / amax - amax / jmax).max(0.0))
        } else {
            ((peak / jmax).sqrt(), 0.0)
        };
        Profile { jerk: jmax, phases: [t_jerk, t_accel, t_jerk, cruise, t_jerk, t_accel, t_jerk] }
    }

    /// The duration of the motion (s).
    pub fn duration(&self) -> f64 {
        self.phases.iter().sum()
    }

    /// The state at time `t` (clamped to the motion).
    pub fn at(&self, t: f64) -> State {
        const SIGNS: [f64; 7] = [1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0];
        let mut left = t.clamp(0.0, self.duration());
        let mut state = State { s: 0.0, v: 0.0, a: 0.0, j: 0.0 };
        for (sign, length) in SIGNS.iter().zip(self.phases) {
            let (j, dt) = (sign * self.jerk, left.min(length));
            state = State {
                s: state.s + state.v * dt + state.a * dt * dt / 2.0 + j * dt * dt * dt / 6.0,
                v: state.v + state.a * dt + j * dt * dt / 2.0,
                a: state.a + j * dt,
                j,
            };
            left -= dt;
            if left <= 0.0 {
                break;
            }
        }
        state
    }
}

/// The fastest jerk-limited change of speed from `v0` to `v1` (both ≥ 0) under `amax`, `jmax`,
/// starting and ending without acceleration: its `(distance, time)`. The acceleration is a
/// symmetric trapezoid (or triangle), so the mean speed is `(v0 + v1) / 2`. The look-ahead uses it
/// to know how early a slowdown must begin.
pub fn speed_change(v0: f64, v1: f64, amax: f64, jmax: f64) -> (f64, f64) {
    let dv = (v1 - v0).abs();
    let time = if dv * jmax >= amax * amax { dv / amax + amax / jmax } else { 2.0 * (dv / jmax).sqrt() };
    ((v0 + v1) / 2.0 * time, time)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples every millisecond and at the end.
    fn samples(profile: &Profile) -> Vec<State> {
        let steps = (profile.duration() * 1000.0).ceil() as usize;
        (0..=steps).map(|k| profile.at(k as f64 / 1000.0)).collect()
    }

    #[test]
    fn a_short_x_move_of_the_mikron_never_reaches_its_acceleration() {
        // 100 mm on X (500 mm/s, 2500 mm/s², 5000 mm/s³): A²/J = 1250 mm/s is above any speed
        // reached, so the motion is four jerk phases of √(v/J) with v = ∛(d²J/4) = 232.08 mm/s:
        // T = 4 √(232.08 / 5000) = 0.86177 s.
        let profile = Profile::rest_to_rest(100.0, 500.0, 2500.0, 5000.0);
        assert!((profile.duration() - 0.861_774).abs() < 1e-6, "{}", profile.duration());
    }

    #[test]
    fn a_long_move_cruises() {
        // 1000 mm at 500 mm/s, 2500 mm/s², 50 000 mm/s³: each ramp takes 500/2500 + 2500/50000 =
        // 0.25 s over 62.5 mm; the cruise 875 mm at 500 mm/s = 1.75 s; T = 2.25 s.
        let profile = Profile::rest_to_rest(1000.0, 500.0, 2500.0, 50_000.0);
        assert!((profile.duration() - 2.25).abs() < 1e-12, "{}", profile.duration());
        let middle = profile.at(1.125);
        assert!((middle.v - 500.0).abs() < 1e-9 && middle.a == 0.0);
    }

    #[test]
    fn a_speed_change_is_one_ramp_of_the_rest_to_rest_motion() {
        // The long move above ramps 0 → 500 mm/s in 0.25 s over 62.5 mm.
        let (distance, time) = speed_change(0.0, 500.0, 2500.0, 50_000.0);
        assert!((distance - 62.5).abs() < 1e-12 && (time - 0.25).abs() < 1e-12, "{distance} {time}");
        // Slowing down takes what speeding up takes; a small change never reaches Amax:
        // 100 → 110 mm/s under J = 5000 mm/s³ takes 2 √(10 / 5000) = 0.08944 s over 9.391 mm.
        assert_eq!(speed_change(110.0, 100.0, 2500.0, 5000.0), speed_change(100.0, 110.0, 2500.0, 5000.0));
        let (distance, time) = speed_change(100.0, 110.0, 2500.0, 5000.0);
        assert!((time - 0.089_443).abs() < 1e-6 && (distance - 105.0 * time).abs() < 1e-12, "{distance} {time}");
        assert_eq!(speed_change(80.0, 80.0, 2500.0, 5000.0), (0.0, 0.0));
    }

    #[test]
    fn every_motion_ends_at_rest_at_its_distance_within_its_limits() {
        for distance in [0.0, 0.001, 0.5, 3.0, 40.0, 200.0, 5000.0] {
            for (vmax, amax, jmax) in
                [(500.0, 2500.0, 5000.0), (500.0, 2100.0, 50_000.0), (2.07, 5.2, 314.0), (30.0, 1.0, 1e6)]
            {
                let profile = Profile::rest_to_rest(distance, vmax, amax, jmax);
                let end = profile.at(profile.duration());
                let case = format!("d {distance}, V {vmax}, A {amax}, J {jmax}: {end:?}");
                assert!((end.s - distance).abs() <= 1e-9 * distance.max(1.0), "{case}");
                // Rounding of the phase times leaves about J · 1e-15 of acceleration.
                assert!(end.v.abs() <= 1e-9 * vmax && end.a.abs() <= 1e-6 * amax, "{case}");
                for state in samples(&profile) {
                    assert!(state.v <= vmax * (1.0 + 1e-12) && state.v >= -1e-9 * vmax, "{case}: {state:?}");
                    assert!(state.a.abs() <= amax * (1.0 + 1e-12), "{case}: {state:?}");
                    assert!(state.j.abs() <= jmax, "{case}: {state:?}");
                }
                // No motion under the limits beats the velocity, acceleration or jerk bound alone.
                let lower = [distance / vmax, 2.0 * (distance / amax).sqrt(), (32.0 * distance / jmax).cbrt()];
                let bound = lower.into_iter().fold(0.0, f64::max);
                assert!(profile.duration() >= bound * (1.0 - 1e-12), "{case}: {} < {bound}", profile.duration());
            }
        }
    }
}
