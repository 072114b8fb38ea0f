//! The policy on the test machines: winding, the pole, true discontinuities (branch changes
//! away from the pole, travel limits), large steps as motion, the free axis through vertical
//! passes, whole-path against greedy, and linearization.

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};
use postpro_cl::Span;
use postpro_machine::model::{ClosedForm, OnDiscontinuity, PathChoice, SolverKind, Travel};

use super::*;
use crate::{linearize, solver_for, testing};

/// Mikron-like, A ∈ [−120°, 30°] and C with the given travel; the part frame parallel to the
/// table, so that tool axes read as in paper 000.
fn mikron_with_c(c: Travel) -> Box<dyn Kinematics> {
    let mut m = testing::mikron(SolverKind::ClosedForm(ClosedForm::MikronUcp710));
    m.chain.part_origin.rotation = UnitQuaternion::identity();
    m.axes[3].travel = Travel::Limited { min: (-120f64).to_radians(), max: 30f64.to_radians() };
    m.axes[4].travel = c;
    solver_for(&m)
}

fn mikron() -> Box<dyn Kinematics> {
    mikron_with_c(Travel::Endless)
}

/// A feed target at `tip` (its span starts at `n`, so that errors name it) with the tool axis
/// tilted by `tilt` from +z towards the azimuth `azimuth` (degrees).
fn oriented(n: usize, tip: Point3<f64>, tilt: f64, azimuth: f64) -> Target {
    let (t, a) = (tilt.to_radians(), azimuth.to_radians());
    let axis = Unit::new_normalize(Vector3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos()));
    Target { pose: Pose { tip, axis }, rapid: false, span: Span::new(n, n + 1) }
}

/// Tool axis tilted by `phi` (deg) in the y-z plane: (0, −sin φ, cos φ).
fn tilted(phi: f64, x: f64) -> Target {
    oriented(x as usize, Point3::new(x, 0.0, 0.0), phi.abs(), if phi >= 0.0 { -90.0 } else { 90.0 })
}

/// Feed targets going `turns` times round the pole, 30° from it, in steps of 5°.
fn round_the_pole(turns: usize) -> Vec<Target> {
    (0..=turns * 72).map(|k| oriented(k, Point3::new(40.0, 0.0, 0.0), 30.0, k as f64 * 5.0)).collect()
}

fn rapid(mut t: Target) -> Target {
    t.rapid = true;
    t
}

fn check_poses(kin: &dyn Kinematics, solved: &Solved, axis_tol: f64) {
    for s in &solved.steps {
        let back = kin.forward(&s.joints);
        assert!((back.tip - s.pose.tip).norm() < 1e-9, "tip off at {s:?}");
        assert!((back.axis.into_inner() - s.pose.axis.into_inner()).norm() < axis_tol, "axis off at {s:?}");
    }
}

fn c_of(solved: &Solved) -> Vec<f64> {
    solved.steps.iter().map(|s| s.joints[4].to_degrees()).collect()
}

fn noted(solved: &Solved, what: fn(&Decision) -> bool) -> Vec<&Noted> {
    solved.decisions.iter().filter(|d| what(&d.decision)).collect()
}

#[test]
fn an_endless_table_winds_over_five_turns_without_a_jump() {
    let kin = mikron();
    let targets = round_the_pole(5);
    let policy = kin.machine().policy.clone();
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
    check_poses(kin.as_ref(), &solved, 1e-9);
    let c = c_of(&solved);
    let total = (c[c.len() - 1] - c[0]).abs();
    assert!((total - 1800.0).abs() < 1e-6, "C turned {total}°");
    assert!(c.windows(2).all(|w| (w[1] - w[0]).abs() < 5.0 + 1e-9), "a jump in C");
    // Feed moves only: five turns, never unwound.
    assert!(noted(&solved, |d| matches!(d, Decision::Unwind { .. })).is_empty());
}

#[test]
fn winding_beyond_the_limit_is_undone_at_the_next_rapid_only() {
    let kin = mikron();
    // Three turns at feed, then a rapid away and a feed move back.
    let mut targets = round_the_pole(3);
    let n = targets.len();
    targets.push(rapid(oriented(n, Point3::new(40.0, 0.0, 50.0), 30.0, 10.0)));
    targets.push(oriented(n + 1, Point3::new(40.0, 0.0, 0.0), 30.0, 15.0));
    let mut policy = kin.machine().policy.clone();
    assert_eq!(policy.unwind, Some(2.0));
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
    check_poses(kin.as_ref(), &solved, 1e-9);
    let c = c_of(&solved);
    // Wound to three turns at feed; the rapid takes the equivalent nearest home (0°).
    assert!(((c[n - 1] - c[0]).abs() - 1080.0).abs() < 1e-6, "C {} → {}", c[0], c[n - 1]);
    assert!(c[n].abs() <= 180.0 + 1e-9, "C at the rapid {}", c[n]);
    assert!((c[n + 1] - c[n]).abs() < 5.0 + 1e-9);
    let unwound = noted(&solved, |d| matches!(d, Decision::Unwind { .. }));
    assert_eq!(unwound.len(), 1, "{:?}", solved.decisions);
    assert_eq!((unwound[0].step, unwound[0].span), (n, targets[n].span));
    assert!(unwound[0].decision.to_string().starts_with("C unwound at a rapid: "), "{}", unwound[0].decision);
    // `unwind: off`: the rapid turns the shortest way and the winding stays.
    policy.unwind = None;
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
    let c = c_of(&solved);
    assert!((c[n] - c[n - 1]).abs() <= 180.0 && c[n].abs() > 720.0, "C {} → {}", c[n - 1], c[n]);
    assert!(noted(&solved, |d| matches!(d, Decision::Unwind { .. })).is_empty());
}

#[test]
fn winding_is_undone_at_a_rapid_of_a_final_vertical_pass() {
    let kin = mikron();
    // Three turns at feed, then a vertical pass to the end of the path, entered by a rapid.
    let mut targets = round_the_pole(3);
    let n = targets.len();
    targets.push(rapid(oriented(n, Point3::new(40.0, 0.0, 50.0), 0.0, 0.0)));
    targets.extend((1..5).map(|k| oriented(n + k, Point3::new(40.0 + k as f64, 0.0, -1.0), 0.0, 0.0)));
    let policy = kin.machine().policy.clone();
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
    let c = c_of(&solved);
    assert!(c[n - 1].abs() > 720.0, "C {}", c[n - 1]);
    assert!(c[n].abs() <= 180.0 + 1e-9 && c[n..].iter().all(|&v| v == c[n]), "C {:?}", &c[n..]);
    let unwound = noted(&solved, |d| matches!(d, Decision::Unwind { .. }));
    assert_eq!(unwound.iter().map(|d| d.step).collect::<Vec<_>>(), [n]);
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
    assert!(!noted(&solved, |d| matches!(d, Decision::SingularHold { .. })).is_empty(), "{:?}", solved.decisions);
}

#[test]
fn a_pass_through_the_pole_that_needs_half_a_turn_turns_the_table_at_the_pole() {
    let kin = mikron();
    // A ∈ [−120°, 30°]: from −50° to +50° the tilt has to stay on A ≤ 0, so the table turns by
    // half a turn; it does so at the pole, where the tool axis does not care, and not as an error.
    let targets: Vec<Target> = (0..=100).map(|k| tilted(-50.0 + f64::from(k), f64::from(k))).collect();
    let policy = kin.machine().policy.clone();
    assert_eq!(policy.on_discontinuity, OnDiscontinuity::Error);
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("a pole passage is motion");
    check_poses(kin.as_ref(), &solved, policy.singular_cone);
    assert!(solved.steps.iter().all(|s| s.kind == StepKind::Cl && s.joints[3] <= 1e-12));
    let c = c_of(&solved);
    assert!((c[100] - c[0]).abs() > 179.9 && (c[100] - c[0]).abs() < 180.1, "C {} → {}", c[0], c[100]);
    // The table turns only on the two moves into and out of the pole (φ = 0), 90° each.
    for (k, w) in c.windows(2).enumerate() {
        let turn = (w[1] - w[0]).abs();
        if k == 49 || k == 50 {
            assert!((turn - 90.0).abs() < 1e-6, "move {k}: {turn}°");
        } else {
            assert!(turn < 1e-9, "move {k}: {turn}°");
        }
    }
    assert_eq!(noted(&solved, |d| matches!(d, Decision::LargeRotaryStep { .. })).len(), 2);
}

#[test]
fn a_branch_change_away_from_the_pole_is_an_error_or_a_retract() {
    // C ∈ [−100°, 100°]: each branch reaches 200° of azimuth. Tilted 20° and sweeping the
    // azimuth over 240°, the tool axis leaves the first branch's reach and must change branch,
    // 20° from the pole: the table would turn by 180°.
    let kin = mikron_with_c(Travel::Limited { min: (-100f64).to_radians(), max: 100f64.to_radians() });
    let targets: Vec<Target> =
        (0..=48).map(|k| oriented(k + 1, Point3::new(f64::from(k as u32), 0.0, 0.0), 20.0, 5.0 * k as f64)).collect();
    let mut policy = kin.machine().policy.clone();
    let err = choose(kin.as_ref(), &targets, &policy, None).expect_err("no continuous path");
    let SolveError::Discontinuity { span, axis, cause, from, to } = &err else { panic!("{err:?}") };
    assert_eq!((*cause, axis.as_str()), (Jump::BranchChange, "C"));
    assert!((to - from).abs() > 150.0, "{err}");
    assert!(span.start > 1 && span.start < 49, "{span:?}");
    assert!(err.to_string().starts_with("no continuous solution (the solution branch changes away from the pole)"));
    policy.on_discontinuity = OnDiscontinuity::Retract { clearance: 50.0 };
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("with a retract");
    check_poses(kin.as_ref(), &solved, 1e-9);
    let kinds: Vec<StepKind> = solved.steps.iter().map(|s| s.kind).filter(|k| *k != StepKind::Cl).collect();
    assert_eq!(kinds, [StepKind::Retract, StepKind::Reorient, StepKind::Reengage]);
    let retract = solved.steps.iter().find(|s| s.kind == StepKind::Retract).expect("retract");
    assert!(retract.rapid);
    assert_eq!(noted(&solved, |d| matches!(d, Decision::Retract { .. })).len(), 1);
    // Every feed move keeps its branch now.
    for w in solved.steps.windows(2) {
        if !w[1].rapid {
            assert!((w[1].joints[3] - w[0].joints[3]).abs() < 10f64.to_radians(), "{w:?}");
        }
    }
}

#[test]
fn a_travel_limit_during_a_feed_move_is_a_discontinuity_but_not_at_a_rapid() {
    // C ∈ [−200°, 200°] and a tilt of 40° (only A = −40° is within A's travel): one and a half
    // turns round the pole run into the end of C.
    let kin = mikron_with_c(Travel::Limited { min: (-200f64).to_radians(), max: 200f64.to_radians() });
    let mut targets: Vec<Target> =
        (0..=108).map(|k| oriented(k + 1, Point3::new(30.0, 0.0, 0.0), 40.0, 5.0 * k as f64)).collect();
    let policy = kin.machine().policy.clone();
    let err = choose(kin.as_ref(), &targets, &policy, None).expect_err("C runs out");
    let SolveError::Discontinuity { cause, axis, from, to, span } = &err else { panic!("{err:?}") };
    assert_eq!((*cause, axis.as_str()), (Jump::TravelLimit, "C"));
    assert!((to - from).abs() > 180.0, "{err}");
    // The same turn at a rapid (the tool away from the part) is fine.
    let k = span.start as usize - 1;
    targets[k].rapid = true;
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("turned back at the rapid");
    check_poses(kin.as_ref(), &solved, 1e-9);
    let c = c_of(&solved);
    assert!(c.iter().all(|c| c.abs() <= 200.0 + 1e-9));
    assert!((c[k] - c[k - 1]).abs() > 180.0);
}

#[test]
fn a_large_step_on_one_branch_is_motion_with_a_warning() {
    let kin = mikron();
    // 40° tilt; the azimuth jumps by 70° in one feed move: C turns 70° in one block.
    let targets = [
        oriented(1, Point3::new(0.0, 0.0, 0.0), 40.0, 0.0),
        oriented(2, Point3::new(5.0, 0.0, 0.0), 40.0, 10.0),
        oriented(3, Point3::new(10.0, 0.0, 0.0), 40.0, 80.0),
        oriented(4, Point3::new(15.0, 0.0, 0.0), 40.0, 85.0),
    ];
    let policy = kin.machine().policy.clone();
    let mut solved = choose(kin.as_ref(), &targets, &policy, None).expect("a large step is motion");
    let large = noted(&solved, |d| matches!(d, Decision::LargeRotaryStep { .. }));
    assert_eq!(large.len(), 1, "{:?}", solved.decisions);
    assert_eq!((large[0].step, large[0].span), (2, targets[2].span));
    let shown = large[0].decision.to_string();
    assert!(shown.starts_with("large rotary step: C ") && shown.ends_with("(70.000° in one block)"), "{shown}");
    let (added, unsettled) =
        linearize::linearize_noting(kin.as_ref(), &mut solved.steps, &mut solved.decisions, &policy);
    assert_eq!(unsettled.segments, 0, "{unsettled:?}");
    assert!(added > 0);
    let at = solved.decisions.iter().find(|d| matches!(d.decision, Decision::LargeRotaryStep { .. })).expect("kept");
    assert_eq!(solved.steps[at.step].span, targets[2].span, "the decision follows its step");
    for w in solved.steps.windows(2) {
        assert!(linearize::deviation(kin.as_ref(), &w[0], &w[1]) <= policy.linearization_tolerance);
    }
}

#[test]
fn a_vertical_pass_keeps_the_free_axis_and_the_table_turns_at_the_rapid() {
    let kin = mikron();
    let tip = |x: f64, z: f64| Point3::new(x, 10.0, z);
    // A 5-axis pass at azimuth 30°, a rapid up, a vertical (3-axis) pass, a rapid, and a 5-axis
    // pass at azimuth 120°.
    let mut targets = vec![];
    for k in 0..5 {
        targets.push(oriented(targets.len() + 1, tip(f64::from(k), 0.0), 20.0, 30.0));
    }
    targets.push(rapid(oriented(targets.len() + 1, tip(5.0, 50.0), 0.0, 0.0)));
    for k in 0..20 {
        targets.push(oriented(targets.len() + 1, tip(10.0 + f64::from(k), -1.0), 0.0, 0.0));
    }
    targets.push(rapid(oriented(targets.len() + 1, tip(30.0, 50.0), 0.0, 0.0)));
    let last_rapid = targets.len() - 1;
    for k in 0..5 {
        targets.push(oriented(targets.len() + 1, tip(40.0 + f64::from(k), 0.0), 20.0, 120.0));
    }
    let policy = kin.machine().policy.clone();
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
    check_poses(kin.as_ref(), &solved, policy.singular_cone);
    let c = c_of(&solved);
    // C keeps its value through the vertical pass and turns at the last rapid, and only there.
    for (k, w) in c.windows(2).enumerate() {
        if k + 1 != last_rapid {
            assert!((w[1] - w[0]).abs() < 1e-9, "C moves into step {}: {} → {}", k + 1, w[0], w[1]);
        }
    }
    assert!(((c[last_rapid] - c[last_rapid - 1]).abs() - 90.0).abs() < 1e-6);
    let held = noted(&solved, |d| matches!(d, Decision::SingularHold { .. }));
    assert_eq!(held.len(), 1);
    let Decision::SingularHold { from, to, points, .. } = held[0].decision else { unreachable!() };
    assert_eq!((held[0].step, points), (5, last_rapid - 4));
    assert!((from - c[4]).abs() < 1e-9 && (to - c[last_rapid]).abs() < 1e-9, "{}", held[0].decision);

    // Without the rapids (every move a feed) the table cannot turn away from the part: it turns
    // while the tool axis is on the pole (exact), in proportion to the length of each move of the
    // vertical pass, and keeps its value on the tilting moves into and out of it (where turning
    // would sweep the tool axis round the pole).
    let feed: Vec<Target> = targets.iter().map(|t| Target { rapid: false, ..*t }).collect();
    let solved = choose(kin.as_ref(), &feed, &policy, None).expect("solvable");
    check_poses(kin.as_ref(), &solved, policy.singular_cone);
    let c = c_of(&solved);
    let length = |k: usize| (feed[k + 1].pose.tip - feed[k].pose.tip).norm();
    let pass_length: f64 = (5..last_rapid).map(length).sum();
    let swing = c[last_rapid + 1] - c[4];
    assert!((swing.abs() - 90.0).abs() < 1e-6);
    for (k, w) in c.windows(2).enumerate() {
        let expected = if (5..last_rapid).contains(&k) { swing * length(k) / pass_length } else { 0.0 };
        assert!((w[1] - w[0] - expected).abs() < 1e-6, "C into step {}: {} → {}, not {expected}", k + 1, w[0], w[1]);
    }
}

#[test]
fn a_path_that_starts_and_stays_vertical_keeps_the_free_axis_at_home() {
    let kin = mikron();
    let mut targets: Vec<Target> =
        (0..30).map(|k| oriented(k + 1, Point3::new(f64::from(k as u32) * 3.0, -5.0, 0.0), 0.0, 0.0)).collect();
    targets[0].rapid = true;
    targets[10].rapid = true;
    let policy = kin.machine().policy.clone();
    let solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
    assert!(solved.steps.iter().all(|s| s.joints[3] == 0.0 && s.joints[4] == 0.0), "{:?}", solved.steps);
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
    let err = choose(kin.as_ref(), &targets, &policy, None).expect_err("greedy meets the limit");
    assert!(matches!(err, SolveError::Discontinuity { cause: Jump::BranchChange, .. }), "{err:?}");
}

#[test]
fn linearization_keeps_the_tip_within_tolerance() {
    let kin = mikron();
    let targets: Vec<Target> = (0..=10).map(|k| tilted(-20.0 + 4.0 * f64::from(k), 30.0 * f64::from(k))).collect();
    let policy = kin.machine().policy.clone();
    let mut solved = choose(kin.as_ref(), &targets, &policy, None).expect("solvable");
    let before: f64 =
        solved.steps.windows(2).map(|w| linearize::deviation(kin.as_ref(), &w[0], &w[1])).fold(0.0, f64::max);
    let added = linearize::linearize(kin.as_ref(), &mut solved.steps, &policy);
    let after: f64 =
        solved.steps.windows(2).map(|w| linearize::deviation(kin.as_ref(), &w[0], &w[1])).fold(0.0, f64::max);
    assert!(before > 0.01 && added > 0 && after <= 0.01, "before {before}, after {after}, added {added}");
    check_poses(kin.as_ref(), &solved, policy.singular_cone);
}

/// A position whose axis values do not put the tip on its CL point is an error naming the
/// statement, never a step: here the path crosses the pole at its third target.
#[test]
fn a_solution_that_misses_the_tip_is_an_error_not_motion() {
    let targets: Vec<Target> =
        [2.0, 1.0, 0.0, -1.0, -2.0].iter().enumerate().map(|(k, &phi)| tilted(phi, k as f64)).collect();
    let policy = mikron().machine().policy.clone();
    let solved = choose(mikron().as_ref(), &targets, &policy, None).expect("solvable");
    assert!(
        solved.decisions.iter().any(|d| matches!(d.decision, Decision::SingularHold { .. })),
        "the pole is crossed"
    );
    // A solver whose held solutions (at the pole) are off by 0.05 mm in X.
    let mikron = mikron();
    let off = testing::Wrapped { inner: mikron.as_ref(), held_error: 0.05 };
    let err = choose(&off, &targets, &policy, None).expect_err("the tip is off");
    let SolveError::TipOff { span, off, .. } = &err else { panic!("{err:?}") };
    assert_eq!(*span, targets[2].span);
    assert!((off - 0.05).abs() < 1e-9, "{off}");
}
