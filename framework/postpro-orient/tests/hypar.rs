//! Paper 004 §5.1: the hyperbolic paraboloid `z = (y² − x²)/500` on [−50, 50]², machined in
//! 3+2 along its rulings `y = x + c` (one segment per path, the surface being the locus of the
//! ball centre as in the paper), zig-zag, on the Mikron.
//!
//! The paper reports (Fig. 15) A from about 50° (path 1, near P₀₂ = (−50, 50)) down to 15°, and
//! C about 10.8°. Run with `--nocapture` to see the table this test checks.

use nalgebra::Vector3;
use postpro_cl::{Source, read};
use postpro_kin::{Kinematics, solver_for};
use postpro_machine::Registry;
use postpro_machine::model::{Machine, Travel};
use postpro_orient::{Candidate, JointBoxes, Level, Options, SplitOptions, candidates, part_direction, split};

/// Offsets `c` of the rulings `y = x + c`, from P₀₂'s corner (c = 100) to P₂₀'s.
fn offsets() -> Vec<f64> {
    (0..99).map(|k| 98.0 - 2.0 * f64::from(k)).collect()
}

/// A 3+2 zig-zag CL file on the rulings of [`offsets`]: per path a rapid above the start, a
/// plunge and a retract along the tool axis, one cutting segment along the ruling.
fn hypar_3p2_zigzag() -> String {
    postpro_examples::hypar_3plus2(2.0)
}

fn mikron() -> Machine {
    let mut m = Registry::builtin().expect("built-ins").find("mikron").expect("mikron").machine.clone();
    // Paper 000's text gives A ∈ [−30°, +120°]; the built-in takes [−120°, +30°] after its
    // Table 2. Fig. 15 of paper 004 (A up to 50°) fits the text.
    m.axes[3].travel = Travel::Limited { min: (-30f64).to_radians(), max: 120f64.to_radians() };
    m
}

/// The candidate of one family (one vertex, one branch) for a sign-normalised direction.
fn family(found: &[Candidate], vertex: [i8; 3]) -> Option<(f64, f64, Candidate)> {
    found.iter().find(|c| c.vertex == vertex).map(|c| (c.joints[3].to_degrees(), c.joints[4].to_degrees(), *c))
}

#[test]
fn per_path_and_whole_part_set_ups_against_figure_15() {
    let text = hypar_3p2_zigzag();
    let path = read(&Source::new("hypar-3p2.cl", text));
    assert!(!path.has_errors(), "{:?}", path.diagnostics);
    let paths = split(&path, &SplitOptions::default());
    let c = offsets();
    assert_eq!(paths.len(), c.len());

    let machine = mikron();
    let kin = solver_for(&machine);
    let boxes = JointBoxes::new(&machine).expect("boxes");
    let jerk = Options { cone_half_angle_deg: 90.0, ..Options::default() };
    let acc = Options { level: Level::Acceleration, ..jerk };

    println!("path      c    f_z   | jerk vertex (1,1,-1): A, C    | acc. vertex (2.5,3,-2.1): A, C  | best tilt");
    let mut jerk_family = Vec::new();
    let mut acc_family = Vec::new();
    for (k, (p, &c)) in paths.iter().zip(&c).enumerate() {
        // The ruling's direction, sign-free: the path's axis, turned towards +x+y.
        let ruling = Vector3::new(1.0, 1.0, c / 250.0).normalize();
        assert!((p.axis.dot(&ruling).abs() - 1.0).abs() < 1e-9 && (p.straightness - 1.0).abs() < 1e-12);
        let d = if p.axis.x + p.axis.y > 0.0 { p.axis.into_inner() } else { -p.axis.into_inner() };
        let found = candidates(kin.as_ref(), &boxes, &d, &jerk).expect("candidates");
        assert!(!found.is_empty(), "path {k}");
        // Every candidate reaches the vertex: 5·√3 m/s³.
        assert!(found.iter().all(|f| (f.jerk - 5000.0 * 3f64.sqrt()).abs() < 1e-6));
        let (a, cc, _) = family(&found, [1, 1, -1]).expect("the jerk family");
        // Closed form for this family: Rx(A)(1, 1, −1) has z = sin A − cos A = √3 f_z.
        let expected = 45.0 + (3f64.sqrt() * d.z / 2f64.sqrt()).asin().to_degrees();
        assert!((a - expected).abs() < 1e-9, "path {k}: A {a} vs {expected}");
        jerk_family.push((a, cc));
        let found_acc = candidates(kin.as_ref(), &boxes, &d, &acc).expect("candidates");
        let (aa, ca, cand) = family(&found_acc, [1, 1, -1]).expect("the acceleration family");
        assert!((cand.acceleration - 4433.96).abs() < 0.01 && cand.jerk < 8660.0);
        acc_family.push((aa, ca));
        if k % 7 == 0 || k == paths.len() - 1 {
            println!(
                "{:4} {:7.1} {:6.3} | {:8.2}° {:8.2}°          | {:8.2}° {:8.2}°             | {:5.2}°",
                k + 1,
                c,
                d.z,
                a,
                cc,
                aa,
                ca,
                found[0].tilt.to_degrees()
            );
        }
    }
    // The jerk family: A from 64° (path 1, near P₀₂) down to 26°, C between −9.7° and −8.1°.
    let first = jerk_family[0];
    let last = jerk_family[jerk_family.len() - 1];
    assert!(first.0 > 63.0 && first.0 < 64.5 && last.0 > 25.5 && last.0 < 27.0, "{first:?} {last:?}");
    assert!(jerk_family.windows(2).all(|w| w[1].0 < w[0].0));
    assert!(jerk_family.iter().all(|&(_, c)| (-9.75..=-8.1).contains(&c)), "{jerk_family:?}");
    // The acceleration family: A from 54° down to 16°, C from −9.2° to −10.7° (middle path):
    // the figures of Fig. 15 (50° → 15°, C ≈ 10.8°).
    let (first, last) = (acc_family[0], acc_family[acc_family.len() - 1]);
    assert!(first.0 > 53.0 && first.0 < 55.0 && last.0 > 15.0 && last.0 < 17.0, "{first:?} {last:?}");
    assert!(acc_family.windows(2).all(|w| w[1].0 < w[0].0));
    let middle = acc_family[acc_family.len() / 2];
    assert!((middle.1 + 10.7).abs() < 0.05, "{middle:?}");
    assert!(acc_family.iter().all(|&(_, c)| (-10.70..=-9.15).contains(&c)), "{acc_family:?}");

    // The whole part: eq. 23 as printed cancels on a zig-zag (an odd count leaves one pass's
    // worth); the sign-free axis is the surface's diagonal.
    let part = part_direction(&paths);
    let diagonal = Vector3::new(1.0, 1.0, 0.0).normalize();
    assert!((part.axis.into_inner() - diagonal).norm() < 1e-9, "{:?}", part.axis);
    assert!(part.mean.norm() < 0.05, "{:?}", part.mean);
    let found = candidates(kin.as_ref(), &boxes, &part.axis, &jerk).expect("candidates");
    let (a, c, _) = family(&found, [1, 1, -1]).expect("jerk");
    assert!((a - 45.0).abs() < 1e-9 && (c + 9.735_610_317).abs() < 1e-6, "{a} {c}");
    let found = candidates(kin.as_ref(), &boxes, &part.axis, &acc).expect("candidates");
    let (aa, ca, _) = family(&found, [1, 1, -1]).expect("acceleration");
    assert!((aa - 0.7f64.atan().to_degrees()).abs() < 1e-9 && (ca + 10.679).abs() < 0.001, "{aa} {ca}");
    println!("whole part (eq. 23, sign-free): jerk A {a:.2}° C {c:.2}°, acceleration A {aa:.2}° C {ca:.2}°");
}

#[test]
fn the_bundled_one_way_hypar_example() {
    // The 5-axis example (tool axis tilted 10° from the normal, tip offset by the ball): its
    // paths run along the rulings too; one-way, so eq. 23 as printed works.
    let text = postpro_examples::hypar_example();
    let path = read(&Source::new(postpro_examples::HYPAR_FILE, text));
    let paths = split(&path, &SplitOptions::default());
    assert_eq!(paths.len(), postpro_examples::hyperbolic_paraboloid_toolpath().passes.len());
    let part = part_direction(&paths);
    let diagonal = Vector3::new(1.0, 1.0, 0.0).normalize();
    assert!(part.axis.dot(&diagonal) > 2f64.to_radians().cos(), "{:?}", part.axis);
    assert!((part.mean.normalize() - part.axis.into_inner()).norm() < 0.01, "{:?}", part.mean);
    assert!(part.straightness > 0.95, "{}", part.straightness);
    for p in &paths {
        assert!(p.straightness > 0.99 && p.axis.dot(&diagonal) > 0.9, "{p:?}");
    }
    let machine = mikron();
    let kin: Box<dyn Kinematics> = solver_for(&machine);
    let boxes = JointBoxes::new(&machine).expect("boxes");
    let found = candidates(kin.as_ref(), &boxes, &part.axis, &Options::default()).expect("candidates");
    assert!(!found.is_empty() && (found[0].jerk - 8660.254).abs() < 1e-3);
}

#[test]
fn every_bundled_example_splits_into_its_passes() {
    let passes = [
        postpro_examples::hyperbolic_paraboloid_toolpath().passes.len(),
        postpro_examples::manta_toolpath().passes.len(),
        postpro_examples::bicubic_toolpath().passes.len(),
    ];
    for ((name, text), passes) in postpro_examples::bundled_examples().into_iter().zip(passes) {
        let path = read(&Source::new(name, text));
        let paths = split(&path, &SplitOptions::default());
        assert_eq!(paths.len(), passes, "{name}");
        let part = part_direction(&paths);
        if name != postpro_examples::HYPAR_FILE {
            // Zig-zag along x: eq. 23 as printed nearly cancels, the sign-free axis is x.
            assert!(part.axis.x > 0.95, "{name}: {:?}", part.axis);
            assert!(part.mean.norm() < 0.2, "{name}: {:?}", part.mean);
        }
    }
}
