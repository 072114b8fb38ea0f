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
//! - [`linearize`]: extra points so that the tool tip, moving with the axes interpolated
//!   linearly, stays within tolerance of the programmed segment.

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
pub use linearize::linearize;
pub use path::targets;
pub use policy::{Decision, Noted, Policy, SolveError, Solved, Step, StepKind, Target, choose};
pub use pose::{Joints, MAX_AXES, Pose};
pub use solver::{Kinematics, Solution, Solutions, solver_for};
pub use tool::{LengthFrom, ToolLength, solve_with_tools, tool_changes};

/// Solves a tool path on a machine: the targets of the path, the policy's choice, then
/// linearization within the policy's tolerance (decision steps are kept in step with it).
pub fn solve(kin: &dyn Kinematics, path: &postpro_cl::ToolPath, policy: &Policy) -> Result<Solved, SolveError> {
    let targets = targets(path, policy.linearization_tolerance);
    let mut solved = choose(kin, &targets, policy, None)?;
    solved.inserted = linearize::linearize_noting(kin, &mut solved.steps, &mut solved.decisions, policy);
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
        }
    }
}

#[cfg(test)]
mod policy_tests {
    use nalgebra::{Point3, Unit, Vector3};
    use postpro_cl::Span;
    use postpro_machine::model::{ClosedForm, OnDiscontinuity, PathChoice, SolverKind, Travel};

    use super::*;

    fn mikron() -> Box<dyn Kinematics> {
        let mut m = testing::mikron(SolverKind::ClosedForm(ClosedForm::MikronUcp710));
        // The part frame parallel to the table, so tool axes read as in paper 000.
        m.chain.part_origin.rotation = nalgebra::UnitQuaternion::identity();
        m.axes[3].travel = Travel::Limited { min: (-120f64).to_radians(), max: 30f64.to_radians() };
        m.axes[4].travel = Travel::Endless;
        solver_for(&m)
    }

    /// Tool axis tilted by `phi` (deg) in the y-z plane: (0, −sin φ, cos φ).
    fn tilted(phi: f64, x: f64) -> Target {
        let p = phi.to_radians();
        Target {
            pose: Pose {
                tip: Point3::new(x, 0.0, 0.0),
                axis: Unit::new_normalize(Vector3::new(0.0, -p.sin(), p.cos())),
            },
            rapid: false,
            span: Span::new(x as usize, x as usize + 1),
        }
    }

    fn check_poses(kin: &dyn Kinematics, solved: &Solved, axis_tol: f64) {
        for s in &solved.steps {
            let back = kin.forward(&s.joints);
            assert!((back.tip - s.pose.tip).norm() < 1e-9, "tip off at {s:?}");
            assert!((back.axis.into_inner() - s.pose.axis.into_inner()).norm() < axis_tol, "axis off at {s:?}");
        }
    }

    #[test]
    fn an_endless_table_unwinds_over_five_turns() {
        let kin = mikron();
        let targets: Vec<Target> = (0..=5 * 72)
            .map(|k| {
                let c = f64::from(k) * 5f64.to_radians();
                let axis = Unit::new_normalize(Vector3::new(c.sin() * 0.5, -c.cos() * 0.5, 0.75f64.sqrt()));
                Target {
                    pose: Pose { tip: Point3::new(40.0 * c.cos(), 40.0 * c.sin(), 0.0), axis },
                    rapid: false,
                    span: Span::default(),
                }
            })
            .collect();
        let policy = kin.machine().policy.clone();
        let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
        check_poses(kin.as_ref(), &solved, 1e-9);
        let c: Vec<f64> = solved.steps.iter().map(|s| s.joints[4].to_degrees()).collect();
        let total = (c[c.len() - 1] - c[0]).abs();
        assert!((total - 1800.0).abs() < 1e-6, "C turned {total}°");
        assert!(c.windows(2).all(|w| (w[1] - w[0]).abs() < 5.0 + 1e-9), "a jump in C");
    }

    #[test]
    fn a_path_through_the_pole_keeps_the_table_still() {
        let kin = mikron();
        let targets: Vec<Target> = (0..=40).map(|k| tilted(20.0 - f64::from(k), f64::from(k))).collect();
        let policy = kin.machine().policy.clone();
        let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
        check_poses(kin.as_ref(), &solved, policy.singular_cone);
        for s in &solved.steps {
            assert!(s.joints[4].abs() < 1e-9, "C moved: {:?}", s.joints);
        }
        let a: Vec<f64> = solved.steps.iter().map(|s| s.joints[3].to_degrees()).collect();
        assert!((a[0] - 20.0).abs() < 1e-9 && (a[40] + 20.0).abs() < 1e-9, "A went {a:?}");
        assert!(
            solved.decisions.iter().any(|d| matches!(d.decision, Decision::SingularHold { .. })),
            "{:?}",
            solved.decisions
        );
    }

    #[test]
    fn a_forced_branch_switch_is_an_error_or_a_retract() {
        let kin = mikron();
        // A ∈ [−120°, 30°]: tilts below −30° only on one branch, above +30° only on the other.
        let targets: Vec<Target> = (0..=100).map(|k| tilted(-50.0 + f64::from(k), f64::from(k))).collect();
        let mut policy = kin.machine().policy.clone();
        let err = choose(kin.as_ref(), &targets, &policy, None).expect_err("no continuous path");
        let SolveError::Discontinuity { span, axis, .. } = &err else { panic!("{err:?}") };
        assert_eq!(axis, "C");
        assert!(span.start > 0 && span.start < 100);
        policy.on_discontinuity = OnDiscontinuity::Retract { clearance: 50.0 };
        let solved = choose(kin.as_ref(), &targets, &policy, None).expect("with a retract");
        check_poses(kin.as_ref(), &solved, policy.singular_cone);
        let kinds: Vec<StepKind> = solved.steps.iter().map(|s| s.kind).filter(|k| *k != StepKind::Cl).collect();
        assert_eq!(kinds, [StepKind::Retract, StepKind::Reorient, StepKind::Reengage]);
        let retract = solved.steps.iter().find(|s| s.kind == StepKind::Retract).expect("retract");
        assert!(retract.rapid);
        assert!(solved.decisions.iter().any(|d| matches!(d.decision, Decision::Retract { .. })));
        // Every feed move is continuous now.
        for w in solved.steps.windows(2) {
            if !w[1].rapid {
                assert!((w[1].joints[4] - w[0].joints[4]).abs() <= policy.max_rotary_step, "{w:?}");
            }
        }
    }

    #[test]
    fn whole_path_avoids_the_switch_greedy_walks_into() {
        let kin = mikron();
        // From 10° to 50°: greedy starts on A = +φ (nearest to home) and must switch at 30°;
        // the whole-path choice takes A = −φ, C = 180° from the start.
        let targets: Vec<Target> = (0..=40).map(|k| tilted(10.0 + f64::from(k), f64::from(k))).collect();
        let mut policy = kin.machine().policy.clone();
        let solved = choose(kin.as_ref(), &targets, &policy, None).expect("whole path");
        assert!(solved.steps.iter().all(|s| s.joints[3] <= 0.0));
        policy.choice = PathChoice::Greedy;
        assert!(matches!(choose(kin.as_ref(), &targets, &policy, None), Err(SolveError::Discontinuity { .. })));
    }

    #[test]
    fn linearization_keeps_the_tip_within_tolerance() {
        let kin = mikron();
        let targets: Vec<Target> = (0..=10).map(|k| tilted(-20.0 + 4.0 * f64::from(k), 30.0 * f64::from(k))).collect();
        let policy = kin.machine().policy.clone();
        let mut solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
        let before: f64 =
            solved.steps.windows(2).map(|w| linearize::deviation(kin.as_ref(), &w[0], &w[1])).fold(0.0, f64::max);
        let added = linearize(kin.as_ref(), &mut solved.steps, &policy);
        let after: f64 =
            solved.steps.windows(2).map(|w| linearize::deviation(kin.as_ref(), &w[0], &w[1])).fold(0.0, f64::max);
        assert!(before > 0.01 && added > 0 && after <= 0.01, "before {before}, after {after}, added {added}");
        check_poses(kin.as_ref(), &solved, 1e-9);
    }
}
