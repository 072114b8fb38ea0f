use std::f64::consts::{FRAC_PI_2, PI, TAU};

use super::*;
use crate::testing::{close, close3};

fn arc(from: [f64; 3], to: [f64; 3], center: [f64; 3], plane: Plane, clockwise: bool, full_turns: u32) -> Motion {
    Motion { kind: MotionKind::Arc(Arc { center, plane, clockwise, full_turns }), ..feed(from, to) }
}

fn feed(from: [f64; 3], to: [f64; 3]) -> Motion {
    Motion {
        kind: MotionKind::Feed,
        from,
        from_known: true,
        to,
        rotary: Rotary::default(),
        vector: None,
        feed: Some(100.0),
        line: 1,
    }
}

/// The lengths LinuxCNC's rs274 computes for the same arcs (the rate of an inverse-time `F1`
/// block is its length per minute; `e.ngc` of the harness notes, radius 10): a quarter
/// counter-clockwise and three quarters clockwise in each plane, a full circle, three turns, and
/// helices of 630°.
#[test]
fn arc_lengths_are_those_rs274_computes() {
    let cases = [
        // G17 G3 X0 Y10 I-10 J0 from X10 Y0: 15.7080; G2: 47.1239.
        (arc([10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0; 3], Plane::Xy, false, 0), 15.7080),
        (arc([10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0; 3], Plane::Xy, true, 0), 47.1239),
        // G18 G3 X0 Z-10 I-10 K0 from X10 Z0: 15.7080; G2: 47.1239.
        (arc([10.0, 0.0, 0.0], [0.0, 0.0, -10.0], [0.0; 3], Plane::Zx, false, 0), 15.7080),
        (arc([10.0, 0.0, 0.0], [0.0, 0.0, -10.0], [0.0; 3], Plane::Zx, true, 0), 47.1239),
        // G19 G3 Y0 Z10 J-10 K0 from Y10 Z0: 15.7080; G2: 47.1239.
        (arc([0.0, 10.0, 0.0], [0.0, 0.0, 10.0], [0.0; 3], Plane::Yz, false, 0), 15.7080),
        (arc([0.0, 10.0, 0.0], [0.0, 0.0, 10.0], [0.0; 3], Plane::Yz, true, 0), 47.1239),
        // G3 X10 Y0 I-10 J0 from X10 Y0 (a full circle): 62.8319; with P3: 188.4956.
        (arc([10.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0; 3], Plane::Xy, false, 0), 62.8319),
        (arc([10.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0; 3], Plane::Xy, false, 2), 188.4956),
        // G17 G2 X0 Y10 I-10 J0 P2 Z5: 110.0694; G18 G2 X0 Z-10 I-10 K0 Y7 P2: 110.1783.
        (arc([10.0, 0.0, 0.0], [0.0, 10.0, 5.0], [0.0; 3], Plane::Xy, true, 1), 110.0694),
        (arc([10.0, 0.0, 0.0], [0.0, 7.0, -10.0], [0.0; 3], Plane::Zx, true, 1), 110.1783),
        // G19 G3 Y0 Z10 J-10 K0 X3: 15.9919.
        (arc([0.0, 10.0, 0.0], [3.0, 0.0, 10.0], [0.0; 3], Plane::Yz, false, 0), 15.9919),
    ];
    for (i, (motion, rs274)) in cases.iter().enumerate() {
        assert!(close(motion.length(), *rs274, 5e-5), "case {i}: {} against rs274's {rs274}", motion.length());
    }
}

#[test]
fn points_along_an_arc_turn_in_its_sense_and_end_at_its_end() {
    // A quarter clockwise about Z from (10, 0) is the long way round through (0, -10).
    let m = arc([10.0, 0.0, 0.0], [0.0, 10.0, 4.0], [0.0; 3], Plane::Xy, true, 0);
    assert!(close(m.sweep().unwrap_or(0.0), 1.5 * PI, 1e-12));
    assert!(close3(m.point_at(0.0), m.from, 1e-12));
    assert!(close3(m.point_at(1.0), m.to, 1e-12));
    assert!(close3(m.point_at(1.0 / 3.0), [0.0, -10.0, 4.0 / 3.0], 1e-12));
    // G18 counter-clockwise (about +Y) from X10 Z0: a quarter reaches Z-10 through X7.07 Z-7.07.
    let m = arc([10.0, 0.0, 0.0], [0.0, 0.0, -10.0], [0.0; 3], Plane::Zx, false, 0);
    assert!(close(m.sweep().unwrap_or(0.0), FRAC_PI_2, 1e-12));
    assert!(close3(m.point_at(0.5), [50f64.sqrt(), 0.0, -(50f64.sqrt())], 1e-12));
    // G19 counter-clockwise (about +X) from Y10 Z0 reaches Z10 through Y7.07 Z7.07.
    let m = arc([0.0, 10.0, 0.0], [0.0, 0.0, 10.0], [0.0; 3], Plane::Yz, false, 0);
    assert!(close3(m.point_at(0.5), [0.0, 50f64.sqrt(), 50f64.sqrt()], 1e-12));
    // A full circle with one more turn sweeps 720°.
    let m = arc([10.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0; 3], Plane::Xy, false, 1);
    assert!(close(m.sweep().unwrap_or(0.0), 2.0 * TAU, 1e-12));
    assert!(close3(m.point_at(0.125), [0.0, 10.0, 0.0], 1e-12));
}

#[test]
fn a_spiral_is_as_long_as_its_numerical_integral() {
    // End radius 12 for start radius 10, half a turn, rising 3.
    let m = arc([10.0, 0.0, 0.0], [-12.0, 0.0, 3.0], [0.0; 3], Plane::Xy, false, 0);
    let n = 200_000;
    let numeric: f64 = (0..n)
        .map(|i| {
            let (a, b) = (m.point_at(i as f64 / n as f64), m.point_at((i + 1) as f64 / n as f64));
            ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
        })
        .sum();
    assert!(close(m.length(), numeric, 1e-8), "{} against {numeric}", m.length());
}

#[test]
fn the_distance_to_a_straight_motion_is_to_the_segment() {
    let m = feed([0.0, 0.0, 0.0], [10.0, 0.0, 0.0]);
    assert!(close(m.distance_to_point([5.0, 3.0, 4.0]), 5.0, 1e-12));
    assert!(close(m.distance_to_point([-3.0, 4.0, 0.0]), 5.0, 1e-12));
    assert!(close(m.distance_to_point([13.0, 0.0, 4.0]), 5.0, 1e-12));
    assert!(close(feed([1.0; 3], [1.0; 3]).distance_to_point([1.0, 1.0, 3.0]), 2.0, 1e-12));
    assert!(close(m.length(), 10.0, 1e-12));
}

#[test]
fn the_distance_to_a_planar_arc_is_exact_inside_and_outside_its_sweep() {
    // A quarter counter-clockwise from (10, 0) to (0, 10).
    let m = arc([10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0; 3], Plane::Xy, false, 0);
    // On the ray at 45°, 2 out and 1 above: √(2² + 1²).
    let p = [12.0 * (PI / 4.0).cos(), 12.0 * (PI / 4.0).sin(), 1.0];
    assert!(close(m.distance_to_point(p), 5f64.sqrt(), 1e-12));
    // The centre is 10 from every point of the arc.
    assert!(close(m.distance_to_point([0.0, 0.0, 0.0]), 10.0, 1e-12));
    // At 225° (outside the sweep), the nearest points are the ends.
    let p = [-5.0, -5.0, 0.0];
    let ends = ((15.0f64).powi(2) + 25.0).sqrt();
    assert!(close(m.distance_to_point(p), ends, 1e-12));
    // The same point is on the ray of the three-quarter arc the other way.
    let m = arc([10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0; 3], Plane::Xy, true, 0);
    assert!(close(m.distance_to_point(p), 10.0 - 50f64.sqrt(), 1e-12));
    // In the ZX plane: a quarter about +Y from X10 Z0 to X0 Z-10; a point at X−10 is outside.
    let m = arc([10.0, 0.0, 0.0], [0.0, 0.0, -10.0], [0.0; 3], Plane::Zx, false, 0);
    assert!(close(m.distance_to_point([7.0, 2.0, -7.0]), (10.0 - 98f64.sqrt()).hypot(2.0), 1e-12));
    assert!(close(m.distance_to_point([-10.0, 0.0, 0.0]), 200f64.sqrt(), 1e-12));
}

#[test]
fn the_distance_to_a_helix_is_the_minimum_over_its_points() {
    // Two and a half turns of radius 10 rising 20.
    let m = arc([10.0, 0.0, 0.0], [-10.0, 0.0, 20.0], [0.0; 3], Plane::Xy, false, 2);
    let brute = |p: [f64; 3]| {
        let n = 400_000;
        (0..=n)
            .map(|i| {
                let q = m.point_at(i as f64 / n as f64);
                ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)).sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    };
    for p in [[0.0, 0.0, 7.0], [13.0, 2.0, 9.0], [-4.0, 6.0, 25.0], [30.0, -30.0, -5.0], [0.0, 10.0, 10.0]] {
        let d = m.distance_to_point(p);
        let b = brute(p);
        assert!(d <= b + 1e-9 && b - d < 1e-6, "{p:?}: {d} against {b} sampled");
    }
    // On the helix.
    assert!(m.distance_to_point(m.point_at(0.37)) < 1e-9);
}

#[test]
fn a_program_converts_to_other_units() {
    let mut m = arc([25.4, 0.0, 0.0], [0.0, 25.4, 0.0], [0.0; 3], Plane::Xy, false, 0);
    m.rotary.b = Some(30.0);
    let program = Program {
        name: "p".into(),
        units: Units::Mm,
        motions: vec![m],
        events: vec![Event {
            line: 1,
            before: 0,
            kind: EventKind::LengthOffset { register: Some(1), offset: Some([0.0, 0.0, 254.0]) },
        }],
    };
    let inch = program.in_units(Units::Inch);
    assert_eq!(inch.units, Units::Inch);
    assert!(close3(inch.motions[0].from, [1.0, 0.0, 0.0], 1e-12));
    assert!(close(inch.motions[0].feed.unwrap_or(0.0), 100.0 / 25.4, 1e-12));
    assert_eq!(inch.motions[0].rotary.b, Some(30.0));
    assert!(close(inch.motions[0].length() * 25.4, program.motions[0].length(), 1e-9));
    assert_eq!(inch.events[0].kind, EventKind::LengthOffset { register: Some(1), offset: Some([0.0, 0.0, 10.0]) });
    assert_eq!(Units::Inch.factor(Units::Mm), 25.4);
}

#[test]
fn rotary_values_are_found_by_letter() {
    let mut r = Rotary::default();
    assert!(r.set('b', 12.5));
    assert!(!r.set('X', 1.0));
    assert_eq!(r.get('B'), Some(12.5));
    assert_eq!(r.get('C'), None);
}

/// The working planes' frames: Fanuc's Euler angles Z X Z, Siemens's axis by axis X Y Z and
/// Heidenhain's base and normal vectors give the same plane for the same set-up (the tool along
/// +X, the plane's x along −Z, as postpro writes `G68.2 … I90 J90 K-90`, `CYCLE800(… 0, 90, 0 …)`
/// and `PLANE VECTOR BX+0 BY+0 BZ-1 NX+1 NY+0 NZ+0`); points go out of the plane and back.
#[test]
fn working_plane_frames_agree_across_dialects() {
    let fanuc = Frame::euler_zxz([1.0, 2.0, 3.0], [90.0, 90.0, -90.0]);
    let heidenhain = Frame::from_vectors([1.0, 2.0, 3.0], [0.0, 0.0, -1.0], [2.0, 0.0, 0.0]).expect("a frame");
    let siemens = Frame::euler_xyz([1.0, 2.0, 3.0], [0.0, 90.0, 0.0]);
    for k in 0..3 {
        assert!(close3(fanuc.axes[k], heidenhain.axes[k], 1e-12), "{fanuc:?} {heidenhain:?}");
    }
    assert!(close3(siemens.z(), [1.0, 0.0, 0.0], 1e-12) && close3(siemens.axes[0], [0.0, 0.0, -1.0], 1e-12));
    // Rz(40)·Rx(30): the tool axis tilted 30° about X, then turned 40° about Z.
    let z = Frame::euler_zxz([0.0; 3], [40.0, 30.0, 0.0]).z();
    let (s30, c30, s40, c40) = (0.5, 0.75f64.sqrt(), 40f64.to_radians().sin(), 40f64.to_radians().cos());
    assert!(close3(z, [s30 * s40, -s30 * c40, c30], 1e-12), "{z:?}");
    // Rx(A)·Ry(B)·Rz(C): the z axis is Rx(A)·Ry(B)·z.
    let f = Frame::euler_xyz([0.0; 3], [20.0, 30.0, 50.0]);
    let (sa, ca, sb, cb) = (20f64.to_radians().sin(), 20f64.to_radians().cos(), 0.5, 0.75f64.sqrt());
    assert!(close3(f.z(), [sb, -sa * cb, ca * cb], 1e-12), "{:?}", f.z());
    let p = [4.0, -5.0, 6.0];
    assert!(close3(f.inner(f.outer(p)), p, 1e-12) && close3(fanuc.outer([0.0, 0.0, 2.0]), [3.0, 2.0, 3.0], 1e-12));
    let e = Frame::from_vectors([0.0; 3], [1.0, 0.0, 0.1], [0.0, 0.0, 1.0]).expect_err("not perpendicular");
    assert!(e.contains("not perpendicular"), "{e}");
}
