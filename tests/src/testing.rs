//! Helpers of the library's own unit tests.

/// `a` and `b` within `tol`.
pub(crate) fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// Every coordinate of `a` and `b` within `tol`.
pub(crate) fn close3(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|k| close(a[k], b[k], tol))
}
