//! The limits of one block in inverse-time form (papers 000 and 001, `DOMAIN.md` §4).
//!
//! A block moves every axis `j` by `ΔP_j` in the same time, so it is one motion of the unit
//! parameter `α ∈ [0, 1]`. Its inverse-time velocity `α̇` is capped by the programmed feed
//! (`V_f / L`), by every moving axis (`Vmax_j / |ΔP_j|`) and by the CNC cycle (a block lasts at
//! least one interpolation period: `α̇ ≤ 1 / T_cycle`). Acceleration and jerk of `α` are capped
//! the same way by `Amax_j / |ΔP_j|` and `Jmax_j / |ΔP_j|`. Which cap holds is the report a
//! programmer wants: "C velocity", "cycle time", or nothing when the programmed feed is reached.

use postpro_machine::model::Axis;

/// What caps the inverse-time velocity of a block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limiter {
    /// Nothing: the programmed feed is reachable.
    Programmed,
    /// The velocity of this axis (index into the machine's axes).
    Axis(usize),
    /// The block is shorter than one interpolation cycle at the programmed feed.
    CycleTime,
}

/// The caps of one block on its unit parameter `α` (all in 1/s, 1/s², 1/s³).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockLimits {
    /// `V_f / L`; infinite for a block that moves the tool tip by nothing (pure reorientation).
    pub programmed: f64,
    /// The inverse-time velocity the block can reach: the smallest of the programmed, the axes'
    /// and the cycle's caps. Always finite.
    pub velocity: f64,
    /// Which cap gives [`Self::velocity`]; the programmed feed wins ties.
    pub limiter: Limiter,
    /// `min_j Amax_j / |ΔP_j|` and the axis that gives it; infinite when no axis moves.
    pub acceleration: (f64, Option<usize>),
    /// `min_j Jmax_j / |ΔP_j|` and the axis that gives it; infinite when no axis moves.
    pub jerk: (f64, Option<usize>),
}

impl BlockLimits {
    /// The share of the programmed feed the block can reach (1 when it is reached).
    pub fn feed_ratio(&self) -> f64 {
        if self.programmed.is_finite() { self.velocity / self.programmed } else { 1.0 }
    }
}

/// The limits of a block that moves the axes by `delta` (mm or rad, in the machine's axis order)
/// and the tool tip by `length` (mm) at the programmed `feed` (mm/s), on a CNC with the given
/// interpolation `cycle_time` (s).
///
/// # Panics
/// If `delta` and `axes` differ in length, or `cycle_time` is not positive (a validated machine
/// never has either).
pub fn block_limits(axes: &[Axis], delta: &[f64], length: f64, feed: f64, cycle_time: f64) -> BlockLimits {
    assert_eq!(axes.len(), delta.len(), "one displacement per axis");
    assert!(cycle_time > 0.0, "the cycle time is positive");
    let programmed = if length > 0.0 && feed > 0.0 { feed / length } else { f64::INFINITY };
    let tightest = |limit: fn(&Axis) -> f64| {
        let mut best = (f64::INFINITY, None);
        for (index, (axis, d)) in axes.iter().zip(delta).enumerate() {
            if *d != 0.0 {
                let cap = limit(axis) / d.abs();
                if cap < best.0 {
                    best = (cap, Some(index));
                }
            }
        }
        best
    };
    let (axis_velocity, velocity_axis) = tightest(|a| a.vmax);
    let mut velocity = programmed;
    let mut limiter = Limiter::Programmed;
    if let Some(axis) = velocity_axis
        && axis_velocity < velocity
    {
        velocity = axis_velocity;
        limiter = Limiter::Axis(axis);
    }
    if 1.0 / cycle_time < velocity {
        velocity = 1.0 / cycle_time;
        limiter = Limiter::CycleTime;
    }
    BlockLimits { programmed, velocity, limiter, acceleration: tightest(|a| a.amax), jerk: tightest(|a| a.jmax) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use postpro_machine::Registry;

    /// The Mikron UCP 710 of paper 004 (X Y Z A C): Vmax 500 mm/s on X, Y, Z; A 0.25 rev/s,
    /// C 0.33 rev/s.
    fn mikron() -> Vec<Axis> {
        Registry::builtin().expect("built-ins load").find("mikron-ucp710").expect("built in").machine.axes.clone()
    }

    const PER_MIN: f64 = 1.0 / 60.0;

    #[test]
    fn a_long_slow_move_reaches_its_feed() {
        let limits = block_limits(&mikron(), &[10.0, 0.0, 0.0, 0.0, 0.0], 10.0, 6000.0 * PER_MIN, 0.003);
        assert_eq!(limits.limiter, Limiter::Programmed);
        assert!((limits.velocity - 10.0).abs() < 1e-12, "100 mm/s over 10 mm: {}", limits.velocity);
        assert_eq!(limits.feed_ratio(), 1.0);
        assert!((limits.acceleration.0 - 2500.0 / 10.0).abs() < 1e-9);
        assert_eq!(limits.acceleration.1, Some(0));
        assert!((limits.jerk.0 - 5000.0 / 10.0).abs() < 1e-9);
    }

    #[test]
    fn at_20_m_per_min_and_3_ms_a_block_shorter_than_1_mm_is_held_by_the_cycle() {
        let feed = 20_000.0 * PER_MIN;
        let short = block_limits(&mikron(), &[0.0, 0.5, 0.0, 0.0, 0.0], 0.5, feed, 0.003);
        assert_eq!(short.limiter, Limiter::CycleTime);
        assert!((short.feed_ratio() - 0.5).abs() < 1e-12, "half of F: {}", short.feed_ratio());
        let long = block_limits(&mikron(), &[0.0, 1.5, 0.0, 0.0, 0.0], 1.5, feed, 0.003);
        assert_eq!(long.limiter, Limiter::Programmed);
    }

    #[test]
    fn a_rotary_axis_holds_a_block_that_turns_far_for_a_short_tip_move() {
        // C turns 90° while the tip moves 2 mm at 5 m/min: C needs 0.25 rev in 0.024 s.
        let quarter = std::f64::consts::FRAC_PI_2;
        let limits = block_limits(&mikron(), &[1.0, 1.0, 0.0, 0.1, quarter], 2.0, 5000.0 * PER_MIN, 0.003);
        assert_eq!(limits.limiter, Limiter::Axis(4), "C velocity");
        let c_vmax = 0.33 * std::f64::consts::TAU;
        assert!((limits.velocity - c_vmax / quarter).abs() < 1e-9);
        assert!(limits.feed_ratio() < 0.1);
        // C also has the tightest acceleration; A's jerk (5 rev/s³ over 0.1 rad) is looser than
        // C's (50 rev/s³ over π/2), X's (5 m/s³ over 1 mm) looser still.
        assert_eq!(limits.acceleration.1, Some(4));
        assert_eq!(limits.jerk.1, Some(4));
    }

    #[test]
    fn a_pure_reorientation_is_held_by_its_axes_or_the_cycle() {
        let limits = block_limits(&mikron(), &[0.0, 0.0, 0.0, 0.2, 0.0], 0.0, 1000.0 * PER_MIN, 0.003);
        assert!(limits.programmed.is_infinite());
        assert_eq!(limits.limiter, Limiter::Axis(3));
        assert_eq!(limits.feed_ratio(), 1.0, "no tip feed to fall short of");
        let still = block_limits(&mikron(), &[0.0; 5], 0.0, 1000.0 * PER_MIN, 0.003);
        assert_eq!(still.limiter, Limiter::CycleTime);
        assert_eq!(still.acceleration, (f64::INFINITY, None));
    }
}
