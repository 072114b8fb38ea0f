use std::time::Instant;

use super::*;
use crate::nc::{Arc, MotionKind, Plane};

fn motion(kind: MotionKind, from: [f64; 3], to: [f64; 3], line: usize) -> Motion {
    let feed = if matches!(kind, MotionKind::Rapid) { None } else { Some(100.0) };
    Motion { kind, from, from_known: true, to, rotary: Rotary::default(), vector: None, feed, line }
}

/// A path through `points` (feeds), numbered from `first_line`.
fn polyline(points: &[[f64; 3]], first_line: usize) -> Vec<Motion> {
    points.windows(2).enumerate().map(|(i, w)| motion(MotionKind::Feed, w[0], w[1], first_line + i)).collect()
}

fn quarter(from: [f64; 3], to: [f64; 3], center: [f64; 3], clockwise: bool, line: usize) -> Motion {
    motion(MotionKind::Arc(Arc { center, plane: Plane::Xy, clockwise, full_turns: 0 }), from, to, line)
}

#[test]
fn theirs_found_in_ours_in_order_with_extra_blocks_of_ours_between() {
    let ours = polyline(&[[0.0; 3], [1.0, 0.0, 0.0], [1.5, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0]], 10);
    let theirs = polyline(&[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.00004, 0.0], [2.0, 1.0, 0.0]], 100);
    let c = motions_in_order(&ours, &theirs, 1e-4, 1e-3);
    assert!(c.is_match(), "{c}");
    assert_eq!((c.compared, c.matched), (3, 3));
}

#[test]
fn the_first_motion_of_theirs_not_in_ours_is_reported_with_both_lines() {
    let ours = polyline(&[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]], 10);
    // Their second block ends 0.01 off; their blocks are out of our order after it.
    let theirs = polyline(&[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.01, 0.0], [3.0, 0.0, 0.0]], 100);
    let c = motions_in_order(&ours, &theirs, 1e-4, 1e-3);
    let m = c.mismatch.clone().expect("a mismatch");
    assert_eq!((c.matched, m.theirs_line, m.ours_line), (1, 101, Some(11)));
    assert_eq!(m.nearest.map(|(line, _, _)| line), Some(11));
    assert!(m.reason.contains("0.010000 off"), "{}", m.reason);
    assert_eq!(
        c.to_string(),
        "1 of 3 found in order; their line 101 (to X2 Y0.01 Z0) is not in ours from our line 11 on; nearest: \
         our line 11 to X2 Y0 Z0 (0.010000 off): the end point is 0.010000 off, beyond 0.0001"
    );
    // Order matters: the same motions reversed are not found.
    let reversed: Vec<Motion> = theirs.iter().rev().copied().collect();
    assert!(!motions_in_order(&ours, &reversed, 1e-4, 1e-3).is_match());
}

#[test]
fn rotary_values_are_compared_where_both_programs_give_them() {
    let mut ours = polyline(&[[0.0; 3], [1.0, 0.0, 0.0]], 1);
    let mut theirs = ours.clone();
    ours[0].rotary = Rotary { a: Some(5.0), b: Some(-22.2010), c: Some(1.05) };
    theirs[0].rotary = Rotary { a: None, b: Some(-22.201), c: Some(1.0504) };
    assert!(motions_in_order(&ours, &theirs, 1e-4, 1e-3).is_match());
    theirs[0].rotary.c = Some(361.05);
    let c = motions_in_order(&ours, &theirs, 1e-4, 1e-3);
    assert!(c.mismatch.is_some_and(|m| m.reason.contains("rotary axes differ by 360.000000°")));
}

#[test]
fn arcs_match_needs_the_same_end_centre_plane_and_sense() {
    let ours = vec![
        motion(MotionKind::Feed, [0.0; 3], [10.0, 0.0, 0.0], 1),
        quarter([10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0; 3], false, 2),
        quarter([0.0, 10.0, 0.0], [-10.0, 0.0, 0.0], [0.0; 3], false, 3),
    ];
    let theirs = vec![quarter([10.0, 0.0, 0.0], [-10.0, 0.0, 0.0], [0.0; 3], false, 7)];
    assert!(arcs_match(&ours, &theirs, 1e-4).is_match(), "a split arc ends where theirs does");
    let cw = vec![quarter([10.0, 0.0, 0.0], [-10.0, 0.0, 0.0], [0.0; 3], true, 7)];
    let c = arcs_match(&ours, &cw, 1e-4);
    assert_eq!(c.mismatch.map(|m| m.reason), Some("our arc runs counter-clockwise, theirs clockwise".to_string()));
    let other_centre = vec![quarter([10.0, 0.0, 0.0], [-10.0, 0.0, 0.0], [0.0, -1.0, 0.0], false, 7)];
    assert!(!arcs_match(&ours, &other_centre, 1e-4).is_match());
    // Straight motions of theirs are not compared.
    assert_eq!(arcs_match(&ours, &ours[..1], 1e-4).compared, 0);
}

#[test]
fn the_feed_path_length_leaves_rapids_out_and_counts_arcs_along_their_sweep() {
    let motions = vec![
        motion(MotionKind::Rapid, [0.0, 0.0, 50.0], [0.0, 0.0, 0.0], 1),
        motion(MotionKind::Feed, [0.0; 3], [10.0, 0.0, 0.0], 2),
        quarter([10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0; 3], true, 3),
    ];
    let expected = 10.0 + 10.0 * 1.5 * std::f64::consts::PI;
    assert!((feed_path_length(&motions) - expected).abs() < 1e-12);
}

#[test]
fn the_farthest_point_from_a_feed_path_is_found_with_its_line() {
    let mut motions = vec![motion(MotionKind::Rapid, [0.0, 0.0, 50.0], [0.0; 3], 1)];
    motions.extend(polyline(&[[0.0; 3], [10.0, 0.0, 0.0], [10.0, 10.0, 0.0]], 2));
    let points = [[0.0; 3], [5.0, 0.02, 0.0], [10.0, 5.0, 0.03], [0.0, 0.0, 40.0]];
    let far = max_distance_of_points_to_feed_path(&points[..3], &motions).expect("points");
    assert_eq!((far.point, far.line), (2, Some(3)));
    assert!((far.distance - 0.03).abs() < 1e-12);
    // A point on the rapid is far from the feed path.
    let far = max_distance_of_points_to_feed_path(&points, &motions).expect("points");
    assert_eq!((far.point, far.line), (3, Some(2)));
    assert!((far.distance - 40.0).abs() < 1e-12);
    assert_eq!(max_distance_of_points_to_feed_path(&[], &motions), None);
    let none = max_distance_of_points_to_feed_path(&points, &motions[..1]).expect("points");
    assert_eq!((none.distance, none.line), (f64::INFINITY, None));
}

/// A path that comes back through a point it passed long before (a retract at the same X Y,
/// many motions later): the walk follows the path there and finds the points after it, instead
/// of going back to the first pass and losing the way.
#[test]
fn the_walk_does_not_go_back_to_an_earlier_pass_through_the_same_point() {
    let mut path = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 3.0]];
    path.extend((0..80).map(|i| [100.0 + f64::from(i), 0.0, 0.0]));
    path.extend([[0.0, 0.0, 3.0], [0.0, 50.0, 3.0]]);
    let motions = polyline(&path, 1);
    // On the first retract, far out, where the path comes back, and on the motion after it.
    let points = [[0.0, 0.0, 1.5], [140.0, 0.0, 0.0], [0.0, 0.0, 3.0], [0.0, 25.0, 3.0]];
    let far = max_distance_of_points_to_feed_path(&points, &motions).expect("points");
    assert!(far.distance < 1e-12, "{far:?}");
}

/// 10⁵ points along a path of 2·10⁵ motions (a zigzag whose passes are 1 mm apart, a point
/// 0.001 above the middle of every other motion): the walk finds each point's pass, and takes far less than the
/// 2·10¹⁰ distance evaluations of a search over every pair.
#[test]
fn the_farthest_point_is_found_in_linear_time_on_large_paths() {
    let passes = 1000;
    let per_pass = 200;
    let mut path = Vec::new();
    for pass in 0..passes {
        let y = pass as f64;
        for i in 0..=per_pass {
            let x = if pass % 2 == 0 { i as f64 } else { (per_pass - i) as f64 };
            path.push([x * 0.5, y, 0.0]);
        }
    }
    let motions = polyline(&path, 1);
    assert!(motions.len() >= 200_000);
    let points: Vec<[f64; 3]> =
        motions.iter().step_by(2).map(|m| m.point_at(0.5)).map(|p| [p[0], p[1], 0.001]).collect();
    assert!(points.len() >= 100_000);
    let started = Instant::now();
    let far = max_distance_of_points_to_feed_path(&points, &motions).expect("points");
    let elapsed = started.elapsed();
    assert!((far.distance - 0.001).abs() < 1e-12, "{far:?}");
    assert!(elapsed.as_secs_f64() < 20.0, "{elapsed:?}");
}
