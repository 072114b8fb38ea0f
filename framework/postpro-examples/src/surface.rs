//! Tensor-product Bézier patches and the three test surfaces of the bundled examples.
//!
//! A patch of degree `(m, n)` has `(m + 1) × (n + 1)` control points `P_ij`; the first
//! index `i` runs along the parameter `u`, the second index `j` along `v`, and
//!
//! ```text
//! S(u, v) = Σ_i Σ_j B_i^m(u) · B_j^n(v) · P_ij,   (u, v) ∈ [0, 1]²
//! ```
//!
//! with the Bernstein polynomials `B_i^m(t) = C(m, i) tⁱ (1 − t)^(m−i)`.
//!
//! # Orientation of the normal
//!
//! [`BezierPatch::normal`] is `∂S/∂u × ∂S/∂v`, normalised. For the three test surfaces
//! ([`BezierPatch::hyperbolic_paraboloid`], [`BezierPatch::manta`], [`BezierPatch::bicubic`])
//! `u` increases with `x` and `v` increases with `y`, so this normal points towards `+z`
//! (away from the material, towards the tool).

use std::fmt;

use nalgebra::{Point3, Vector3};

/// Why a control net cannot form a Bézier patch.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PatchError {
    /// The control net has no rows, or its first row has no points.
    Empty,
    /// Row `row` has `len` points while row 0 has `expected`.
    Ragged {
        /// Index of the offending row.
        row: usize,
        /// Number of points in that row.
        len: usize,
        /// Number of points in row 0.
        expected: usize,
    },
    /// A control point has a NaN or infinite coordinate.
    NotFinite {
        /// Index along `u`.
        i: usize,
        /// Index along `v`.
        j: usize,
    },
}

impl fmt::Display for PatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Empty => write!(f, "the control net of a Bézier patch must not be empty"),
            Self::Ragged { row, len, expected } => {
                write!(f, "the control net is not rectangular: row {row} has {len} points, row 0 has {expected}")
            }
            Self::NotFinite { i, j } => {
                write!(f, "control point P{i},{j} has a non-finite coordinate")
            }
        }
    }
}

impl std::error::Error for PatchError {}

/// A tensor-product Bézier patch of arbitrary degree, defined on `[0, 1]²`.
#[derive(Debug, Clone, PartialEq)]
pub struct BezierPatch {
    /// `control[i][j]` = `P_ij`, `i` along `u`, `j` along `v`.
    control: Vec<Vec<Vector3<f64>>>,
}

impl BezierPatch {
    /// Builds a patch from its control net: `control[i][j]` is `P_ij`, with `i` along `u`
    /// and `j` along `v`. The degree is `(control.len() − 1, control[0].len() − 1)`.
    ///
    /// # Panics
    ///
    /// Panics if the net is empty, not rectangular or has non-finite coordinates; use
    /// [`BezierPatch::try_new`] to get an error instead.
    #[must_use]
    pub fn new(control: Vec<Vec<[f64; 3]>>) -> Self {
        match Self::try_new(control) {
            Ok(patch) => patch,
            Err(e) => panic!("invalid Bézier control net: {e}"),
        }
    }

    /// Builds a patch from its control net (see [`BezierPatch::new`]), reporting an invalid
    /// net as an error.
    ///
    /// # Errors
    ///
    /// [`PatchError`] if the net is empty, ragged or has a non-finite coordinate.
    pub fn try_new(control: Vec<Vec<[f64; 3]>>) -> Result<Self, PatchError> {
        let expected = control.first().map_or(0, Vec::len);
        if expected == 0 {
            return Err(PatchError::Empty);
        }
        for (row, points) in control.iter().enumerate() {
            if points.len() != expected {
                return Err(PatchError::Ragged { row, len: points.len(), expected });
            }
            for (j, p) in points.iter().enumerate() {
                if p.iter().any(|c| !c.is_finite()) {
                    return Err(PatchError::NotFinite { i: row, j });
                }
            }
        }
        let control = control.into_iter().map(|row| row.into_iter().map(Vector3::from).collect()).collect();
        Ok(Self { control })
    }

    /// The hyperbolic paraboloid `z = (y² − x²) / 500` on `[−50, 50]²`, as a degree (2, 2)
    /// patch (`x = 100u − 50`, `y = 100v − 50`).
    ///
    /// Its two families of rulings are the lines `y = x + c` and `y = −x + c`, at 45° to
    /// the `x` and `y` axes.
    #[must_use]
    pub fn hyperbolic_paraboloid() -> Self {
        Self::new(vec![
            vec![[-50.0, -50.0, 0.0], [-50.0, 0.0, -10.0], [-50.0, 50.0, 0.0]],
            vec![[0.0, -50.0, 10.0], [0.0, 0.0, 0.0], [0.0, 50.0, 10.0]],
            vec![[50.0, -50.0, 0.0], [50.0, 0.0, -10.0], [50.0, 50.0, 0.0]],
        ])
    }

    /// The "Manta" test surface: a bicubic patch over `[0, 600]²` (`x = 600u`, `y = 600v`)
    /// with heights between 0 and 100.
    #[must_use]
    pub fn manta() -> Self {
        Self::new(vec![
            vec![[0.0, 0.0, 0.0], [0.0, 200.0, 0.0], [0.0, 400.0, 100.0], [0.0, 600.0, 100.0]],
            vec![[200.0, 0.0, 0.0], [200.0, 200.0, 0.0], [200.0, 400.0, 100.0], [200.0, 600.0, 100.0]],
            vec![[400.0, 0.0, 100.0], [400.0, 200.0, 100.0], [400.0, 400.0, 0.0], [400.0, 600.0, 0.0]],
            vec![[600.0, 0.0, 100.0], [600.0, 200.0, 100.0], [600.0, 400.0, 0.0], [600.0, 600.0, 0.0]],
        ])
    }

    /// The bicubic test surface of paper 002: `x_ij = 12i`, `y_ij = 12j` (so the patch
    /// covers `[0, 36]²` with `x = 36u`, `y = 36v`) and the height matrix
    ///
    /// ```text
    /// z = [[-16, -8, -6,  0],
    ///      [ -8, -6,  0, -2],
    ///      [ -6,  0, -2,  0],
    ///      [  0, -2,  0,  0]]
    /// ```
    #[must_use]
    pub fn bicubic() -> Self {
        const X: [[f64; 4]; 4] =
            [[0.0, 0.0, 0.0, 0.0], [12.0, 12.0, 12.0, 12.0], [24.0, 24.0, 24.0, 24.0], [36.0, 36.0, 36.0, 36.0]];
        const Z: [[f64; 4]; 4] =
            [[-16.0, -8.0, -6.0, 0.0], [-8.0, -6.0, 0.0, -2.0], [-6.0, 0.0, -2.0, 0.0], [0.0, -2.0, 0.0, 0.0]];
        let control = (0..4).map(|i| (0..4).map(|j| [X[i][j], X[j][i], Z[i][j]]).collect()).collect();
        Self::new(control)
    }

    /// Degree along `u` (number of control rows − 1).
    #[must_use]
    pub fn degree_u(&self) -> usize {
        self.control.len() - 1
    }

    /// Degree along `v` (number of control points per row − 1).
    #[must_use]
    pub fn degree_v(&self) -> usize {
        self.control.first().map_or(0, Vec::len) - 1
    }

    /// The control point `P_ij` (`i` along `u`, `j` along `v`), if it exists.
    #[must_use]
    pub fn control_point(&self, i: usize, j: usize) -> Option<[f64; 3]> {
        self.control.get(i).and_then(|row| row.get(j)).map(|p| [p.x, p.y, p.z])
    }

    /// Axis-aligned bounding box `(min, max)` of the control net. By the convex-hull
    /// property of Bézier patches it contains the whole surface.
    #[must_use]
    pub fn bounding_box(&self) -> (Point3<f64>, Point3<f64>) {
        let mut min = Vector3::repeat(f64::INFINITY);
        let mut max = Vector3::repeat(f64::NEG_INFINITY);
        for p in self.control.iter().flatten() {
            min = min.inf(p);
            max = max.sup(p);
        }
        (Point3::from(min), Point3::from(max))
    }

    /// The surface point `S(u, v)`. Parameters outside `[0, 1]` extrapolate the polynomial.
    #[must_use]
    pub fn point(&self, u: f64, v: f64) -> Point3<f64> {
        let bu = bernstein(self.degree_u(), u);
        let bv = bernstein(self.degree_v(), v);
        Point3::from(self.combine(&bu, &bv, |i, j| self.control[i][j]))
    }

    /// The first partial derivative `∂S/∂u` at `(u, v)`.
    #[must_use]
    pub fn du(&self, u: f64, v: f64) -> Vector3<f64> {
        let m = self.degree_u();
        if m == 0 {
            return Vector3::zeros();
        }
        let bu = bernstein(m - 1, u);
        let bv = bernstein(self.degree_v(), v);
        let d = self.combine(&bu, &bv, |i, j| self.control[i + 1][j] - self.control[i][j]);
        d * m as f64
    }

    /// The first partial derivative `∂S/∂v` at `(u, v)`.
    #[must_use]
    pub fn dv(&self, u: f64, v: f64) -> Vector3<f64> {
        let n = self.degree_v();
        if n == 0 {
            return Vector3::zeros();
        }
        let bu = bernstein(self.degree_u(), u);
        let bv = bernstein(n - 1, v);
        let d = self.combine(&bu, &bv, |i, j| self.control[i][j + 1] - self.control[i][j]);
        d * n as f64
    }

    /// The unit normal `(∂S/∂u × ∂S/∂v) / |∂S/∂u × ∂S/∂v|` at `(u, v)`.
    ///
    /// For the three test surfaces it points towards `+z` (see the module documentation).
    /// At a degenerate point, where the cross product vanishes, `+z` is returned.
    #[must_use]
    pub fn normal(&self, u: f64, v: f64) -> Vector3<f64> {
        self.du(u, v).cross(&self.dv(u, v)).try_normalize(1e-12).unwrap_or_else(Vector3::z)
    }

    /// `Σ_i Σ_j bu[i] · bv[j] · f(i, j)`.
    fn combine(&self, bu: &[f64], bv: &[f64], f: impl Fn(usize, usize) -> Vector3<f64>) -> Vector3<f64> {
        let mut sum = Vector3::zeros();
        for (i, &wu) in bu.iter().enumerate() {
            let mut row = Vector3::zeros();
            for (j, &wv) in bv.iter().enumerate() {
                row += f(i, j) * wv;
            }
            sum += row * wu;
        }
        sum
    }
}

/// The `degree + 1` Bernstein polynomials of the given degree at `t`, computed with the
/// (numerically stable) de Casteljau recurrence.
fn bernstein(degree: usize, t: f64) -> Vec<f64> {
    let s = 1.0 - t;
    let mut b = vec![0.0; degree + 1];
    b[0] = 1.0;
    for k in 1..=degree {
        let mut previous = 0.0;
        for value in b.iter_mut().take(k + 1) {
            let current = *value;
            *value = s * current + t * previous;
            previous = current;
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> impl Iterator<Item = (f64, f64)> {
        (0..=8).flat_map(|a| (0..=8).map(move |b| (f64::from(a) / 8.0, f64::from(b) / 8.0)))
    }

    fn surfaces() -> [(&'static str, BezierPatch); 3] {
        [
            ("hypar", BezierPatch::hyperbolic_paraboloid()),
            ("manta", BezierPatch::manta()),
            ("bicubic", BezierPatch::bicubic()),
        ]
    }

    #[test]
    fn bernstein_is_a_partition_of_unity() {
        for degree in 0..7 {
            for k in 0..=10 {
                let t = f64::from(k) / 10.0;
                let sum: f64 = bernstein(degree, t).iter().sum();
                assert!((sum - 1.0).abs() < 1e-14, "degree {degree}, t {t}");
            }
        }
        assert_eq!(bernstein(2, 0.5), vec![0.25, 0.5, 0.25]);
    }

    #[test]
    fn degrees() {
        let hypar = BezierPatch::hyperbolic_paraboloid();
        assert_eq!((hypar.degree_u(), hypar.degree_v()), (2, 2));
        let manta = BezierPatch::manta();
        assert_eq!((manta.degree_u(), manta.degree_v()), (3, 3));
        let bicubic = BezierPatch::bicubic();
        assert_eq!((bicubic.degree_u(), bicubic.degree_v()), (3, 3));
        let linear = BezierPatch::new(vec![vec![[0.0; 3]]; 2]);
        assert_eq!((linear.degree_u(), linear.degree_v()), (1, 0));
    }

    #[test]
    fn corners_interpolate_the_control_net() {
        for (name, s) in surfaces() {
            let (m, n) = (s.degree_u(), s.degree_v());
            for (u, v, i, j) in [(0.0, 0.0, 0, 0), (1.0, 0.0, m, 0), (0.0, 1.0, 0, n), (1.0, 1.0, m, n)] {
                let p = s.point(u, v);
                let c = s.control_point(i, j).expect("corner exists");
                assert!((p.coords - Vector3::from(c)).norm() < 1e-12, "{name} corner {i},{j}");
            }
        }
    }

    #[test]
    fn hyperbolic_paraboloid_equals_its_closed_form() {
        let s = BezierPatch::hyperbolic_paraboloid();
        // The control points give z(0, ±50) = +5 and z(±50, 0) = −5, hence (y² − x²)/500.
        assert!((s.point(0.5, 0.0).z - 5.0).abs() < 1e-12);
        assert!((s.point(0.0, 0.5).z + 5.0).abs() < 1e-12);
        for (u, v) in grid().chain([(0.13, 0.77), (0.91, 0.42), (0.333, 0.05)]) {
            let p = s.point(u, v);
            assert!((p.x - (100.0 * u - 50.0)).abs() < 1e-12);
            assert!((p.y - (100.0 * v - 50.0)).abs() < 1e-12);
            let z = (p.y * p.y - p.x * p.x) / 500.0;
            assert!((p.z - z).abs() < 1e-12, "at ({u}, {v}): {} vs {z}", p.z);
        }
    }

    #[test]
    fn hyperbolic_paraboloid_rulings_are_straight_lines() {
        let s = BezierPatch::hyperbolic_paraboloid();
        for c in [-0.6, -0.2, 0.0, 0.35] {
            // v − u = c, i.e. y = x + 100c.
            let (t0, t1) = (f64::max(0.0, -c), f64::min(1.0, 1.0 - c));
            let a = s.point(t0, t0 + c);
            let b = s.point(t1, t1 + c);
            for k in 1..10 {
                let t = t0 + (t1 - t0) * f64::from(k) / 10.0;
                let p = s.point(t, t + c);
                let on_chord = a + (b - a) * (f64::from(k) / 10.0);
                assert!((p - on_chord).norm() < 1e-10, "c {c}, t {t}");
            }
        }
    }

    #[test]
    fn bicubic_and_manta_are_graphs_over_their_squares() {
        let manta = BezierPatch::manta();
        let bicubic = BezierPatch::bicubic();
        for (u, v) in grid() {
            let p = manta.point(u, v);
            assert!((p.x - 600.0 * u).abs() < 1e-9 && (p.y - 600.0 * v).abs() < 1e-9);
            assert!((-1e-9..=100.0 + 1e-9).contains(&p.z));
            let q = bicubic.point(u, v);
            assert!((q.x - 36.0 * u).abs() < 1e-12 && (q.y - 36.0 * v).abs() < 1e-12);
            assert!((-16.0 - 1e-9..=1e-9).contains(&q.z));
        }
        assert_eq!(bicubic.control_point(0, 0), Some([0.0, 0.0, -16.0]));
        assert_eq!(bicubic.control_point(1, 3), Some([12.0, 36.0, -2.0]));
        assert_eq!(bicubic.control_point(3, 1), Some([36.0, 12.0, -2.0]));
    }

    #[test]
    fn normals_are_unit_and_point_up() {
        for (name, s) in surfaces() {
            for (u, v) in grid() {
                let n = s.normal(u, v);
                assert!((n.norm() - 1.0).abs() < 1e-12, "{name} ({u}, {v})");
                assert!(n.z > 0.0, "{name} normal at ({u}, {v}) points down: {n}");
                assert!(n.dot(&s.du(u, v)).abs() < 1e-9);
                assert!(n.dot(&s.dv(u, v)).abs() < 1e-9);
            }
        }
        // Closed form for the hyperbolic paraboloid: n ∝ (2x/500, −2y/500, 1).
        let s = BezierPatch::hyperbolic_paraboloid();
        let p = s.point(0.8, 0.3);
        let expected = Vector3::new(2.0 * p.x / 500.0, -2.0 * p.y / 500.0, 1.0).normalize();
        assert!((s.normal(0.8, 0.3) - expected).norm() < 1e-12);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let h = 1e-6;
        for (name, s) in surfaces() {
            for (u, v) in grid() {
                // Central differences, one-sided inside the domain at the borders.
                let (u0, u1) = (f64::max(u - h, 0.0), f64::min(u + h, 1.0));
                let (v0, v1) = (f64::max(v - h, 0.0), f64::min(v + h, 1.0));
                let fd_u = (s.point(u1, v) - s.point(u0, v)) / (u1 - u0);
                let fd_v = (s.point(u, v1) - s.point(u, v0)) / (v1 - v0);
                let scale = 1.0 + s.du(u, v).norm();
                assert!((s.du(u, v) - fd_u).norm() < 1e-3 * scale, "{name} du ({u}, {v})");
                let scale = 1.0 + s.dv(u, v).norm();
                assert!((s.dv(u, v) - fd_v).norm() < 1e-3 * scale, "{name} dv ({u}, {v})");
            }
        }
    }

    #[test]
    fn invalid_nets_are_rejected() {
        assert_eq!(BezierPatch::try_new(vec![]), Err(PatchError::Empty));
        assert_eq!(BezierPatch::try_new(vec![vec![]]), Err(PatchError::Empty));
        assert_eq!(
            BezierPatch::try_new(vec![vec![[0.0; 3]; 2], vec![[0.0; 3]]]),
            Err(PatchError::Ragged { row: 1, len: 1, expected: 2 })
        );
        assert_eq!(BezierPatch::try_new(vec![vec![[0.0, f64::NAN, 0.0]]]), Err(PatchError::NotFinite { i: 0, j: 0 }));
    }

    #[test]
    fn bounding_box_contains_the_surface() {
        for (name, s) in surfaces() {
            let (min, max) = s.bounding_box();
            for (u, v) in grid() {
                let p = s.point(u, v);
                for k in 0..3 {
                    assert!(min[k] - 1e-9 <= p[k] && p[k] <= max[k] + 1e-9, "{name}");
                }
            }
        }
    }
}
