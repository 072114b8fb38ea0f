//! Paper 004 on the Mikron UCP 710: Table 2, the bounds of eq. 21, the examples of §4.3
//! (Figs. 8, 9, 11), and the candidates of every built-in machine checked independently.

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use postpro_kin::{Chain, Joints, Kinematics, solver_for};
use postpro_machine::Registry;
use postpro_machine::model::{Machine, Travel};
use postpro_orient::{Candidate, JointBoxes, JointMap, Level, Options, OrientError, bounds, candidates};

fn machine(name: &str) -> Machine {
    Registry::builtin().expect("built-ins").find(name).expect("machine").machine.clone()
}

/// The Mikron with an endless A axis: the paper's examples ignore the travels.
fn mikron_without_a_limits() -> Machine {
    let mut m = machine("mikron");
    m.axes[3].travel = Travel::Endless;
    m
}

/// Paper 004's Jacobian (eq. 16 as corrected in `../shared/DOMAIN.md` §2): an independent oracle.
fn rz_rx(a: f64, c: f64) -> Matrix3<f64> {
    (Rotation3::from_axis_angle(&Vector3::z_axis(), c) * Rotation3::from_axis_angle(&Vector3::x_axis(), a)).into_inner()
}

fn at_zero(kin: &dyn Kinematics, boxes: &JointBoxes) -> JointMap {
    JointMap::at(kin, boxes, &Joints::zeros(kin.machine().axes.len())).expect("regular")
}

/// Paper 004 Table 2: rows d_vel, d_acc, d_jerk; columns the norms along them of the velocity
/// (m/s), acceleration (m/s²) and jerk (m/s³) polytopes, as printed (bold: the row's own level).
const TABLE_2: [(Level, [f64; 3]); 3] =
    [(Level::Velocity, [0.87, 3.6, 8.7]), (Level::Acceleration, [0.74, 4.4, 7.4]), (Level::Jerk, [0.87, 3.6, 8.7])];
/// Printed decimals per column.
const DECIMALS: [i32; 3] = [2, 1, 1];

#[test]
fn table_2_preferred_directions_and_norms() {
    let mikron = machine("mikron");
    let kin = solver_for(&mikron);
    let boxes = JointBoxes::new(&mikron).expect("boxes");
    // At A = C = 0 the part frame of the built-in set-up is the machine (joint) frame, the frame
    // in which the paper gives its directions (eq. 7: "a unit direction d in the joint space").
    let map = at_zero(kin.as_ref(), &boxes);
    for (row, printed) in TABLE_2 {
        let preferred = boxes.polytope(row, &map).preferred();
        for (k, column) in Level::ALL.into_iter().enumerate() {
            // mm → m.
            let norm = boxes.polytope(column, &map).norm_along(&preferred.direction) / 1000.0;
            let half_unit = 0.5 * 10f64.powi(-DECIMALS[k]) + 1e-9;
            assert!(
                (norm - printed[k]).abs() <= half_unit,
                "d_{} row, {} column: {norm:.4} printed {}",
                row.name(),
                column.name(),
                printed[k]
            );
        }
        // Its own column: the preferred norm is the vertex norm.
        let own = preferred.norm / 1000.0;
        assert!((own - printed[row as usize]).abs() <= 0.5 * 10f64.powi(-DECIMALS[row as usize]) + 1e-9);
    }
    // The directions: the paper draws them (Fig. 6), it prints no components. Velocity and jerk
    // boxes are cubes: the diagonal; the acceleration box (2.5, 3, 2.1) m/s²: its own diagonal.
    let dir = |level| boxes.polytope(level, &map).preferred().direction.into_inner();
    let diagonal = Vector3::new(1.0, 1.0, 1.0).normalize();
    assert!((dir(Level::Velocity) - diagonal).norm() < 1e-12);
    assert!((dir(Level::Jerk) - diagonal).norm() < 1e-12);
    let acc = Vector3::new(2.5, 3.0, 2.1).normalize();
    assert!((dir(Level::Acceleration) - acc).norm() < 1e-12);
    assert!((acc - Vector3::new(0.5638, 0.6766, 0.4736)).abs().max() < 1e-4);
    // Every vertex of a level has the same norm, at every set-up (J is a rotation).
    for (a, c) in [(0.0, 0.0), (0.5, 2.0), (-1.9, -0.3)] {
        let map = JointMap::at(kin.as_ref(), &boxes, &Joints::from_slice(&[0.0, 0.0, 0.0, a, c])).expect("map");
        for level in Level::ALL {
            for v in boxes.polytope(level, &map).vertices() {
                assert!((v.norm - boxes.limits(level).norm()).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn equation_21_bounds_on_the_mikron() {
    // (level, lower, upper) in m/s^k: eq. 21 for the jerk, the same reasoning for the others.
    let expected = [
        (Level::Jerk, 7.07, 8.66),
        (Level::Acceleration, (3.0f64.powi(2) + 2.1f64.powi(2)).sqrt(), 4.434),
        (Level::Velocity, 0.707, 0.866),
    ];
    for name in ["mikron", "mikron-generic"] {
        let mikron = machine(name);
        let kin = solver_for(&mikron);
        let boxes = JointBoxes::new(&mikron).expect("boxes");
        for (level, lower, upper) in expected {
            let b = bounds(kin.as_ref(), &boxes, level).expect("bounds");
            assert_eq!(b.level, level);
            assert!((b.lower / 1000.0 - lower).abs() < 0.01, "{name} {level:?}: lower {}", b.lower);
            assert!((b.upper / 1000.0 - upper).abs() < 0.01, "{name} {level:?}: upper {}", b.upper);
            // The pole is the C axis, ±z of the part.
            assert!(b.pole.is_some_and(|p| p.z.abs() > 1.0 - 1e-12), "{b:?}");
        }
        let jerk = bounds(kin.as_ref(), &boxes, Level::Jerk).expect("bounds");
        assert!((jerk.lower - 5000.0 * 2f64.sqrt()).abs() < 1e-6 && (jerk.upper - 5000.0 * 3f64.sqrt()).abs() < 1e-6);
        // Fig. 11: the pole's best set-up is A = ±45° (C free).
        assert!((jerk.lower_at[3].abs().to_degrees() - 45.0).abs() < 1e-6, "{:?}", jerk.lower_at);
    }
}

/// The best jerk along `d` over every (A, C) of the Mikron, by a 6° grid then a pattern
/// search, with the paper's Jacobian (checked against the forward kinematics elsewhere).
fn best_jerk_anywhere(boxes: &JointBoxes, d: &Vector3<f64>) -> f64 {
    let limits = boxes.limits(Level::Jerk);
    let d = d.normalize();
    let norm = |a: f64, c: f64| {
        let u = rz_rx(a, c).transpose() * d;
        (0..3).map(|i| limits[i] / u[i].abs()).fold(f64::INFINITY, f64::min)
    };
    let step = 6f64.to_radians();
    let mut best = (0.0, 0.0, f64::NEG_INFINITY);
    for i in 0..60 {
        for j in 0..60 {
            let (a, c) = (f64::from(i) * step, f64::from(j) * step);
            let v = norm(a, c);
            if v > best.2 {
                best = (a, c, v);
            }
        }
    }
    let mut h = step;
    while h > 1e-9 {
        let mut moved = false;
        for (da, dc) in [(h, 0.0), (-h, 0.0), (0.0, h), (0.0, -h), (h, h), (-h, -h), (h, -h), (-h, h)] {
            let v = norm(best.0 + da, best.1 + dc);
            if v > best.2 {
                best = (best.0 + da, best.1 + dc, v);
                moved = true;
            }
        }
        if !moved {
            h /= 2.0;
        }
    }
    best.2
}

#[test]
fn no_feed_direction_does_worse_than_the_lower_bound() {
    let mikron = mikron_without_a_limits();
    let kin = solver_for(&mikron);
    let boxes = JointBoxes::new(&mikron).expect("boxes");
    let b = bounds(kin.as_ref(), &boxes, Level::Jerk).expect("bounds");
    // At the pole itself nothing beats the bound (a grid cannot exceed the true maximum).
    let pole = b.pole.expect("pole").into_inner();
    let at_pole = best_jerk_anywhere(&boxes, &pole);
    assert!(at_pole <= b.lower + 1e-6 && at_pole >= b.lower - 1e-3, "{at_pole} vs {}", b.lower);
    // Directions spread over the upper hemisphere (the polytope is symmetric): either a vertex
    // is reachable (upper bound) or the best is between the bounds.
    let n = 60;
    let mut polar = 0;
    for k in 0..n {
        let z = (f64::from(k) + 0.5) / f64::from(n);
        let phi = f64::from(k) * 2.399_963_229_728_653;
        let r = (1.0 - z * z).sqrt();
        let d = Vector3::new(r * phi.cos(), r * phi.sin(), z);
        let found = candidates(kin.as_ref(), &boxes, &d, &Options::default()).expect("candidates");
        if let Some(best) = found.first() {
            assert!((best.jerk - b.upper).abs() < 1e-6);
            // Eq. 20: a vertex is reachable iff the feed is not too steep.
            assert!(z * z <= 2.0 / 3.0 + 1e-9, "{z}");
        } else {
            polar += 1;
            assert!(z * z >= 2.0 / 3.0 - 1e-9, "{z}");
            let best = best_jerk_anywhere(&boxes, &d);
            assert!(best >= b.lower * (1.0 - 2e-3) && best <= b.upper, "{d:?}: {best}");
        }
    }
    assert!(polar > 5, "{polar}");
}

/// Checks a candidate against the paper's Jacobian and tool axis, independently of the crate.
fn check_on_the_mikron(c: &Candidate, d: &Vector3<f64>, boxes: &JointBoxes) {
    let (a, cc) = (c.joints[3], c.joints[4]);
    let vertex = boxes.limits(Level::Jerk).component_mul(&Vector3::from(c.vertex.map(f64::from)));
    let image = rz_rx(a, cc) * vertex;
    assert!((image.normalize() - d.normalize()).norm() < 1e-9, "{c:?}");
    assert!(c.alignment_error < 1e-9);
    let axis = Vector3::new(cc.sin() * a.sin(), -cc.cos() * a.sin(), a.cos());
    assert!((c.tool_axis.into_inner() - axis).norm() < 1e-9);
    assert!((c.jerk - image.norm()).abs() < 1e-6);
    assert_eq!(&c.joints.as_slice()[..3], &[0.0; 3]);
}

fn angles_deg(c: &Candidate) -> (f64, f64) {
    (c.joints[3].to_degrees(), c.joints[4].to_degrees())
}

#[test]
fn figure_8_both_set_ups_for_the_diagonal() {
    // f_path1 = (1, 1, 1)/√3: A = C = 0 and A = C = 90° point it at (J_X, J_Y, J_Z).
    let d = Vector3::new(1.0, 1.0, 1.0);
    let wide = mikron_without_a_limits();
    let boxes = JointBoxes::new(&wide).expect("boxes");
    for kin in [solver_for(&wide), Box::new(Chain::new(wide.clone())) as Box<dyn Kinematics>] {
        let found = candidates(kin.as_ref(), &boxes, &d, &Options::default()).expect("candidates");
        assert_eq!(found.len(), 16);
        for c in &found {
            check_on_the_mikron(c, &d, &boxes);
        }
        let mut top: Vec<(f64, f64)> = found
            .iter()
            .filter(|c| c.vertex == [1, 1, 1])
            .map(angles_deg)
            .map(|(a, c)| (a.round(), c.round()))
            .collect();
        top.sort_by(|x, y| x.0.total_cmp(&y.0));
        assert_eq!(top, [(0.0, 0.0), (90.0, 90.0)]);
    }
    // The built-in travel of A, [-120°, 30°], keeps A = 0 and drops A = 90°.
    let mikron = machine("mikron");
    let kin = solver_for(&mikron);
    let found = candidates(kin.as_ref(), &boxes, &d, &Options::default()).expect("candidates");
    assert!(found.iter().any(|c| c.vertex == [1, 1, 1] && c.joints[3].abs() < 1e-9 && c.joints[4].abs() < 1e-9));
    assert!(found.iter().all(|c| c.joints[3].to_degrees() <= 30.0 + 1e-9 && c.joints[3].to_degrees() >= -120.0 - 1e-9));
    assert!(found.len() < 16);
    // The best first: A = C = 0 has the tool axis on the reference +z.
    assert!(found[0].tilt.abs() < 1e-9 && found[0].vertex == [1, 1, 1]);
}

#[test]
fn figure_9_two_set_ups_per_vertex_for_x() {
    let d = Vector3::x();
    let wide = mikron_without_a_limits();
    let kin = solver_for(&wide);
    let boxes = JointBoxes::new(&wide).expect("boxes");
    let found = candidates(kin.as_ref(), &boxes, &d, &Options::default()).expect("candidates");
    assert_eq!(found.len(), 16);
    for vertex_index in 0..8 {
        let of_vertex: Vec<&Candidate> = found.iter().filter(|c| c.vertex_index == vertex_index).collect();
        assert_eq!(of_vertex.len(), 2);
        assert_ne!(of_vertex[0].branch, of_vertex[1].branch);
    }
    // The paper's vertex (q_X min, q_Y min, q_Z max).
    assert!(found.iter().filter(|c| c.vertex == [-1, -1, 1]).all(|c| (c.jerk - 8660.254).abs() < 1e-3));
    for c in &found {
        check_on_the_mikron(c, &d, &boxes);
    }
}

#[test]
fn figure_11_the_pole_reaches_no_vertex() {
    let mikron = mikron_without_a_limits();
    let kin = solver_for(&mikron);
    let boxes = JointBoxes::new(&mikron).expect("boxes");
    for d in [Vector3::z(), -Vector3::z(), Vector3::new(0.01, 0.0, 1.0)] {
        assert!(candidates(kin.as_ref(), &boxes, &d, &Options::default()).expect("no error").is_empty());
    }
}

#[test]
fn the_acceleration_and_velocity_vertices_can_be_aimed_at_too() {
    let mikron = mikron_without_a_limits();
    let kin = solver_for(&mikron);
    let boxes = JointBoxes::new(&mikron).expect("boxes");
    let d = Vector3::new(0.3, -0.8, 0.2);
    let options = Options { level: Level::Acceleration, ..Options::default() };
    let found = candidates(kin.as_ref(), &boxes, &d, &options).expect("candidates");
    assert_eq!(found.len(), 16);
    for c in &found {
        assert!((c.acceleration - 4433.96).abs() < 0.01, "{c:?}");
        assert!(c.jerk < 8660.0 && c.norm(Level::Jerk) == c.jerk);
        let vertex = boxes.limits(Level::Acceleration).component_mul(&Vector3::from(c.vertex.map(f64::from)));
        assert!(((rz_rx(c.joints[3], c.joints[4]) * vertex).normalize() - d.normalize()).norm() < 1e-9);
    }
}

#[test]
fn the_closed_form_and_the_generic_chain_give_the_same_set_ups() {
    let wide = mikron_without_a_limits();
    let boxes = JointBoxes::new(&wide).expect("boxes");
    let closed = solver_for(&wide);
    let generic = Chain::new(wide.clone());
    for d in [Vector3::new(0.2, 0.9, -0.3), Vector3::new(-1.0, 0.1, 0.5), Vector3::new(0.0, 1.0, 0.0)] {
        let a = candidates(closed.as_ref(), &boxes, &d, &Options::default()).expect("closed");
        let b = candidates(&generic, &boxes, &d, &Options::default()).expect("generic");
        assert_eq!(a.len(), 16);
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!((x.vertex, x.branch), (y.vertex, y.branch));
            let diff =
                x.joints.as_slice().iter().zip(y.joints.as_slice()).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
            assert!(diff < 1e-9, "{x:?} {y:?}");
        }
    }
}

#[test]
fn the_cone_and_the_travels_filter_unreachable_cases_give_nothing() {
    let mikron = machine("mikron");
    let kin = solver_for(&mikron);
    let boxes = JointBoxes::new(&mikron).expect("boxes");
    let d = Vector3::new(1.0, 1.0, 0.0);
    let all = candidates(kin.as_ref(), &boxes, &d, &Options::default()).expect("candidates");
    assert_eq!(all.len(), 4, "{all:?}");
    for cone in [50.0, 45.0 + 1e-6] {
        let options = Options { cone_half_angle_deg: cone, ..Options::default() };
        assert_eq!(candidates(kin.as_ref(), &boxes, &d, &options).expect("cone").len(), 4);
    }
    for cone in [44.9, 0.0] {
        let options = Options { cone_half_angle_deg: cone, ..Options::default() };
        assert!(candidates(kin.as_ref(), &boxes, &d, &options).expect("cone").is_empty());
    }
    // A reference axis elsewhere: tilts are measured from it.
    let tilted = Options { reference_axis: Unit::new_normalize(Vector3::new(0.0, 1.0, 1.0)), ..Options::default() };
    let found = candidates(kin.as_ref(), &boxes, &d, &tilted).expect("candidates");
    for c in &found {
        assert!((c.tilt - c.tool_axis.dot(&tilted.reference_axis).acos()).abs() < 1e-12);
    }
    assert!(found.windows(2).all(|w| w[0].tilt <= w[1].tilt + 1e-12));
    // A travel that no set-up fits.
    let mut stuck = mikron.clone();
    stuck.axes[3].travel = Travel::Limited { min: 0.0, max: 1f64.to_radians() };
    let kin_stuck = solver_for(&stuck);
    assert!(candidates(kin_stuck.as_ref(), &boxes, &d, &Options::default()).expect("travel").is_empty());
    // Errors, not panics.
    for bad in [Vector3::zeros(), Vector3::new(f64::NAN, 1.0, 0.0), Vector3::new(f64::INFINITY, 0.0, 0.0)] {
        let err = candidates(kin.as_ref(), &boxes, &bad, &Options::default()).expect_err("not a direction");
        assert!(matches!(err, OrientError::Direction { what: "feed direction", .. }), "{err}");
    }
    for cone in [-1.0, 180.5, f64::NAN] {
        let options = Options { cone_half_angle_deg: cone, ..Options::default() };
        assert!(matches!(candidates(kin.as_ref(), &boxes, &d, &options), Err(OrientError::Cone(_))));
    }
    let nan_axis =
        Options { reference_axis: Unit::new_unchecked(Vector3::new(f64::NAN, 0.0, 0.0)), ..Options::default() };
    assert!(matches!(candidates(kin.as_ref(), &boxes, &d, &nan_axis), Err(OrientError::Direction { .. })));
}

#[test]
fn every_built_in_machine_gives_checked_set_ups_or_none() {
    let registry = Registry::builtin().expect("built-ins");
    let directions = [
        Vector3::new(1.0, 1.0, 0.0),
        Vector3::new(0.3, -0.5, 0.8),
        Vector3::new(0.0, 0.0, 1.0),
        Vector3::new(1.0, 1.0, 1.0),
        Vector3::new(-0.7, 0.2, -0.1),
    ];
    for entry in registry.entries() {
        let m = &entry.machine;
        let kin = solver_for(m);
        let boxes = JointBoxes::new(m).expect("three linear axes");
        for level in Level::ALL {
            let b = bounds(kin.as_ref(), &boxes, level).expect("bounds");
            assert!(b.lower > 0.0 && b.lower <= b.upper + 1e-9, "{}: {b:?}", m.name);
        }
        for d in &directions {
            let found = candidates(kin.as_ref(), &boxes, d, &Options::default()).expect("candidates");
            assert!(found.len() <= 16, "{}", m.name);
            for c in &found {
                // The forward kinematics of the set-up points the vertex along d.
                let map = JointMap::at(kin.as_ref(), &boxes, &c.joints).expect("map");
                let vertex = boxes.limits(Level::Jerk).component_mul(&Vector3::from(c.vertex.map(f64::from)));
                assert!(((map.to_part() * vertex).normalize() - d.normalize()).norm() < 1e-9, "{}", m.name);
                for &i in m.chain.part.iter().chain(&m.chain.tool) {
                    assert!(m.axes[i].travel.contains(c.joints[i]), "{}: {c:?}", m.name);
                }
            }
        }
    }
}

#[test]
fn a_head_table_turns_the_polytope_with_its_table_and_the_tool_with_its_head() {
    let m = machine("head-table");
    let kin = solver_for(&m);
    let boxes = JointBoxes::new(&m).expect("boxes");
    // The table (C about z) only turns directions about z: aim at a vertex turned by 30° about z.
    let map = at_zero(kin.as_ref(), &boxes);
    let vertex = boxes.polytope(Level::Jerk, &map).vertices()[0].direction;
    let d = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.5) * vertex.into_inner();
    let reference = Unit::new_normalize(Vector3::new(0.3, 0.0, 1.0));
    let options = Options { reference_axis: reference, ..Options::default() };
    let found = candidates(kin.as_ref(), &boxes, &d, &options).expect("candidates");
    // The four vertices on the same side of z as the aimed one are reachable by the table.
    assert_eq!(found.len(), 4, "{found:?}");
    assert!(found.iter().all(|c| c.vertex[2] == 1));
    let c = found.iter().find(|c| c.vertex == [1, 1, 1]).expect("the aimed vertex");
    let (b, table) = (m.axis_index("B").expect("B"), m.axis_index("C").expect("C"));
    assert!((c.joints[table] + 0.5).abs() < 1e-9 || (c.joints[table] - 0.5).abs() < 1e-9, "{c:?}");
    // The head brings the tool nearer the reference than it is at B = 0.
    assert!(c.joints[b].abs() > 0.05 && c.tilt < reference.z.acos() - 0.05, "{c:?}");
    assert_eq!(c.axis_value(&m, "C"), Some(c.joints[table]));
    assert_eq!(c.axis_value(&m, "W"), None);
    // Off the cone of reachable directions: none.
    assert!(candidates(kin.as_ref(), &boxes, &Vector3::new(1.0, 0.0, 0.0), &options).expect("ok").is_empty());
}
