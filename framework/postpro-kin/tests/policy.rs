//! The policy on the built-in machine definitions: Siemens NX's own Haas UMC-750 post on a real
//! simultaneous 5-axis CLSF (our B and C against the program it wrote), shortest turns and a
//! still free axis on random paths, a 90° swing of C at the pole linearised to the tolerance,
//! and unwinding at a rapid.

use std::f64::consts::PI;
use std::path::PathBuf;

use nalgebra::{Point3, Unit, Vector3};
use postpro_cl::{Source, Span, read};
use postpro_kin::{
    Decision, Kinematics, Pose, Solved, StepKind, Target, ToolLength, choose, linearize, solve, solver_for,
};
use postpro_machine::Registry;
use postpro_machine::model::{AxisKind, Machine, Travel};
use proptest::prelude::*;

fn machine(name: &str) -> Machine {
    Registry::builtin().expect("the built-in definitions load").find(name).expect("built in").machine.clone()
}

fn peers() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/peers");
    assert!(dir.is_dir(), "{} is missing: ../shared must sit beside the repository", dir.display());
    dir
}

/// The motion blocks of an NX/Haas program: the modal X, Y, Z (inch) and B, C (degrees) after
/// each block that moves in the part frame (G28 and G53 blocks move in machine coordinates and
/// are left out).
fn nx_blocks(text: &str) -> Vec<[f64; 5]> {
    let mut state: [Option<f64>; 5] = [None; 5];
    let mut out = Vec::new();
    for line in text.lines().filter(|l| l.starts_with('N')) {
        let code = line.split('(').next().unwrap_or_default();
        let words: Vec<&str> = code.split_whitespace().collect();
        if words.iter().any(|w| *w == "G28" || *w == "G53") {
            continue;
        }
        let mut moved = false;
        for w in &words {
            let Some(slot) = "XYZBC".find(&w[..1]) else { continue };
            state[slot] = Some(w[1..].parse().expect("a number"));
            moved |= slot < 3;
        }
        if moved && let [Some(x), Some(y), Some(z), Some(b), Some(c)] = state {
            out.push([x, y, z, b, c]);
        }
    }
    out
}

/// `APT_Variable_Axis.txt` (NX VARIABLE_CONTOUR, inch) on the Haas UMC-750 with its default
/// policy solves, and our B and C are the NX post's at every orientation, within 0.001° (the NX
/// program prints three decimals): its singular cone (0.1°) holds none of them (NX computes C
/// down to B 0.303°), and its pole passage (2°) lets B change sign where NX does. With TCP (G234) its X Y Z are the
/// CL points, which pairs its blocks with ours.
#[test]
fn variable_axis_on_the_haas_umc750_gives_the_nx_posts_angles() {
    let dir = peers().join("userFour__MECH491-postprocessor/Variable_Axis");
    let source = Source::from_path(&dir.join("input/APT_Variable_Axis.txt")).expect("readable");
    let nx = nx_blocks(
        &std::fs::read_to_string(dir.join("expected/PostProcessed_Variable_Axis.txt")).expect("the NX program"),
    );
    let m = machine("umc750");
    let kin = solver_for(&m);
    let solved = solve(kin.as_ref(), &read(&source), &m.policy).expect("posts with the default options");
    let (b, c) = (m.axis_index("B").expect("B"), m.axis_index("C").expect("C"));

    let cl: Vec<_> = solved.steps.iter().filter(|s| s.kind == StepKind::Cl).collect();
    let mut next = 0;
    let (mut compared, mut in_cone, mut largest) = (0, 0, 0.0f64);
    for block in &nx {
        // The CL points have four decimals, and NX rounds its own values again (1e-4 apart).
        let at = |s: &&postpro_kin::Step| (0..3).all(|i| (s.pose.tip[i] / 25.4 - block[i]).abs() < 1.5e-4);
        let k = next + cl[next..].iter().position(at).unwrap_or_else(|| panic!("no CL point at {block:?}"));
        next = k + 1;
        let step = cl[k];
        // The tool axis's distance from the pole (+z here: C's axis through the part zero).
        if step.pose.axis.z.clamp(-1.0, 1.0).acos() < m.policy.singular_cone {
            in_cone += 1;
            continue;
        }
        let (db, dc) = ((step.joints[b].to_degrees() - block[3]).abs(), (step.joints[c].to_degrees() - block[4]).abs());
        assert!(
            db <= 1e-3 && dc <= 1e-3,
            "{}: B {:.4} C {:.4}, NX B {} C {}",
            source.location(step.span.start as usize),
            step.joints[b].to_degrees(),
            step.joints[c].to_degrees(),
            block[3],
            block[4]
        );
        largest = largest.max(db).max(dc);
        compared += 1;
    }
    eprintln!(
        "Variable_Axis: {compared} orientations compared, {in_cone} inside the cone, largest difference {largest:.6}°"
    );
    assert_eq!((nx.len(), compared, in_cone), (348, 348, 0));
    // The NX post lets C swing by 87° in one block near the pole: a warning here, not an error.
    assert!(solved.decisions.iter().any(|d| matches!(d.decision, Decision::LargeRotaryStep { .. })));
}

fn endless_rotaries(m: &Machine) -> Vec<usize> {
    (0..m.axes.len()).filter(|&i| m.axes[i].kind == AxisKind::Rotary && m.axes[i].travel == Travel::Endless).collect()
}

fn rotaries(m: &Machine) -> Vec<usize> {
    (0..m.axes.len()).filter(|&i| m.axes[i].kind == AxisKind::Rotary).collect()
}

/// A smooth 5-axis path of `n` points: the tool axis tilted by up to 60° (through the pole when
/// the tilt's offset is small) and turning round it, the tip on a smooth curve near the part zero.
fn smooth_path(n: usize, c: &[f64]) -> Vec<Target> {
    (0..n)
        .map(|k| {
            let t = k as f64 / n as f64 * 2.0 * PI;
            let tilt = (c[0] * 60.0 * (t * (1.0 + c[1] * 2.0) + c[2] * 6.0).sin().abs() + c[3] * 5.0).to_radians();
            let azimuth = c[4] * 4.0 * t + c[5] * 3.0 * (2.0 * t).sin() + c[6] * 6.0;
            let axis =
                Unit::new_normalize(Vector3::new(tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), tilt.cos()));
            let tip = Point3::new(40.0 * (t + c[7]).cos(), 30.0 * (2.0 * t).sin(), 10.0 * c[8] * t.cos());
            Target { pose: Pose { tip, axis }, rapid: false, span: Span::new(k, k + 1) }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    /// On random smooth 5-axis paths an endless table never turns further than the shortest
    /// way between two consecutive positions (linearised ones included): at most half a turn.
    #[test]
    fn an_endless_table_never_turns_further_than_the_shortest_way(c in prop::collection::vec(0.0f64..1.0, 9)) {
        let targets = smooth_path(300, &c);
        for name in ["haas-umc750", "maho600e", "mikron-ucp710"] {
            let m = machine(name);
            let kin = solver_for(&m);
            let mut solved = choose(kin.as_ref(), &targets, &m.policy, None)
                .map_err(|e| TestCaseError::fail(format!("{name}: {e}")))?;
            linearize(kin.as_ref(), &mut solved.steps, &m.policy);
            for &r in &endless_rotaries(&m) {
                for w in solved.steps.windows(2) {
                    let turn = (w[1].joints[r] - w[0].joints[r]).abs();
                    prop_assert!(turn <= PI + 1e-9, "{name}: {} turns {}° at {:?}", m.axes[r].letter, turn.to_degrees(), w[1].span);
                }
            }
        }
    }

    /// A feed move whose tool axis passes near the pole (within 3°, across the singular cone and
    /// the pole passage), on every built-in 5-axis machine: the points linearization adds bring every
    /// piece within tolerance. A jump of the free axis at the cone's edge, or half a turn to the
    /// other branch, leaves the tip off the path.
    #[test]
    fn a_move_past_the_pole_is_linearised_within_tolerance(
        (x, y, z) in (-80.0f64..80.0, -80.0f64..80.0, -20.0f64..30.0),
        (dx, dy, dz) in (-8.0f64..8.0, -8.0f64..8.0, -1.0f64..1.0),
        (tilt0, tilt1) in (0.05f64..3.0, 0.05f64..3.0),
        (azimuth0, azimuth1) in (0.0f64..360.0, 0.0f64..360.0),
    ) {
        let axis = |tilt: f64, azimuth: f64| {
            let (t, a) = (tilt.to_radians(), azimuth.to_radians());
            Unit::new_normalize(Vector3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos()))
        };
        let targets = [
            Target { pose: Pose { tip: Point3::new(x, y, z), axis: axis(tilt0, azimuth0) }, rapid: false, span: Span::new(1, 2) },
            Target {
                pose: Pose { tip: Point3::new(x + dx, y + dy, z + dz), axis: axis(tilt1, azimuth1) },
                rapid: false,
                span: Span::new(2, 3),
            },
        ];
        for name in ["haas-umc750", "maho600e", "mikron-ucp710", "trunnion", "head-table", "nutating", "maho-generic", "mikron-generic"] {
            let m = machine(name);
            let kin = solver_for(&m);
            // A change of branch away from the pole is a discontinuity: not this test's.
            let Ok(mut solved) = choose(kin.as_ref(), &targets, &m.policy, None) else { continue };
            let (added, unsettled) =
                linearize::linearize_noting(kin.as_ref(), &mut solved.steps, &mut solved.decisions, &m.policy);
            prop_assert_eq!(unsettled.segments, 0, "{}: {:?} after {} points", name, unsettled, added);
            // Linearization checks each piece at seven points near the pole; between them (64
            // here) the tip may stray a little further (7 % is the most seen).
            let after = largest_tip_deviation(kin.as_ref(), &solved);
            prop_assert!(after <= 1.1 * m.policy.linearization_tolerance, "{name}: {after} mm after {added} points");
        }
    }

    /// On a 3-axis path (tool axis +z throughout, rapids here and there) no rotary axis moves,
    /// on any built-in machine: the free axis keeps its home value.
    #[test]
    fn on_a_3_axis_path_the_free_axis_does_not_move(
        tips in prop::collection::vec((-60.0f64..60.0, -60.0f64..60.0, -20.0f64..40.0, prop::bool::weighted(0.1)), 2..80)
    ) {
        let targets: Vec<Target> = tips
            .iter()
            .enumerate()
            .map(|(k, &(x, y, z, rapid))| Target {
                pose: Pose { tip: Point3::new(x, y, z), axis: Vector3::z_axis() },
                rapid,
                span: Span::new(k, k + 1),
            })
            .collect();
        for entry in Registry::builtin().expect("built-ins").entries() {
            let m = &entry.machine;
            let kin = solver_for(m);
            let solved = choose(kin.as_ref(), &targets, &m.policy, None)
                .map_err(|e| TestCaseError::fail(format!("{}: {e}", m.name)))?;
            for &r in &rotaries(m) {
                for s in &solved.steps {
                    prop_assert!((s.joints[r] - m.axes[r].home).abs() < 1e-12, "{}: {} at {}", m.name, m.axes[r].letter, s.joints[r]);
                }
            }
        }
    }
}

/// The largest distance of the interpolated tool tip from the programmed segment of each feed
/// move (from one CL step to the next, whatever was linearised between them), sampled densely
/// (64 samples per step).
fn largest_tip_deviation(kin: &dyn Kinematics, solved: &Solved) -> f64 {
    let steps = &solved.steps;
    let programmed: Vec<usize> = (0..steps.len()).filter(|&k| steps[k].kind != StepKind::Linearized).collect();
    let mut worst = 0.0f64;
    for w in programmed.windows(2) {
        let (a, b) = (steps[w[0]].pose.tip, steps[w[1]].pose.tip);
        let ab = b - a;
        for k in w[0]..w[1] {
            for n in 0..=64 {
                let tip = kin.forward(&steps[k].joints.lerp(&steps[k + 1].joints, f64::from(n) / 64.0)).tip;
                let t = if ab.norm_squared() > 0.0 {
                    ((tip - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                worst = worst.max((tip - (a + ab * t)).norm());
            }
        }
    }
    worst
}

/// A feed move that passes 0.34° from the pole, 76 mm off the C axis (line 224 of
/// `APT_Variable_Axis.txt`): the policy takes it as a pole passage, C swinging 44° while the tip
/// moves 7.6 mm. On the Mikron it passes through the singular cone (0.5°), where C is carried; on
/// the Haas outside it (0.1°), but within its pole passage (2°), on another branch at each end.
/// Either way the points linearization adds keep the axes continuous (C carried from where the
/// stretch near the pole begins to where it ends, the tilt through zero): no piece jumps half a
/// turn of C, and every piece comes within tolerance.
#[test]
fn a_move_through_the_singular_cone_is_linearised_within_tolerance() {
    for name in ["mikron", "haas-umc750"] {
        let m = machine(name);
        let kin = solver_for(&m);
        let pose = |tip: [f64; 3], axis: [f64; 3]| Pose {
            tip: Point3::from(tip),
            axis: Unit::new_normalize(Vector3::from(axis)),
        };
        let targets: Vec<Target> = [
            pose([-76.2, 7.62, 31.191], [-0.0097118, -0.0059519, 0.9999351]),
            pose([-76.2, 15.24, 31.237], [0.0262469, -0.0058125, 0.9996386]),
        ]
        .into_iter()
        .enumerate()
        .map(|(k, pose)| Target { pose, rapid: false, span: Span::new(k + 1, k + 2) })
        .collect();
        let mut solved = choose(kin.as_ref(), &targets, &m.policy, None).expect("a pole passage is motion");
        let c = m.axis_index("C").expect("C");
        let swing = (solved.steps[1].joints[c] - solved.steps[0].joints[c]).to_degrees();
        assert!(swing.abs() > 40.0, "{name}: C swings {swing}°");
        let (added, unsettled) =
            linearize::linearize_noting(kin.as_ref(), &mut solved.steps, &mut solved.decisions, &m.policy);
        assert_eq!(unsettled.segments, 0, "{name}: {unsettled:?}");
        let after = largest_tip_deviation(kin.as_ref(), &solved);
        assert!(after <= m.policy.linearization_tolerance, "{name}: {after} mm after {added} points");
        assert!(added < 1000, "{name}: {added} points");
        let largest_turn = solved.steps.windows(2).map(|w| (w[1].joints[c] - w[0].joints[c]).abs()).fold(0.0, f64::max);
        assert!(largest_turn.to_degrees() < 5.0, "{name}: C turns {}° in one piece", largest_turn.to_degrees());
        // The tool axis leaves the programmed one by no more than its distance from the pole.
        let mut sols = postpro_kin::Solutions::new();
        for s in &solved.steps {
            let off = kin.forward(&s.joints).axis.angle(&s.pose.axis);
            kin.inverse(&s.pose, &mut sols);
            let pole = sols.iter().filter_map(|s| s.pole).map(|(_, d)| d).fold(f64::INFINITY, f64::min);
            assert!(off <= pole + 1e-9, "{name}: the tool axis is {off} rad off, {pole} rad from the pole");
        }
    }
}

/// Near the pole a small change of the tool axis swings C by 90° in one block: on the Haas
/// UMC-750 (part 60 mm off the C axis) that is motion, linearised until the tip stays within the
/// tolerance of every programmed segment, with a warning for the large step.
#[test]
fn a_90_degree_swing_of_c_at_the_pole_is_linearised_within_tolerance() {
    let m = machine("haas-umc750");
    let kin = solver_for(&m);
    let axis = |tilt: f64, azimuth: f64| {
        let (t, a) = (tilt.to_radians(), azimuth.to_radians());
        Unit::new_normalize(Vector3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos()))
    };
    // 1° from the pole: three points at azimuths 0°, 90° and 100° (C swings 90°, then 10°).
    let targets: Vec<Target> = [(0.0, 0.0), (90.0, 1.0), (100.0, 2.0)]
        .iter()
        .enumerate()
        .map(|(k, &(azimuth, dx))| Target {
            pose: Pose { tip: Point3::new(60.0 + dx, 0.0, 5.0), axis: axis(1.0, azimuth) },
            rapid: false,
            span: Span::new(k + 1, k + 2),
        })
        .collect();
    let mut solved = choose(kin.as_ref(), &targets, &m.policy, None).expect("a swing at the pole is motion");
    let c = m.axis_index("C").expect("C");
    let swing = (solved.steps[1].joints[c] - solved.steps[0].joints[c]).to_degrees();
    assert!((swing.abs() - 90.0).abs() < 1e-6, "C swings {swing}°");
    assert!(solved.decisions.iter().any(|d| matches!(d.decision, Decision::LargeRotaryStep { .. }) && d.step == 1));
    let before = largest_tip_deviation(kin.as_ref(), &solved);
    let (added, unsettled) =
        linearize::linearize_noting(kin.as_ref(), &mut solved.steps, &mut solved.decisions, &m.policy);
    assert_eq!(unsettled.segments, 0, "{unsettled:?}");
    let after = largest_tip_deviation(kin.as_ref(), &solved);
    let tolerance = m.policy.linearization_tolerance;
    eprintln!("90° swing: deviation {before:.3} mm before, {after:.5} mm after, {added} points added");
    assert!(before > 10.0 && added > 10 && after <= tolerance, "before {before}, after {after}, added {added}");
    for s in &solved.steps {
        let back = kin.forward(&s.joints);
        assert!((back.tip - s.pose.tip).norm() < 1e-9);
    }
}

/// Across the nutating head's pole with a tool 60 mm longer than the definition's: C is held
/// through the singular run, so the tool axis reached is off the CL's within the cone; the tip is
/// on every CL point all the same, and the linearization keeps it within the tolerance with few
/// points (a tip off by the length times the axis's error could never be brought within it).
#[test]
fn across_the_pole_a_tool_of_another_length_keeps_its_tip_on_the_cl_points() {
    let m = machine("example-head-head-nutating");
    let inner = solver_for(&m);
    let kin = ToolLength::new(inner.as_ref(), m.chain.tool_length + 60.0);
    // 0.3 mm steps along X, the tool tilting from +1° to -1° about Y, 0.01° aside in Y.
    let targets: Vec<Target> = (0..=40)
        .map(|k| {
            let tilt = (1.0 - 0.05 * f64::from(k)).to_radians();
            let axis = Unit::new_normalize(Vector3::new(tilt.sin(), 0.01_f64.to_radians().sin(), tilt.cos()));
            let tip = Point3::new(-6.0 + 0.3 * f64::from(k), 0.0, 5.0);
            Target { pose: Pose { tip, axis }, rapid: false, span: Span::new(k as usize + 1, k as usize + 2) }
        })
        .collect();
    let mut solved = choose(&kin, &targets, &m.policy, None).expect("the pole is passed");
    assert!(
        solved.decisions.iter().any(|d| matches!(d.decision, Decision::SingularHold { .. })),
        "the path crosses the singular cone: {:?}",
        solved.decisions
    );
    let cone = m.policy.singular_cone;
    for s in &solved.steps {
        let back = kin.forward(&s.joints);
        assert!((back.tip - s.pose.tip).norm() < 1e-9, "tip {:?} for {:?}", back.tip, s.pose.tip);
        assert!(back.axis.angle(&s.pose.axis) <= cone + 1e-9);
    }
    let (added, unsettled) = linearize::linearize_noting(&kin, &mut solved.steps, &mut solved.decisions, &m.policy);
    assert_eq!(unsettled.segments, 0, "{unsettled:?}");
    assert!(largest_tip_deviation(&kin, &solved) <= m.policy.linearization_tolerance);
    assert!(added <= 200, "{added} points added for 40 CL intervals");
}

/// Winding beyond `unwind` (2 turns on the Haas) is undone at the next rapid, noted.
#[test]
fn winding_beyond_unwind_turns_is_undone_at_the_next_rapid() {
    let m = machine("haas-umc750");
    assert_eq!(m.policy.unwind, Some(2.0));
    let kin = solver_for(&m);
    let c = m.axis_index("C").expect("C");
    // Two and a half turns round the pole at 30° (a helix), a rapid up, and back down.
    let mut targets: Vec<Target> = (0..=180)
        .map(|k| {
            let a = k as f64 * 5f64.to_radians();
            let axis = Unit::new_normalize(Vector3::new(0.5 * a.cos(), 0.5 * a.sin(), 0.75f64.sqrt()));
            Target {
                pose: Pose { tip: Point3::new(20.0, 0.0, 0.1 * k as f64), axis },
                rapid: false,
                span: Span::new(k, k + 1),
            }
        })
        .collect();
    let n = targets.len();
    let last = targets[n - 1];
    targets.push(Target {
        pose: Pose { tip: last.pose.tip + Vector3::new(0.0, 0.0, 50.0), ..last.pose },
        rapid: true,
        span: Span::new(n, n + 1),
    });
    targets.push(Target { rapid: false, span: Span::new(n + 1, n + 2), ..last });
    let solved = choose(kin.as_ref(), &targets, &m.policy, None).expect("solvable");
    let wound = solved.steps[n - 1].joints[c] - solved.steps[0].joints[c];
    assert!((wound.abs().to_degrees() - 900.0).abs() < 1e-6, "wound {}°", wound.to_degrees());
    let at_rapid = solved.steps[n].joints[c];
    assert!(at_rapid.abs() <= PI + 1e-9, "C {}° at the rapid", at_rapid.to_degrees());
    assert!((solved.steps[n + 1].joints[c] - at_rapid).abs() < 1e-9);
    let unwound: Vec<_> = solved.decisions.iter().filter(|d| matches!(d.decision, Decision::Unwind { .. })).collect();
    assert_eq!(unwound.len(), 1);
    assert_eq!((unwound[0].step, unwound[0].span), (n, targets[n].span));
}
