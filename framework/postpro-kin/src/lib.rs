//! # postpro-kin: from poses in the part frame to axis values
//!
//! - [`Kinematics`]: forward kinematics and **every** inverse solution of a machine. Two solvers:
//!   the generic serial chain ([`Chain`]: product of exponentials, Paden–Kahan subproblems, any
//!   axis directions and offsets) and hand-derived closed forms ([`TableTableClosedForm`]).
//!   **IK never picks a branch.**
//! - [`policy`]: the choice among the solutions along a path (preferred branch, ranges,
//!   unwinding of endless axes, singularities, whole-path dynamic programming or greedy,
//!   discontinuities), every non-obvious decision reported.
//! - [`bspline`]: the cubic B-spline a CNC interpolates through axis positions (Siemens
//!   `BSPLINE`), fitted within tolerance, with its derivatives.
//! - [`linearize`](mod@linearize): extra points so that the tool tip, moving with the axes interpolated
//!   linearly, stays within tolerance of the programmed segment.

mod bits;
pub mod bspline;
mod chain;
mod closed;
pub mod linearize;
mod path;
pub mod policy;
mod pose;
mod solver;
mod tool;

pub use chain::Chain;
pub use closed::TableTableClosedForm;
pub use linearize::{Linearizer, Linearizing, Shape, Unsettled, linearize};
pub use path::{targets, targets_of};
pub use policy::{
    BranchGraph, Choice, Collected, Decision, Jump, Noted, Placer, Policy, SolveError, Solved, Step, StepKind,
    StepSink, Target, choose,
};
pub use pose::{Bend, Joints, MAX_AXES, Pose, PoseRate};
pub use solver::{Kinematics, Solution, Solutions, solver_for};
pub use tool::{LengthFrom, Stretches, ToolLength, ToolPlacer, solve_with_tools, tool_changes};

/// Solves a tool path on a machine: the targets of the path, the policy's choice, then
/// linearization within the policy's tolerance (decision steps are kept in step with it).
pub fn solve(kin: &dyn Kinematics, path: &postpro_cl::ToolPath, policy: &Policy) -> Result<Solved, SolveError> {
    let targets = targets(path, policy.linearization_tolerance);
    let mut solved = choose(kin, &targets, policy, None)?;
    (solved.inserted, solved.unsettled) =
        linearize::linearize_noting(kin, &mut solved.steps, &mut solved.decisions, policy);
    Ok(solved)
}

#[cfg(test)]
mod testing;

#[cfg(test)]
mod tests {
    use nalgebra::{Point3, Unit, Vector3};
    use postpro_machine::model::{ClosedForm, SolverKind};

    use super::*;

    fn poses() -> Vec<Pose> {
        let mut out = Vec::new();
        for k in 0..40 {
            let t = f64::from(k) * 0.37;
            let axis =
                Unit::new_normalize(Vector3::new(t.sin() * 0.6, (t * 1.3).cos() * 0.5, 0.6 + 0.4 * (t * 0.7).sin()));
            out.push(Pose { tip: Point3::new(10.0 * t.cos(), -20.0 + t, 5.0 * t.sin()), axis });
        }
        out
    }

    fn round_trip(kin: &dyn Kinematics, reachable_min: usize) {
        let mut sols = Solutions::new();
        let mut reached = 0;
        for pose in poses() {
            kin.inverse(&pose, &mut sols);
            if !sols.is_empty() {
                reached += 1;
            }
            for s in sols.iter() {
                let back = kin.forward(&s.joints);
                assert!((back.tip - pose.tip).norm() < 1e-9, "tip {:?} vs {:?} ({:?})", back.tip, pose.tip, s);
                assert!(
                    (back.axis.into_inner() - pose.axis.into_inner()).norm() < 1e-9,
                    "axis {:?} vs {:?}",
                    back.axis,
                    pose.axis
                );
            }
        }
        assert!(reached >= reachable_min, "only {reached} poses reached");
    }

    #[test]
    fn forward_of_inverse_is_identity_for_every_layout() {
        round_trip(&Chain::new(testing::mikron(SolverKind::Generic)), 40);
        round_trip(&Chain::new(testing::maho(SolverKind::Generic)), 40);
        round_trip(&Chain::new(testing::head_table()), 40);
        // A 45° nutating head reaches the hemisphere it can tilt into.
        round_trip(&Chain::new(testing::nutating()), 20);
        let mikron = testing::mikron(SolverKind::ClosedForm(ClosedForm::MikronUcp710));
        round_trip(solver_for(&mikron).as_ref(), 40);
        let maho = testing::maho(SolverKind::ClosedForm(ClosedForm::Maho600e));
        round_trip(solver_for(&maho).as_ref(), 40);
    }

    #[test]
    fn the_rate_of_the_forward_kinematics_is_its_derivative() {
        let mikron = testing::mikron(SolverKind::ClosedForm(ClosedForm::MikronUcp710));
        let solvers = [
            Chain::new(testing::mikron(SolverKind::Generic)),
            Chain::new(testing::maho(SolverKind::Generic)),
            Chain::new(testing::head_table()),
            Chain::new(testing::nutating()),
        ];
        let closed = solver_for(&mikron);
        let mut kins: Vec<&dyn Kinematics> = solvers.iter().map(|c| c as &dyn Kinematics).collect();
        kins.push(closed.as_ref());
        for kin in kins {
            let longer = ToolLength::new(kin, kin.machine().chain.tool_length + 35.0);
            for kin in [kin, &longer] {
                for k in 0..20 {
                    let t = f64::from(k) * 0.41;
                    let joints = Joints::from_slice(&[
                        10.0 * t.cos(),
                        t - 5.0,
                        3.0 * t.sin(),
                        0.7 * (1.3 * t).sin(),
                        2.0 * (0.9 * t).cos(),
                    ]);
                    let rates = Joints::from_slice(&[0.3, -1.2, 0.5, 0.8 * t.cos(), -0.6]);
                    let exact = kin.forward_rate(&joints, &rates);
                    let by_difference = testing::Wrapped { inner: kin, held_error: 0.0 }.forward_rate(&joints, &rates);
                    assert!((exact.tip - by_difference.tip).norm() < 1e-5, "{exact:?} vs {by_difference:?}");
                    assert!((exact.axis - by_difference.axis).norm() < 1e-7, "{exact:?} vs {by_difference:?}");
                    // Not a trivial agreement: the tip does move, and it turns.
                    assert!(exact.tip.norm() > 0.1 && exact.axis.norm() > 0.1);
                }
            }
        }
    }

    /// `whole_turns` is `2π · round(angle / 2π)` to the bit: signed zeros, the half turns and
    /// either side of them, many turns, and what is not a number.
    #[test]
    fn whole_turns_are_the_rounded_turns_to_the_bit() {
        use std::f64::consts::{PI, TAU};
        let mut angles = vec![0.0, -0.0, 1e-300, -1e-300, 1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        for edge in [PI, 3.0 * PI, 0.5 * TAU, 1e6 * TAU + PI] {
            for a in [edge, -edge] {
                angles.extend([a, a.next_up(), a.next_down()]);
            }
        }
        angles.extend((-4000..4000).map(|k| f64::from(k) * 0.00731));
        for a in angles {
            let (got, expected) = (chain::whole_turns(a), TAU * (a / TAU).round());
            assert!(
                got.to_bits() == expected.to_bits() || got.is_nan() && expected.is_nan(),
                "{a}: {got} vs {expected}"
            );
        }
    }

    /// Along the linear move `a → b`, at 31 points: the tip and the tool axis stay within
    /// `bend · t(1 − t)/2` of their chords (asserted). Returns the bend and the least bound of
    /// the tip's the move itself shows (its largest deviation over `t(1 − t)/2`).
    fn within_bend(kin: &dyn Kinematics, a: &Joints, b: &Joints) -> (Bend, f64) {
        let bend = kin.bend(a, b).expect("a chain bounds its bend");
        let (pa, pb) = (kin.forward(a), kin.forward(b));
        let mut shown: f64 = 0.0;
        for n in 1..32 {
            let t = f64::from(n) / 32.0;
            let p = kin.forward(&a.lerp(b, t));
            let off = (p.tip.coords - pa.tip.coords.lerp(&pb.tip.coords, t)).norm();
            let turned = (p.axis.into_inner() - pa.axis.into_inner().lerp(&pb.axis.into_inner(), t)).norm();
            let room = t * (1.0 - t) / 2.0;
            assert!(off <= bend.tip * room + 1e-9, "tip {off} at {t} from {a:?} to {b:?}: {bend:?}");
            assert!(turned <= bend.axis * room + 1e-12, "axis {turned} at {t} from {a:?} to {b:?}: {bend:?}");
            shown = shown.max(off / room);
        }
        (bend, shown)
    }

    /// The bend bound on every layout, with the rotary centres far apart (each turn's distance
    /// from the last centre counts): the tip and axis stay within `bend · t(1 − t)/2` of their
    /// chords, and the bound is not loose by more than a few times (a bound that said nothing
    /// would pass the first check).
    #[test]
    fn the_bend_bounds_the_tool_on_every_layout() {
        let apart = testing::machine(
            &[("A", [1.0, 0.0, 0.0], [0.0, 150.0, -90.0], true), ("C", [0.0, 0.0, 1.0], [-260.0, 40.0, 120.0], true)],
            SolverKind::Generic,
        );
        let heads = testing::machine(
            &[("C", [0.0, 0.0, 1.0], [90.0, -60.0, 500.0], false), ("A", [1.0, 0.0, 0.0], [0.0, 40.0, 260.0], false)],
            SolverKind::Generic,
        );
        // With the tip on A's centre: C alone turning (C's distance is A's centre's), A turning
        // slowly as Y moves (the rate's cross term), and fast as Y moves far (the segment's end).
        let on_a = Point3::new(0.0, 150.0, -90.0) - apart.chain.tool_tip();
        let from = Joints::from_slice(&[on_a.x, on_a.y, on_a.z, 0.0, 0.0]);
        let to = |d: [f64; 5]| Joints::from_slice(&std::array::from_fn::<f64, 5, _>(|i| from[i] + d[i]));
        let cases = [to([0.0, 0.0, 0.0, 0.0, 1.0]), to([0.0, 100.0, 0.0, 0.01, 0.0]), to([0.0, 300.0, 0.0, 2.0, 0.0])];
        let chain = Chain::new(apart.clone());
        for b in cases {
            within_bend(&chain, &from, &b);
        }
        let chains = [
            Chain::new(testing::mikron(SolverKind::Generic)),
            Chain::new(testing::maho(SolverKind::Generic)),
            Chain::new(testing::head_table()),
            Chain::new(testing::nutating()),
            Chain::new(apart),
            Chain::new(heads),
        ];
        for chain in &chains {
            let longer = ToolLength::new(chain, chain.machine().chain.tool_length + 120.0);
            let mut tightest = f64::INFINITY;
            for kin in [chain as &dyn Kinematics, &longer] {
                for k in 0..40 {
                    let s = f64::from(k) * 0.37;
                    let a =
                        Joints::from_slice(&[40.0 * s.cos(), 30.0 - s, 9.0 * s.sin(), 0.9 * s.sin(), 2.0 * s.cos()]);
                    let size = f64::from(k % 8 + 1) / 8.0;
                    let d = [60.0 * size, -25.0 * size, 40.0 * size, 0.8 * size * s.cos(), -1.1 * size];
                    let b = Joints::from_slice(&std::array::from_fn::<f64, 5, _>(|i| a[i] + d[i]));
                    let (bend, shown) = within_bend(kin, &a, &b);
                    tightest = tightest.min(bend.tip / shown);
                }
            }
            assert!(tightest < 4.0, "{}: the bound is at best {tightest} times the bend", chain.machine().name);
        }
    }

    #[test]
    fn closed_forms_agree_with_the_generic_chain() {
        for (form, machine) in
            [(ClosedForm::MikronUcp710, testing::mikron as fn(SolverKind) -> _), (ClosedForm::Maho600e, testing::maho)]
        {
            let generic = Chain::new(machine(SolverKind::Generic));
            let closed = TableTableClosedForm::new(machine(SolverKind::ClosedForm(form)), form).expect("shape");
            let (mut a, mut b) = (Solutions::new(), Solutions::new());
            for pose in poses() {
                generic.inverse(&pose, &mut a);
                closed.inverse(&pose, &mut b);
                assert_eq!(a.len(), b.len());
                for s in b.iter() {
                    let close = a.iter().any(|g| {
                        g.joints.as_slice().iter().zip(s.joints.as_slice()).all(|(x, y)| (x - y).abs() < 1e-9)
                    });
                    assert!(close, "closed {:?} not among generic {:?}", s, a);
                }
            }
            // The forward kinematics and its rate, written out per coordinate axis, are the
            // chain's to rounding, at any angles (the poses' solutions and beyond a turn).
            for k in 0..200 {
                let t = f64::from(k) * 0.173;
                let joints = Joints::from_slice(&[
                    300.0 * t.cos(),
                    t * 7.0 - 150.0,
                    -40.0 * t.sin(),
                    4.0 * (1.3 * t).sin(),
                    9.0 * (0.7 * t).cos(),
                ]);
                let rates = Joints::from_slice(&[0.3, -1.2, 0.5, 0.8 * t.cos(), -0.6 * (2.1 * t).sin()]);
                let (g, c) = (generic.forward(&joints), closed.forward(&joints));
                assert!((g.tip - c.tip).norm() < 1e-10, "{form:?} at {joints:?}: {g:?} vs {c:?}");
                assert!((g.axis.into_inner() - c.axis.into_inner()).norm() < 1e-14, "{form:?}: {g:?} vs {c:?}");
                let (g, c) = (generic.forward_rate(&joints, &rates), closed.forward_rate(&joints, &rates));
                assert!((g.tip - c.tip).norm() < 1e-10, "{form:?} at {joints:?}: {g:?} vs {c:?}");
                assert!((g.axis - c.axis).norm() < 1e-14, "{form:?}: {g:?} vs {c:?}");
            }
        }
    }
}
