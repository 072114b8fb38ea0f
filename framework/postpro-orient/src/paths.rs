//! The paths of a program and their feed directions (paper 004 eqs. 23–24).
//!
//! A **path** is a run of feed moves (lines, arcs, NURBS) between the things that interrupt
//! cutting: rapid moves, feed moves along the tool axis (plunges and retracts), tool changes,
//! cycles, stops, operation boundaries. Its feed direction is taken two ways:
//!
//! - `mean`, the paper's: the length-weighted mean of the unit tangents,
//!   `(1/s) ∫ f ds` (eq. 24), i.e. the chord over the length; over the part, the paths' means
//!   weighted by their lengths (eq. 23). It is **signed**: the passes of a zig-zag cancel, and a
//!   closed contour has none.
//! - `axis`, sign-free: the principal eigenvector of the scatter `Σ Lᵢ dᵢ dᵢᵀ` of the moves
//!   (length `Lᵢ`, unit direction `dᵢ`). The polytope is symmetric, so the sense of travel does
//!   not matter, and a zig-zag keeps its direction. For one straight segment both agree; for a
//!   gently curved path they differ by second-order terms. `straightness` (largest eigenvalue
//!   over the length: 1 for a straight path, ⅓ for directions spread evenly in space) says
//!   how well one direction represents the path.
//!
//! Arcs are measured by chords every 5° of sweep, NURBS by chords at eight points per control
//! point.

use std::ops::Range;

use nalgebra::{Matrix3, Point3, SymmetricEigen, Unit, Vector3};
use postpro_cl::{ItemKind, Motion, MoveKind, Nurbs, Span, ToolPath};

/// How a program is cut into paths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitOptions {
    /// A feed move within this angle (degrees) of the tool axis is a plunge or a retract: it
    /// belongs to no path and ends the current one.
    pub axial_angle_deg: f64,
    /// Paths shorter than this (mm) are left out.
    pub min_length: f64,
}

impl Default for SplitOptions {
    /// Plunges and retracts within 5° of the tool axis; every path kept.
    fn default() -> SplitOptions {
        SplitOptions { axial_angle_deg: 5.0, min_length: 0.0 }
    }
}

/// One path: a run of feed moves.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    /// The items of the tool path it spans (indices into `ToolPath::items`).
    pub items: Range<usize>,
    /// The CL statements it spans.
    pub span: Span,
    /// Moves (lines, arcs, curves) in it.
    pub moves: usize,
    /// Where it starts and ends.
    pub start: Point3<f64>,
    /// Where it ends.
    pub end: Point3<f64>,
    /// Its length (mm).
    pub length: f64,
    /// The paper's mean feed direction (eq. 24): `Σ Lᵢ dᵢ / Σ Lᵢ`, not a unit vector.
    pub mean: Vector3<f64>,
    /// The sign-free feed direction: the principal axis of `scatter`, turned to agree with
    /// `mean` (or, without a mean, with its largest component positive).
    pub axis: Unit<Vector3<f64>>,
    /// The largest eigenvalue of `scatter` over the length, in [⅓, 1].
    pub straightness: f64,
    /// `Σ Lᵢ dᵢ dᵢᵀ` (mm).
    pub scatter: Matrix3<f64>,
}

/// The feed direction of the whole part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartDirection {
    /// Paths counted.
    pub paths: usize,
    /// Their total length (mm).
    pub length: f64,
    /// The paper's eq. 23: the paths' means weighted by their lengths, `Σ mean_p L_p / Σ L_p`.
    pub mean: Vector3<f64>,
    /// The sign-free direction: the principal axis of the sum of the paths' scatters.
    pub axis: Unit<Vector3<f64>>,
    /// The largest eigenvalue of that sum over the length.
    pub straightness: f64,
}

/// The paths of a tool path, in program order.
pub fn split(path: &ToolPath, options: &SplitOptions) -> Vec<Path> {
    let axial_cos = options.axial_angle_deg.to_radians().cos();
    let mut out = Vec::new();
    let mut current: Option<Builder> = None;
    let mut position: Option<Point3<f64>> = None;
    let mut close = |current: &mut Option<Builder>| {
        if let Some(path) = current.take().and_then(Builder::finish).filter(|p| p.length >= options.min_length) {
            out.push(path);
        }
    };
    for (index, item) in path.items.iter().enumerate() {
        match &item.kind {
            ItemKind::Move(m) => {
                let from = position.replace(m.to);
                let cutting =
                    matches!(m.motion, Motion::Feed(_)) && matches!(m.kind, MoveKind::Goto | MoveKind::Godlta);
                let Some(from) = from.filter(|_| cutting) else {
                    close(&mut current);
                    continue;
                };
                let step = m.to - from;
                let length = step.norm();
                if !length.is_finite() {
                    close(&mut current);
                    continue;
                }
                if length <= 1e-9 {
                    continue;
                }
                if (step.dot(&m.axis) / length).abs() >= axial_cos {
                    close(&mut current);
                    continue;
                }
                let b = current.get_or_insert_with(|| Builder::new(index, item.span, from));
                b.add(index, item.span, &[from, m.to]);
            }
            ItemKind::Arc(a) => {
                position = Some(a.end);
                if !matches!(a.motion, Motion::Feed(_)) {
                    close(&mut current);
                    continue;
                }
                let n = (a.sweep.abs() / 5f64.to_radians()).ceil().clamp(1.0, 10_000.0) as usize;
                let mut points: Vec<Point3<f64>> = (0..n).map(|k| a.point_at(k as f64 / n as f64)).collect();
                points.push(a.end);
                let b = current.get_or_insert_with(|| Builder::new(index, item.span, a.start));
                b.add(index, item.span, &points);
            }
            ItemKind::Nurbs(n) => {
                let from = position.replace(n.end());
                if !matches!(n.motion, Motion::Feed(_)) {
                    close(&mut current);
                    continue;
                }
                let points = nurbs_points(n, from);
                if let Some(&first) = points.first() {
                    let b = current.get_or_insert_with(|| Builder::new(index, item.span, first));
                    b.add(index, item.span, &points);
                }
            }
            ItemKind::ToolChange(_)
            | ItemKind::CycleOn(_)
            | ItemKind::CycleOff
            | ItemKind::Stop(_)
            | ItemKind::OptionalStop
            | ItemKind::OperationStart(_)
            | ItemKind::OperationEnd
            | ItemKind::Multax(_)
            | ItemKind::End
            | ItemKind::Fini => close(&mut current),
            _ => {}
        }
    }
    close(&mut current);
    out
}

/// The direction of the whole part from its paths: eq. 23 and the sign-free axis.
pub fn part_direction(paths: &[Path]) -> PartDirection {
    let length: f64 = paths.iter().map(|p| p.length).sum();
    let sum: Vector3<f64> = paths.iter().map(|p| p.mean * p.length).sum();
    let mean = if length > 0.0 { sum / length } else { Vector3::zeros() };
    let scatter: Matrix3<f64> = paths.iter().map(|p| p.scatter).sum();
    let (axis, top) = principal(&scatter, &mean);
    let straightness = if length > 0.0 { top / length } else { 0.0 };
    PartDirection { paths: paths.len(), length, mean, axis, straightness }
}

/// A path being gathered.
struct Builder {
    first: usize,
    last: usize,
    span: Span,
    moves: usize,
    start: Point3<f64>,
    end: Point3<f64>,
    length: f64,
    sum: Vector3<f64>,
    scatter: Matrix3<f64>,
}

impl Builder {
    fn new(index: usize, span: Span, start: Point3<f64>) -> Builder {
        Builder {
            first: index,
            last: index,
            span,
            moves: 0,
            start,
            end: start,
            length: 0.0,
            sum: Vector3::zeros(),
            scatter: Matrix3::zeros(),
        }
    }

    /// One move through `points` (chords).
    fn add(&mut self, index: usize, span: Span, points: &[Point3<f64>]) {
        for w in points.windows(2) {
            let step = w[1] - w[0];
            let length = step.norm();
            if length.is_finite() && length > 0.0 {
                self.length += length;
                self.sum += step;
                self.scatter += step * step.transpose() / length;
            }
        }
        if let Some(&end) = points.last() {
            self.end = end;
        }
        self.moves += 1;
        self.last = index;
        self.span = self.span.to(span);
    }

    fn finish(self) -> Option<Path> {
        if self.length.is_nan() || self.length <= 0.0 {
            return None;
        }
        let mean = self.sum / self.length;
        let (axis, top) = principal(&self.scatter, &mean);
        Some(Path {
            items: self.first..self.last + 1,
            span: self.span,
            moves: self.moves,
            start: self.start,
            end: self.end,
            length: self.length,
            mean,
            axis,
            straightness: top / self.length,
            scatter: self.scatter,
        })
    }
}

/// The principal axis of a scatter matrix and its eigenvalue, turned to agree with `mean`
/// (or, where `mean` is orthogonal to it, with its largest component positive). +x for a zero
/// or non-finite matrix.
fn principal(scatter: &Matrix3<f64>, mean: &Vector3<f64>) -> (Unit<Vector3<f64>>, f64) {
    let fallback = (Vector3::x_axis(), 0.0);
    if !scatter.iter().all(|v| v.is_finite()) {
        return fallback;
    }
    let Some(eigen) = SymmetricEigen::try_new(*scatter, 1e-15, 1000) else { return fallback };
    let Some((k, &top)) = eigen.eigenvalues.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
        return fallback;
    };
    let Some(mut axis) = Unit::try_new(eigen.eigenvectors.column(k).into_owned(), 1e-12) else { return fallback };
    let along = axis.dot(mean);
    let flip = if along.abs() > 1e-9 {
        along < 0.0
    } else {
        let big = axis.iter().copied().max_by(|a, b| a.abs().total_cmp(&b.abs())).unwrap_or(1.0);
        big < 0.0
    };
    if flip {
        axis = -axis;
    }
    (axis, top.max(0.0))
}

/// Points along a NURBS curve from `from` (its start), or the chord to its end when the curve
/// is malformed.
fn nurbs_points(n: &Nurbs, from: Option<Point3<f64>>) -> Vec<Point3<f64>> {
    let count = n.control.len();
    let well_formed = count > n.degree
        && n.degree >= 1
        && n.knots.len() == count + n.degree + 1
        && n.knots.iter().all(|k| k.is_finite())
        && n.knots.windows(2).all(|w| w[0] <= w[1]);
    let start = from.or_else(|| n.control.first().copied());
    if !well_formed {
        return start.into_iter().chain(Some(n.end())).collect();
    }
    let samples = (8 * count).clamp(8, 10_000);
    start.into_iter().chain(n.even_points(samples)).collect()
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point3, Vector3};
    use postpro_cl::{Arc, Feed, FeedPer, Item, ItemKind, Motion, Move, MoveKind, Nurbs, Span, ToolPath};

    use super::*;

    const FEED: Motion = Motion::Feed(Feed { value: 1000.0, per: FeedPer::Minute });

    struct Program(Vec<Item>);

    impl Program {
        fn push(&mut self, kind: ItemKind) -> &mut Self {
            let n = self.0.len();
            self.0.push(Item { span: Span::new(10 * n, 10 * n + 5), kind });
            self
        }
        fn go(&mut self, motion: Motion, to: [f64; 3]) -> &mut Self {
            let m = Move { to: Point3::from(to), axis: Vector3::z_axis(), motion, kind: MoveKind::Goto };
            self.push(ItemKind::Move(m))
        }
        fn feed(&mut self, to: [f64; 3]) -> &mut Self {
            self.go(FEED, to)
        }
        fn rapid(&mut self, to: [f64; 3]) -> &mut Self {
            self.go(Motion::Rapid, to)
        }
        fn path(&self) -> ToolPath {
            ToolPath { items: self.0.clone(), ..ToolPath::default() }
        }
    }

    fn close(a: &Vector3<f64>, b: [f64; 3], tol: f64) -> bool {
        (a - Vector3::from(b)).norm() < tol
    }

    #[test]
    fn a_zig_zag_cancels_in_the_mean_not_in_the_axis() {
        let mut p = Program(Vec::new());
        for k in 0..4 {
            let y = f64::from(k) * 5.0;
            let (x0, x1) = if k % 2 == 0 { (0.0, 100.0) } else { (100.0, 0.0) };
            // Rapid above, plunge along the tool axis, cut, retract along the tool axis.
            p.rapid([x0, y, 20.0]).feed([x0, y, 0.0]).feed([x1, y, 0.0]).feed([x1, y, 20.0]);
        }
        let paths = split(&p.path(), &SplitOptions::default());
        assert_eq!(paths.len(), 4);
        for (k, path) in paths.iter().enumerate() {
            assert_eq!(path.moves, 1);
            assert_eq!(path.items, 4 * k + 2..4 * k + 3);
            assert_eq!(path.span, p.0[4 * k + 2].span);
            assert!((path.length - 100.0).abs() < 1e-12);
            let sense = if k % 2 == 0 { 1.0 } else { -1.0 };
            assert!(close(&path.mean, [sense, 0.0, 0.0], 1e-12), "{:?}", path.mean);
            assert!(close(&path.axis, [sense, 0.0, 0.0], 1e-12), "{:?}", path.axis);
            assert!((path.straightness - 1.0).abs() < 1e-12);
        }
        let part = part_direction(&paths);
        assert_eq!(part.paths, 4);
        assert!((part.length - 400.0).abs() < 1e-9);
        // Eq. 23 as printed: the passes cancel.
        assert!(part.mean.norm() < 1e-12, "{:?}", part.mean);
        assert!(close(&part.axis, [1.0, 0.0, 0.0], 1e-12) && (part.straightness - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rapids_and_tool_changes_split_other_items_do_not() {
        let mut p = Program(Vec::new());
        p.rapid([0.0, 0.0, 0.0]).feed([10.0, 0.0, 0.0]);
        p.push(ItemKind::Comment("between".into())).push(ItemKind::Coolant(postpro_cl::Coolant::Flood));
        p.feed([10.0, 10.0, 0.0]).feed([10.0, 10.0, 0.0]); // a zero-length move changes nothing
        p.push(ItemKind::ToolChange(postpro_cl::ToolChange { number: 2, adjust: None, name: None }));
        p.feed([20.0, 10.0, 0.0]).rapid([0.0, 0.0, 50.0]).feed([0.0, 0.0, 40.0]).feed([0.0, 3.0, 40.0]);
        p.go(Motion::Unset, [5.0, 5.0, 5.0]).feed([5.0, 6.0, 5.0]);
        let paths = split(&p.path(), &SplitOptions::default());
        let summary: Vec<(usize, f64)> = paths.iter().map(|p| (p.moves, p.length)).collect();
        assert_eq!(summary, [(2, 20.0), (1, 10.0), (1, 3.0), (1, 1.0)]);
        // An L: the two legs weigh equally; straightness one half.
        assert!((paths[0].straightness - 0.5).abs() < 1e-12);
        assert!(close(&paths[0].mean, [0.5, 0.5, 0.0], 1e-12));
        let long = split(&p.path(), &SplitOptions { min_length: 5.0, ..SplitOptions::default() });
        assert_eq!(long.len(), 2);
        assert!(split(&ToolPath::default(), &SplitOptions::default()).is_empty());
        let part = part_direction(&[]);
        assert_eq!((part.paths, part.length, part.straightness), (0, 0.0, 0.0));
    }

    #[test]
    fn a_full_circle_has_no_mean_and_an_in_plane_axis() {
        let mut p = Program(Vec::new());
        p.rapid([10.0, 0.0, 0.0]);
        let arc = Arc {
            start: Point3::new(10.0, 0.0, 0.0),
            center: Point3::origin(),
            normal: Vector3::z_axis(),
            radius: 10.0,
            end: Point3::new(10.0, 0.0, 0.0),
            sweep: std::f64::consts::TAU,
            axis: Vector3::z_axis(),
            motion: FEED,
        };
        p.push(ItemKind::Arc(Box::new(arc)));
        let paths = split(&p.path(), &SplitOptions::default());
        assert_eq!(paths.len(), 1);
        let path = &paths[0];
        assert!((path.length - 20.0 * std::f64::consts::PI).abs() < 0.03, "{}", path.length);
        assert!(path.mean.norm() < 1e-9);
        assert!(path.axis.z.abs() < 1e-9 && (path.straightness - 0.5).abs() < 1e-9, "{path:?}");
        assert_eq!(path.end, Point3::new(10.0, 0.0, 0.0));
    }

    #[test]
    fn nurbs_curves_are_followed_and_malformed_ones_taken_as_chords() {
        let mut p = Program(Vec::new());
        p.rapid([0.0, 0.0, 0.0]);
        let curve = Nurbs {
            degree: 2,
            knots: vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            control: vec![Point3::origin(), Point3::new(10.0, 10.0, 0.0), Point3::new(20.0, 0.0, 0.0)],
            axis: Vector3::z_axis(),
            motion: FEED,
        };
        p.push(ItemKind::Nurbs(Box::new(curve.clone())));
        let broken = Nurbs { knots: vec![0.0], ..curve.clone() };
        p.rapid([0.0, 0.0, 0.0]).push(ItemKind::Nurbs(Box::new(broken)));
        let unsorted = Nurbs { knots: vec![0.0, 0.0, 0.0, 1.0, 1.0, -1.0], ..curve };
        p.rapid([0.0, 0.0, 0.0]).push(ItemKind::Nurbs(Box::new(unsorted)));
        let paths = split(&p.path(), &SplitOptions::default());
        assert_eq!(paths.len(), 3);
        // The parabola from (0,0) through its apex (10,5) to (20,0): longer than its chord.
        assert!(paths[0].length > 22.9 && paths[0].length < 23.0, "{}", paths[0].length);
        assert!(close(&paths[0].mean, [20.0 / paths[0].length, 0.0, 0.0], 1e-9));
        assert!(close(&paths[0].axis, [1.0, 0.0, 0.0], 1e-9));
        assert!((paths[1].length - 20.0).abs() < 1e-12 && (paths[2].length - 20.0).abs() < 1e-12);
    }
}
