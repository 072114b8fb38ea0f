//! The solvers on every built-in and example machine definition: forward of inverse is the
//! identity, the closed forms agree with the generic chain, paper 000's Table 2, a MAHO 600E
//! pose worked by hand from paper 002, and the real CL files of `../shared/data/cl` (pinned).

use std::f64::consts::PI;
use std::path::PathBuf;

use nalgebra::{Point3, Unit, Vector3};
use postpro_cl::{Source, read};
use postpro_kin::{
    Chain, Decision, Joints, Kinematics, Pose, Solutions, SolveError, StepKind, ToolLength, solve, solver_for,
};
use postpro_machine::Registry;
use postpro_machine::model::{AxisKind, Machine, SolverKind, Travel};
use proptest::prelude::*;

fn registry() -> Registry {
    Registry::builtin().expect("the built-in definitions load")
}

fn machine(name: &str) -> Machine {
    registry().find(name).expect("built in").machine.clone()
}

/// Random axis values inside every travel (endless rotaries: one turn either way).
fn joints_in_travel(m: &Machine, unit: &[f64]) -> Joints {
    let mut j = Joints::zeros(m.axes.len());
    for (i, a) in m.axes.iter().enumerate() {
        let (lo, hi) = match a.travel {
            Travel::Limited { min, max } => (min, max),
            Travel::Endless => (-PI, PI),
        };
        // Linear axes: a box around the middle of the travel keeps the tip near the part.
        let (lo, hi) =
            if a.kind == AxisKind::Linear { ((lo + hi) / 2.0 - 200.0, (lo + hi) / 2.0 + 200.0) } else { (lo, hi) };
        j[i] = lo + (hi - lo) * unit[i % unit.len()];
    }
    j
}

fn same_angle(a: f64, b: f64) -> bool {
    let d = (a - b).rem_euclid(2.0 * PI);
    d < 1e-9 || 2.0 * PI - d < 1e-9
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, .. ProptestConfig::default() })]

    /// FK(IK(pose)) = pose within 1e-9 for every branch, on every built-in and example machine,
    /// for random poses in range; and the axis values the pose came from are among the solutions.
    #[test]
    fn forward_of_every_inverse_solution_is_the_pose(unit in prop::collection::vec(0.0f64..1.0, 6)) {
        for entry in registry().entries() {
            let kin = solver_for(&entry.machine);
            let m = kin.machine();
            let original = joints_in_travel(m, &unit);
            let pose = kin.forward(&original);
            let mut sols = Solutions::new();
            kin.inverse(&pose, &mut sols);
            prop_assert!(!sols.is_empty(), "{}: no solution for a pose it reached", m.name);
            for s in sols.iter() {
                let back = kin.forward(&s.joints);
                prop_assert!((back.tip - pose.tip).norm() < 1e-9, "{}: tip {:?} vs {:?}", m.name, back.tip, pose.tip);
                prop_assert!((back.axis.into_inner() - pose.axis.into_inner()).norm() < 1e-9, "{}: axis", m.name);
            }
            let singular = sols.iter().any(|s| s.pole.is_some_and(|(_, d)| d < 1e-6));
            let found = sols.iter().any(|s| {
                m.axes.iter().enumerate().all(|(i, a)| match a.kind {
                    AxisKind::Linear => (s.joints[i] - original[i]).abs() < 1e-7,
                    AxisKind::Rotary => same_angle(s.joints[i], original[i]),
                })
            });
            prop_assert!(found || singular, "{}: {:?} not among {:?}", m.name, original, sols);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, .. ProptestConfig::default() })]

    /// What the kinematics' bend bounds holds: while the axes move linearly, the tool tip and
    /// the tool axis stay within `bend · t(1 − t)/2` of the chord of their ends (the bound the
    /// linearization skips its samples on). Every built-in and example machine, as its solver
    /// and as the generic chain, with the definition's tool and one 150 mm longer; moves from
    /// nothing to 2 rad and 300 mm an axis.
    #[test]
    fn the_tool_stays_within_its_bend_of_the_chord(
        unit in prop::collection::vec(0.0f64..1.0, 6),
        step in prop::collection::vec(-1.0f64..1.0, 6),
        scale in 0.0f64..1.0,
    ) {
        for entry in registry().entries() {
            let m = &entry.machine;
            let solvers: [Box<dyn Kinematics>; 2] = [solver_for(m), Box::new(Chain::new(m.clone()))];
            for solver in &solvers {
                for longer in [0.0, 150.0] {
                    let kin = ToolLength::new(solver.as_ref(), m.chain.tool_length + longer);
                    let a = joints_in_travel(m, &unit);
                    let mut b = a;
                    for (i, axis) in m.axes.iter().enumerate() {
                        let most = if axis.kind == AxisKind::Linear { 300.0 } else { 2.0 };
                        b[i] += step[i] * most * scale * scale;
                    }
                    let bend = kin.bend(&a, &b).expect("the chain and the closed forms bound their bend");
                    let (pa, pb) = (kin.forward(&a), kin.forward(&b));
                    for k in 1..64 {
                        let t = f64::from(k) / 64.0;
                        let p = kin.forward(&a.lerp(&b, t));
                        let tip = (p.tip.coords - pa.tip.coords.lerp(&pb.tip.coords, t)).norm();
                        let axis = (p.axis.into_inner() - pa.axis.into_inner().lerp(&pb.axis.into_inner(), t)).norm();
                        let within = |bound: f64| bound * t * (1.0 - t) / 2.0 + 1e-9;
                        prop_assert!(tip <= within(bend.tip), "{}: tip {tip} off at t = {t}, bend {bend:?}", m.name);
                        prop_assert!(axis <= within(bend.axis), "{}: axis {axis} off at t = {t}, bend {bend:?}", m.name);
                    }
                }
            }
        }
    }
}

#[test]
fn closed_forms_agree_with_the_generic_chain_on_the_built_ins() {
    for name in ["mikron-ucp710", "maho600e"] {
        let m = machine(name);
        assert!(matches!(m.solver, SolverKind::ClosedForm(_)), "{name} is a closed form");
        let closed = solver_for(&m);
        let generic = Chain::new(Machine { solver: SolverKind::Generic, ..m.clone() });
        let (mut a, mut b) = (Solutions::new(), Solutions::new());
        for k in 0..2000 {
            let t = f64::from(k) * 0.0137;
            let axis = Unit::new_normalize(Vector3::new((3.0 * t).sin(), (2.0 * t).cos(), 0.2 + (t * 0.7).cos()));
            let pose = Pose { tip: Point3::new(50.0 * t.sin(), 30.0 * t.cos(), 10.0 * t), axis };
            closed.inverse(&pose, &mut a);
            generic.inverse(&pose, &mut b);
            assert_eq!(a.len(), b.len(), "{name}: {pose:?}");
            for s in a.iter() {
                let close = b
                    .iter()
                    .any(|g| g.joints.as_slice().iter().zip(s.joints.as_slice()).all(|(x, y)| (x - y).abs() < 1e-9));
                assert!(close, "{name}: closed {s:?} not among generic {b:?}");
            }
        }
    }
}

/// Paper 000, Table 2: with A limited to 150° of travel ([−120°, +30°] here), the number of
/// admissible solutions is 0 for k in [−1, −0.5), 1 for [−0.5, 0.866), 2 for [0.866, 1), and
/// infinite at k = 1 (the singularity: C is free).
#[test]
fn paper_000_table_2_admissible_mikron_solutions() {
    let m = machine("mikron");
    let kin = solver_for(&m);
    let a = m.axis_index("A").expect("A");
    let Travel::Limited { min, max } = m.axes[a].travel else { panic!("A is limited") };
    let admissible = |k: f64, phi: f64| {
        let s = (1.0 - k * k).sqrt();
        let pose =
            Pose { tip: Point3::origin(), axis: Unit::new_normalize(Vector3::new(s * phi.cos(), s * phi.sin(), k)) };
        let mut sols = Solutions::new();
        kin.inverse(&pose, &mut sols);
        let singular = sols.iter().any(|s| s.pole.is_some_and(|(_, d)| d < 1e-12));
        let count = sols.iter().filter(|s| s.joints[a] >= min - 1e-12 && s.joints[a] <= max + 1e-12).count();
        (count, singular)
    };
    for (lo, hi, expected) in [(-1.0, -0.5, 0), (-0.5, 0.866, 1), (0.8661, 1.0, 2)] {
        for n in 0..50 {
            let k = lo + (hi - lo) * (f64::from(n) + 0.5) / 50.0;
            for phi in [0.0, 1.0, 2.5, -2.0] {
                assert_eq!(admissible(k, phi), (expected, false), "k = {k}, phi = {phi}");
            }
        }
    }
    let (count, singular) = admissible(1.0, 0.3);
    assert!(singular && count >= 1, "k = 1 is the singularity: {count} solution(s) reported, C free");
}

/// Paper 002's forward transformation, its Z_m typo fixed (sin b / cos b), with the paper's
/// offsets and a zero tool length, worked by hand for b = 30°, a = 40° and the workpiece point
/// (10, 20, 5):
///   X_m = 10·cos40·cos30 − 20·cos30·sin40 − (5 + 165 − 250.314)·sin30 + 298.92   = 334.5777…
///   Y_m = 10·sin40 + 20·cos40 + 177.278                                           = 199.0268…
///   Z_m = 10·sin30·cos40 − 20·sin40·sin30 + (5 + 165 − 250.314)·cos30 − 291.406   = −363.5576…
/// and the tool axis (sin b cos a, −sin b sin a, cos b).
#[test]
fn maho_600e_pose_worked_by_hand() {
    let m = machine("maho");
    let kin = solver_for(&m);
    let (b, a) = (30f64.to_radians(), 40f64.to_radians());
    let axis = Unit::new_normalize(Vector3::new(b.sin() * a.cos(), -b.sin() * a.sin(), b.cos()));
    let pose = Pose { tip: Point3::new(10.0, 20.0, 5.0), axis };
    let mut sols = Solutions::new();
    kin.inverse(&pose, &mut sols);
    let expected = [334.577731497161, 199.02676495924493, -363.55761816081394, 30.0, 40.0];
    let (xb, xc) = (m.axis_index("B").expect("B"), m.axis_index("C").expect("C"));
    let hit = sols.iter().find(|s| (s.joints[xb].to_degrees() - 30.0).abs() < 1e-9).expect("the B = +30° branch");
    for (i, e) in expected.iter().enumerate().take(3) {
        assert!((hit.joints[i] - e).abs() < 1e-9, "axis {i}: {} vs {e}", hit.joints[i]);
    }
    assert!((hit.joints[xc].to_degrees() - expected[4]).abs() < 1e-9);
    // The other branch: B = −30°, C = 40° ± 180°, and it reaches the same pose.
    let other = sols.iter().find(|s| (s.joints[xb].to_degrees() + 30.0).abs() < 1e-9).expect("the B = −30° branch");
    assert!(same_angle(other.joints[xc], (40f64 + 180.0).to_radians()));
    assert!((kin.forward(&other.joints).tip - pose.tip).norm() < 1e-9);
}

fn shared_cl() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/cl");
    assert!(dir.is_dir(), "{} is missing: ../shared must sit beside the repository", dir.display());
    dir
}

/// The decisions of a solved path, counted by kind: `2 large rotary step, 1 unwind`.
fn decision_kinds(solved: &postpro_kin::Solved) -> String {
    let mut kinds: Vec<(&str, usize)> = Vec::new();
    for d in &solved.decisions {
        let kind = match d.decision {
            Decision::BranchSwitch { .. } => "branch switch",
            Decision::SingularHold { .. } => "singular hold",
            Decision::OffPreference { .. } => "off preference",
            Decision::Retract { .. } => "retract",
            Decision::LargeRotaryStep { .. } => "large rotary step",
            Decision::Unwind { .. } => "unwind",
        };
        match kinds.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, n)) => *n += 1,
            None => kinds.push((kind, 1)),
        }
    }
    if kinds.is_empty() {
        return "no decision".to_string();
    }
    kinds.iter().map(|(k, n)| format!("{n} {k}")).collect::<Vec<_>>().join(", ")
}

/// Every 5-axis and 3+2 file of the corpus goes through the IKT of each built-in 5-axis machine
/// with its default policy, and what happens is pinned: solved (CL points, points added by
/// linearization, decisions by kind) or the error with the line and column it names; never a
/// panic. Large rotary steps are motion (a warning); only a branch change away from the pole or
/// a travel limit during a feed move may refuse a file. (Some files leave the travels because
/// the part zero is a fixed point of each machine here, whatever the file's set-up.)
#[test]
fn real_multi_axis_files_on_the_built_in_5_axis_machines() {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(shared_cl())
        .expect("listing")
        .map(|entry| entry.expect("entry").path())
        .filter(|path| path.extension().is_none_or(|e| e != "md"))
        .collect();
    paths.sort();
    let mut report = Vec::new();
    let mut files = 0;
    for path in &paths {
        let source = Source::from_path(path).expect("readable");
        let (summary, _) = postpro_cl::summarize(&source);
        if !matches!(summary.axes, "5-axis" | "3+2") {
            continue;
        }
        files += 1;
        let name = path.file_name().unwrap_or_default().to_string_lossy().to_string();
        report.push(format!("{name} ({})", summary.axes));
        let tool_path = read(&source);
        for machine_name in ["mikron-ucp710", "maho600e", "haas-umc750"] {
            let m = machine(machine_name);
            let kin = solver_for(&m);
            let outcome = match solve(kin.as_ref(), &tool_path, &m.policy) {
                Ok(solved) => {
                    for s in solved.steps.iter().step_by(7) {
                        let back = kin.forward(&s.joints);
                        assert!(
                            (back.tip - s.pose.tip).norm() < 1e-6,
                            "{machine_name}: {}",
                            source.location(s.span.start as usize)
                        );
                    }
                    let cl = solved.steps.iter().filter(|s| s.kind == StepKind::Cl).count();
                    format!("ok, {cl} CL points, {} inserted; {}", solved.inserted, decision_kinds(&solved))
                }
                Err(e) => {
                    let span = match &e {
                        SolveError::Unreachable { span, .. }
                        | SolveError::OutOfTravel { span, .. }
                        | SolveError::Discontinuity { span, .. }
                        | SolveError::TipOff { span, .. } => *span,
                    };
                    assert!(
                        span.end() <= source.text().len() && span.len > 0,
                        "{machine_name}: error without a statement: {e}"
                    );
                    let at = source.line_col(span.start as usize);
                    format!("error at {}:{}: {e}", at.line, at.column)
                }
            };
            report.push(format!("  {machine_name}: {outcome}"));
        }
    }
    assert!(files >= 6, "only {files} multi-axis files found");
    insta::assert_snapshot!(report.join("\n"));
}

/// The generic copies of the two built-ins are the same machines, and their generic chains give
/// the closed forms' solutions to 1e-9.
#[test]
fn the_generic_definitions_of_the_built_ins_match_their_closed_forms() {
    for name in ["mikron-ucp710", "maho600e"] {
        let closed = machine(name);
        let generic = machine(&format!("{name}-generic"));
        assert_eq!(generic.solver, SolverKind::Generic);
        let same = Machine {
            name: closed.name.clone(),
            aliases: closed.aliases.clone(),
            description: closed.description.clone(),
            solver: closed.solver,
            ..generic.clone()
        };
        assert_eq!(same, closed, "{name}-generic.yaml drifted from {name}.yaml");
        let (a, b) = (solver_for(&closed), solver_for(&generic));
        let (mut sa, mut sb) = (Solutions::new(), Solutions::new());
        for k in 0..500 {
            let t = f64::from(k) * 0.031;
            let axis = Unit::new_normalize(Vector3::new(t.sin(), (1.7 * t).cos(), 0.5 + t.cos()));
            let pose = Pose { tip: Point3::new(20.0 * t.cos(), 10.0 * t, -5.0 * t.sin()), axis };
            a.inverse(&pose, &mut sa);
            b.inverse(&pose, &mut sb);
            assert_eq!(sa.len(), sb.len());
            for s in sa.iter() {
                assert!(
                    sb.iter().any(|g| g
                        .joints
                        .as_slice()
                        .iter()
                        .zip(s.joints.as_slice())
                        .all(|(x, y)| (x - y).abs() < 1e-9))
                );
            }
        }
    }
}
