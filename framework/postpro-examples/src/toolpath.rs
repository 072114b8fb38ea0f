//! Five-axis ball-end finishing paths on a Bézier patch.
//!
//! A tool path is a sequence of **passes**. Each pass is a straight line in the parameter
//! square `[0, 1]²` of the patch (an iso-`v` curve for [`Pattern::AlongU`], a diagonal
//! `v − u = c` for [`Pattern::Diagonal`]), sampled at (almost) equal 3-D arc length on the
//! surface. For every sample the generator computes
//!
//! * the surface point `S` and the unit normal `n` (pointing to `+z`, away from the
//!   material, see [`crate::surface`]);
//! * the unit feed direction `f`: the tangent of the pass in the direction of travel,
//!   made orthogonal to `n`;
//! * the unit **tool axis** `a` (from the tip towards the spindle): `n` rotated by the
//!   lead angle `θ` about `n × f`, i.e. `a = n cos θ + f sin θ`. A **positive lead angle
//!   leans the spindle end of the tool forward, towards the feed direction**: the tip
//!   trails and the ball cuts with its front, off its dead centre. Because `n` and `f`
//!   change along a pass, so does `a`: the paths are genuinely 5-axis;
//! * the CL point, which is the **tool tip** of the ball-end mill of radius `r`:
//!   `tip = S + r·n − r·a` (the ball centre `S + r·n` lies on the surface normal, at
//!   distance `r` from the contact point).
//!
//! [`Toolpath::moves`] turns the passes into the motion sequence a CL file contains: for
//! every pass a rapid to the clearance point above the start (`clearance` along the start
//! axis), a plunge at the plunge feed to the start point, the cut at the cutting feed, and
//! a rapid retract of `clearance` along the last tool axis.

use std::fmt;

use nalgebra::{Point3, Vector2, Vector3};

use crate::surface::BezierPatch;

/// How the passes are laid out on the patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    /// Passes along `u` (iso-`v` curves); along `x` for the bundled surfaces.
    AlongU,
    /// Passes along the parameter diagonals `v − u = c`, from small to large `u`. For a
    /// patch with `x` affine in `u` and `y` affine in `v` over a square (the hyperbolic
    /// paraboloid) these are the lines `y = x + c'` at 45° to `x` and `y`.
    Diagonal,
}

/// Distance between neighbouring passes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepOver {
    /// Maximum distance in mm between neighbouring passes, measured in the `xy` plane
    /// perpendicular to the passes. The `xy` extent of the patch is taken from the
    /// bounding box of its control net, assuming the parametrisation is affine in `xy`
    /// (exact for the bundled surfaces). The passes are spread evenly, so the real
    /// step-over may be slightly smaller.
    Distance(f64),
    /// Exactly this many passes, spread evenly over the patch.
    Passes(usize),
}

/// Parameters of a finishing tool path with a ball-end mill.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolpathParams {
    /// Ball radius `r` in mm (the tool diameter is `2r`).
    pub tool_radius: f64,
    /// Tool length in mm (only written to the tool description records).
    pub tool_length: f64,
    /// Lead angle in degrees: tilt of the tool axis from the surface normal towards the
    /// feed direction (negative values lean it backwards).
    pub lead_angle_deg: f64,
    /// How passes are laid out.
    pub pattern: Pattern,
    /// Distance between passes, or their number.
    pub step_over: StepOver,
    /// `true`: every other pass runs backwards (zig-zag); `false`: all passes run in the
    /// same direction (one-way), with a rapid back between passes.
    pub zigzag: bool,
    /// Maximum 3-D distance in mm between neighbouring contact points along a pass.
    pub point_spacing: f64,
    /// Passes whose `xy` length is shorter than this (in mm) are left out (they only
    /// occur in the corners of [`Pattern::Diagonal`] layouts).
    pub min_pass_length: f64,
    /// Retract and approach distance in mm along the tool axis.
    pub clearance: f64,
    /// Cutting feed in mm/min.
    pub feed: f64,
    /// Plunge (approach) feed in mm/min.
    pub plunge_feed: f64,
    /// Spindle speed in rev/min (clockwise).
    pub spindle_rpm: u32,
}

impl ToolpathParams {
    /// Defaults for the hyperbolic paraboloid: one-way passes along the 45° rulings,
    /// step-over 5 mm, a point every 1 mm, ball D10 (r = 5), lead 10°, feed 2000 mm/min.
    #[must_use]
    pub fn hyperbolic_paraboloid() -> Self {
        Self {
            tool_radius: 5.0,
            tool_length: 75.0,
            lead_angle_deg: 10.0,
            pattern: Pattern::Diagonal,
            step_over: StepOver::Distance(5.0),
            zigzag: false,
            point_spacing: 1.0,
            min_pass_length: 10.0,
            clearance: 20.0,
            feed: 2000.0,
            plunge_feed: 500.0,
            spindle_rpm: 12000,
        }
    }

    /// Defaults for the Manta: zig-zag along `x`, step-over 20 mm, a point every 4 mm,
    /// ball D20 (r = 10), lead 10°, feed 5000 mm/min.
    #[must_use]
    pub fn manta() -> Self {
        Self {
            tool_radius: 10.0,
            tool_length: 100.0,
            lead_angle_deg: 10.0,
            pattern: Pattern::AlongU,
            step_over: StepOver::Distance(20.0),
            zigzag: true,
            point_spacing: 4.0,
            min_pass_length: 0.0,
            clearance: 25.0,
            feed: 5000.0,
            plunge_feed: 1500.0,
            spindle_rpm: 8000,
        }
    }

    /// Defaults for the bicubic surface of paper 002: 20 zig-zag passes along `x` (the
    /// 20 × 20 raster of its Fig. 4), a point every 0.5 mm, ball D6 (r = 3), lead 10°,
    /// feed 1000 mm/min.
    #[must_use]
    pub fn bicubic() -> Self {
        Self {
            tool_radius: 3.0,
            tool_length: 50.0,
            lead_angle_deg: 10.0,
            pattern: Pattern::AlongU,
            step_over: StepOver::Passes(20),
            zigzag: true,
            point_spacing: 0.5,
            min_pass_length: 0.0,
            clearance: 10.0,
            feed: 1000.0,
            plunge_feed: 300.0,
            spindle_rpm: 15000,
        }
    }

    /// Tool diameter `2r` in mm.
    #[must_use]
    pub fn tool_diameter(&self) -> f64 {
        2.0 * self.tool_radius
    }

    /// Checks that every value is usable.
    ///
    /// # Errors
    ///
    /// [`ToolpathError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<(), ToolpathError> {
        let positive = |name: &'static str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(ToolpathError::InvalidParameter {
                    name,
                    reason: format!("must be a finite number > 0, got {value}"),
                })
            }
        };
        let non_negative = |name: &'static str, value: f64| {
            if value.is_finite() && value >= 0.0 {
                Ok(())
            } else {
                Err(ToolpathError::InvalidParameter {
                    name,
                    reason: format!("must be a finite number >= 0, got {value}"),
                })
            }
        };
        positive("tool_radius", self.tool_radius)?;
        non_negative("tool_length", self.tool_length)?;
        if !(self.lead_angle_deg.is_finite() && self.lead_angle_deg.abs() < 90.0) {
            return Err(ToolpathError::InvalidParameter {
                name: "lead_angle_deg",
                reason: format!("must lie strictly between -90 and 90, got {}", self.lead_angle_deg),
            });
        }
        match self.step_over {
            StepOver::Distance(d) => positive("step_over", d)?,
            StepOver::Passes(0) => {
                return Err(ToolpathError::InvalidParameter {
                    name: "step_over",
                    reason: "needs at least one pass".to_owned(),
                });
            }
            StepOver::Passes(_) => {}
        }
        positive("point_spacing", self.point_spacing)?;
        non_negative("min_pass_length", self.min_pass_length)?;
        non_negative("clearance", self.clearance)?;
        positive("feed", self.feed)?;
        positive("plunge_feed", self.plunge_feed)?;
        if self.spindle_rpm == 0 {
            return Err(ToolpathError::InvalidParameter { name: "spindle_rpm", reason: "must be > 0".to_owned() });
        }
        Ok(())
    }
}

/// Why no tool path could be generated.
#[derive(Debug, Clone, PartialEq)]
pub enum ToolpathError {
    /// A parameter is out of range.
    InvalidParameter {
        /// Field of [`ToolpathParams`].
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The layout left no pass (e.g. every diagonal was shorter than `min_pass_length`).
    NoPasses,
}

impl fmt::Display for ToolpathError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidParameter { name, reason } => {
                write!(f, "invalid tool path parameter `{name}`: {reason}")
            }
            Self::NoPasses => write!(f, "the pass layout leaves no pass on the patch"),
        }
    }
}

impl std::error::Error for ToolpathError {}

/// One sample of a cutting pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutPoint {
    /// Surface parameters `(u, v)` of the contact point, in `[0, 1]²`.
    pub uv: (f64, f64),
    /// Contact point `S` on the surface.
    pub surface: Point3<f64>,
    /// Unit surface normal `n` at `S`.
    pub normal: Vector3<f64>,
    /// Unit feed direction `f` (tangent to the surface, orthogonal to `n`).
    pub feed_dir: Vector3<f64>,
    /// Unit tool axis `a` (tip → spindle): `n cos θ + f sin θ`.
    pub axis: Vector3<f64>,
    /// The CL point: tool tip `S + r·n − r·a`.
    pub tip: Point3<f64>,
}

impl CutPoint {
    /// Centre of the ball: `tip + r·a` (equal to `S + r·n`).
    #[must_use]
    pub fn ball_centre(&self, tool_radius: f64) -> Point3<f64> {
        self.tip + self.axis * tool_radius
    }
}

/// One cutting pass: its samples in the order of travel.
#[derive(Debug, Clone, PartialEq)]
pub struct Pass {
    /// The samples, at least two.
    pub points: Vec<CutPoint>,
}

/// What a move is for; decides rapid or feed and the feed rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveKind {
    /// Rapid to the clearance point above the start of a pass.
    Rapid,
    /// Plunge at the plunge feed from the clearance point to the start of a pass.
    Plunge,
    /// Cutting move at the cutting feed.
    Cut,
    /// Rapid retract along the tool axis at the end of a pass.
    Retract,
}

/// One move of the CL file: go to `tip` with tool axis `axis`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// Purpose of the move.
    pub kind: MoveKind,
    /// Target tool tip position.
    pub tip: Point3<f64>,
    /// Target unit tool axis (tip → spindle).
    pub axis: Vector3<f64>,
    /// Feed rate in mm/min, `None` for a rapid move.
    pub feed: Option<f64>,
}

/// A generated finishing tool path.
#[derive(Debug, Clone, PartialEq)]
pub struct Toolpath {
    /// The parameters it was generated with.
    pub params: ToolpathParams,
    /// The cutting passes in machining order.
    pub passes: Vec<Pass>,
}

impl Toolpath {
    /// Total number of cutting samples over all passes.
    #[must_use]
    pub fn cut_point_count(&self) -> usize {
        self.passes.iter().map(|p| p.points.len()).sum()
    }

    /// The motion sequence (see the module documentation): per pass a rapid to the
    /// clearance point, a plunge, the cut and a rapid retract.
    #[must_use]
    pub fn moves(&self) -> Vec<Move> {
        let p = &self.params;
        let mut moves = Vec::with_capacity(self.cut_point_count() + 2 * self.passes.len());
        for pass in &self.passes {
            let (Some(first), Some(last)) = (pass.points.first(), pass.points.last()) else {
                continue;
            };
            moves.push(Move {
                kind: MoveKind::Rapid,
                tip: first.tip + first.axis * p.clearance,
                axis: first.axis,
                feed: None,
            });
            moves.push(Move { kind: MoveKind::Plunge, tip: first.tip, axis: first.axis, feed: Some(p.plunge_feed) });
            moves.extend(pass.points.iter().skip(1).map(|c| Move {
                kind: MoveKind::Cut,
                tip: c.tip,
                axis: c.axis,
                feed: Some(p.feed),
            }));
            moves.push(Move {
                kind: MoveKind::Retract,
                tip: last.tip + last.axis * p.clearance,
                axis: last.axis,
                feed: None,
            });
        }
        moves
    }
}

/// Number of chords used to measure the arc length of a pass.
const ARC_SAMPLES: usize = 2048;

/// Generates the finishing tool path of `params` on `surface`.
///
/// # Errors
///
/// [`ToolpathError`] if a parameter is invalid or no pass is left.
pub fn generate(surface: &BezierPatch, params: &ToolpathParams) -> Result<Toolpath, ToolpathError> {
    params.validate()?;
    let lines = pass_lines(surface, params);
    if lines.is_empty() {
        return Err(ToolpathError::NoPasses);
    }
    let passes = lines.into_iter().map(|(a, b)| Pass { points: sample_pass(surface, params, a, b) }).collect();
    Ok(Toolpath { params: params.clone(), passes })
}

/// The passes as segments `(start, end)` in parameter space, in machining order and
/// travel direction.
fn pass_lines(surface: &BezierPatch, params: &ToolpathParams) -> Vec<(Vector2<f64>, Vector2<f64>)> {
    let (min, max) = surface.bounding_box();
    let (sx, sy) = (max.x - min.x, max.y - min.y);
    let mut lines = Vec::new();
    match params.pattern {
        Pattern::AlongU => {
            let count = match params.step_over {
                StepOver::Distance(d) => (sy / d - 1e-9).ceil().max(0.0) as usize + 1,
                StepOver::Passes(n) => n,
            };
            for k in 0..count {
                let v = if count == 1 { 0.5 } else { k as f64 / (count - 1) as f64 };
                lines.push((Vector2::new(0.0, v), Vector2::new(1.0, v)));
            }
        }
        Pattern::Diagonal => {
            // Lines v − u = c; in xy (affine assumption) (y − y0)/sy − (x − x0)/sx = c, whose
            // perpendicular distance for a change dc is dc / |(1/sx, 1/sy)|.
            let offsets: Vec<f64> = match params.step_over {
                StepOver::Distance(d) => {
                    let norm = (sx.powi(-2) + sy.powi(-2)).sqrt();
                    let dc = if norm.is_finite() { d * norm } else { 2.0 };
                    let k_max = ((1.0 - 1e-9) / dc).floor() as i64;
                    (-k_max..=k_max).map(|k| k as f64 * dc).collect()
                }
                StepOver::Passes(n) => (0..n).map(|k| -1.0 + 2.0 * (k + 1) as f64 / (n + 1) as f64).collect(),
            };
            let diagonal = (sx * sx + sy * sy).sqrt();
            for c in offsets {
                let length = (1.0 - c.abs()) * diagonal;
                if length < params.min_pass_length || length <= 0.0 {
                    continue;
                }
                let u0 = f64::max(0.0, -c);
                let u1 = f64::min(1.0, 1.0 - c);
                lines.push((Vector2::new(u0, u0 + c), Vector2::new(u1, u1 + c)));
            }
        }
    }
    if params.zigzag {
        for (k, line) in lines.iter_mut().enumerate() {
            if k % 2 == 1 {
                *line = (line.1, line.0);
            }
        }
    }
    lines
}

/// Samples the pass from `a` to `b` (parameter space) at equal 3-D arc length.
fn sample_pass(surface: &BezierPatch, params: &ToolpathParams, a: Vector2<f64>, b: Vector2<f64>) -> Vec<CutPoint> {
    let at = |t: f64| {
        let uv = a + (b - a) * t;
        (uv.x.clamp(0.0, 1.0), uv.y.clamp(0.0, 1.0))
    };
    // Cumulative chord length table.
    let mut cumulative = Vec::with_capacity(ARC_SAMPLES + 1);
    cumulative.push(0.0);
    let mut previous = {
        let (u, v) = at(0.0);
        surface.point(u, v)
    };
    for k in 1..=ARC_SAMPLES {
        let (u, v) = at(k as f64 / ARC_SAMPLES as f64);
        let p = surface.point(u, v);
        let last = cumulative.last().copied().unwrap_or(0.0);
        cumulative.push(last + (p - previous).norm());
        previous = p;
    }
    let total = cumulative.last().copied().unwrap_or(0.0);
    let segments = ((total / params.point_spacing) - 1e-9).ceil().max(1.0) as usize;

    let theta = params.lead_angle_deg.to_radians();
    let (sin, cos) = theta.sin_cos();
    let r = params.tool_radius;
    let direction = b - a;
    let mut points = Vec::with_capacity(segments + 1);
    let mut chord = 0;
    for k in 0..=segments {
        let s = total * k as f64 / segments as f64;
        while chord + 1 < ARC_SAMPLES && cumulative[chord + 1] < s {
            chord += 1;
        }
        let (l0, l1) = (cumulative[chord], cumulative[chord + 1]);
        let frac = if l1 > l0 { ((s - l0) / (l1 - l0)).clamp(0.0, 1.0) } else { 0.0 };
        let t = if k == segments { 1.0 } else { (chord as f64 + frac) / ARC_SAMPLES as f64 };
        let (u, v) = at(t);
        let surface_point = surface.point(u, v);
        let normal = surface.normal(u, v);
        let tangent = surface.du(u, v) * direction.x + surface.dv(u, v) * direction.y;
        let tangent = tangent - normal * normal.dot(&tangent);
        let feed_dir = tangent.try_normalize(1e-12).unwrap_or_else(|| normal.cross(&Vector3::y()).normalize());
        let axis = (normal * cos + feed_dir * sin).normalize();
        let tip = surface_point + normal * r - axis * r;
        points.push(CutPoint { uv: (u, v), surface: surface_point, normal, feed_dir, axis, tip });
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all() -> [(&'static str, BezierPatch, ToolpathParams); 3] {
        [
            ("hypar", BezierPatch::hyperbolic_paraboloid(), ToolpathParams::hyperbolic_paraboloid()),
            ("manta", BezierPatch::manta(), ToolpathParams::manta()),
            ("bicubic", BezierPatch::bicubic(), ToolpathParams::bicubic()),
        ]
    }

    #[test]
    fn default_parameters_are_valid() {
        for (name, surface, params) in all() {
            params.validate().expect(name);
            let path = generate(&surface, &params).expect(name);
            assert!(path.passes.iter().all(|p| p.points.len() >= 2), "{name}");
        }
    }

    #[test]
    fn pass_counts() {
        let count = |s: &BezierPatch, p: &ToolpathParams| generate(s, p).expect("valid").passes.len();
        let (_, manta, manta_params) = &all()[1];
        assert_eq!(count(manta, manta_params), 31); // y = 0, 20, ..., 600
        let (_, bicubic, bicubic_params) = &all()[2];
        assert_eq!(count(bicubic, bicubic_params), 20);
        let (_, hypar, hypar_params) = &all()[0];
        assert_eq!(count(hypar, hypar_params), 27); // |c| <= 13 * 5√2 mm
    }

    #[test]
    fn axes_are_unit_and_tilted_by_the_lead_angle() {
        for (name, surface, params) in all() {
            let path = generate(&surface, &params).expect(name);
            let cos = params.lead_angle_deg.to_radians().cos();
            for c in path.passes.iter().flat_map(|p| &p.points) {
                assert!((c.axis.norm() - 1.0).abs() < 1e-12, "{name}");
                assert!((c.normal.norm() - 1.0).abs() < 1e-12, "{name}");
                assert!((c.feed_dir.norm() - 1.0).abs() < 1e-12, "{name}");
                assert!(c.feed_dir.dot(&c.normal).abs() < 1e-12, "{name}");
                assert!((c.axis.dot(&c.normal) - cos).abs() < 1e-12, "{name}");
                // Positive lead: the spindle end leans towards the feed direction.
                assert!(c.axis.dot(&c.feed_dir) > 0.0, "{name}");
                assert!(c.axis.z > 0.0, "{name}");
            }
            for m in path.moves() {
                assert!((m.axis.norm() - 1.0).abs() < 1e-12, "{name}");
            }
        }
    }

    #[test]
    fn axis_varies_along_every_pass() {
        for (name, surface, params) in all() {
            let path = generate(&surface, &params).expect(name);
            for (k, pass) in path.passes.iter().enumerate() {
                let first = pass.points[0].axis;
                let max_angle = pass.points.iter().map(|c| c.axis.angle(&first).to_degrees()).fold(0.0, f64::max);
                assert!(max_angle > 1.0, "{name} pass {k}: axis varies only {max_angle}°");
            }
        }
    }

    #[test]
    fn tip_formula_puts_the_ball_centre_on_the_normal_at_distance_r() {
        for (name, surface, params) in all() {
            let path = generate(&surface, &params).expect(name);
            let r = params.tool_radius;
            for c in path.passes.iter().flat_map(|p| &p.points) {
                let centre = c.ball_centre(r);
                let offset = centre - c.surface;
                assert!((offset.norm() - r).abs() < 1e-9, "{name}");
                assert!((offset - c.normal * r).norm() < 1e-9, "{name}");
                // The ball touches the surface tangentially at S.
                let (u, v) = c.uv;
                assert!(offset.dot(&surface.du(u, v)).abs() < 1e-6, "{name}");
                assert!(offset.dot(&surface.dv(u, v)).abs() < 1e-6, "{name}");
                // And the surface point really is S(u, v).
                assert!((surface.point(u, v) - c.surface).norm() < 1e-12, "{name}");
            }
        }
    }

    #[test]
    fn points_stay_within_the_patch() {
        for (name, surface, params) in all() {
            let path = generate(&surface, &params).expect(name);
            let (min, max) = surface.bounding_box();
            let r = params.tool_radius;
            // |tip − S| = r |n − a| = 2r sin(θ/2).
            let slack = 2.0 * r * (params.lead_angle_deg.to_radians() / 2.0).sin() + 1e-9;
            for c in path.passes.iter().flat_map(|p| &p.points) {
                let (u, v) = c.uv;
                assert!((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v), "{name}");
                for k in 0..3 {
                    assert!(min[k] - 1e-9 <= c.surface[k] && c.surface[k] <= max[k] + 1e-9);
                    assert!(min[k] - slack <= c.tip[k] && c.tip[k] <= max[k] + slack, "{name}");
                }
            }
        }
    }

    #[test]
    fn point_spacing_is_respected() {
        for (name, surface, params) in all() {
            let path = generate(&surface, &params).expect(name);
            for pass in &path.passes {
                let gaps: Vec<f64> = pass.points.windows(2).map(|w| (w[1].surface - w[0].surface).norm()).collect();
                let max = gaps.iter().copied().fold(0.0, f64::max);
                let min = gaps.iter().copied().fold(f64::INFINITY, f64::min);
                assert!(max <= params.point_spacing * 1.001, "{name}: {max}");
                assert!(min >= 0.9 * max, "{name}: uneven spacing {min}..{max}");
            }
        }
    }

    #[test]
    fn hypar_passes_follow_the_45_degree_rulings() {
        let surface = BezierPatch::hyperbolic_paraboloid();
        let path = generate(&surface, &ToolpathParams::hyperbolic_paraboloid()).expect("valid");
        let mut offsets = Vec::new();
        for pass in &path.passes {
            let first = pass.points[0].surface;
            let last = pass.points[pass.points.len() - 1].surface;
            let c = first.y - first.x;
            offsets.push(c);
            for p in &pass.points {
                // On the line y = x + c, which is straight on the surface.
                assert!((p.surface.y - p.surface.x - c).abs() < 1e-9);
                let t = (p.surface.x - first.x) / (last.x - first.x);
                let on_chord = first + (last - first) * t;
                assert!((p.surface - on_chord).norm() < 1e-9);
                assert!(p.feed_dir.x > 0.0 && p.feed_dir.y > 0.0);
            }
        }
        for w in offsets.windows(2) {
            // 5 mm apart perpendicular to the passes.
            assert!(((w[1] - w[0]) / 2f64.sqrt() - 5.0).abs() < 1e-9);
        }
    }

    #[test]
    fn zigzag_alternates_and_one_way_does_not() {
        let manta = generate(&BezierPatch::manta(), &ToolpathParams::manta()).expect("valid");
        for (k, pass) in manta.passes.iter().enumerate() {
            let dx = pass.points[pass.points.len() - 1].surface.x - pass.points[0].surface.x;
            assert_eq!(dx > 0.0, k % 2 == 0, "pass {k}");
            assert!((pass.points[0].surface.y - 20.0 * k as f64).abs() < 1e-9);
        }
    }

    #[test]
    fn moves_have_the_expected_shape() {
        let params = ToolpathParams::bicubic();
        let path = generate(&BezierPatch::bicubic(), &params).expect("valid");
        let moves = path.moves();
        assert_eq!(moves.len(), path.cut_point_count() + 2 * path.passes.len());
        let first = &path.passes[0].points[0];
        assert_eq!(moves[0].kind, MoveKind::Rapid);
        assert_eq!(moves[0].feed, None);
        assert!((moves[0].tip - (first.tip + first.axis * params.clearance)).norm() < 1e-12);
        assert_eq!(moves[1].kind, MoveKind::Plunge);
        assert_eq!(moves[1].feed, Some(params.plunge_feed));
        assert_eq!(moves[1].tip, first.tip);
        assert_eq!(moves[2].kind, MoveKind::Cut);
        assert_eq!(moves[2].feed, Some(params.feed));
        let last = moves.last().expect("moves");
        assert_eq!(last.kind, MoveKind::Retract);
        assert_eq!(last.feed, None);
    }

    #[test]
    fn invalid_parameters_are_reported() {
        let surface = BezierPatch::bicubic();
        let mut p = ToolpathParams::bicubic();
        p.point_spacing = 0.0;
        assert!(matches!(generate(&surface, &p), Err(ToolpathError::InvalidParameter { name: "point_spacing", .. })));
        let mut p = ToolpathParams::bicubic();
        p.lead_angle_deg = 90.0;
        assert!(p.validate().is_err());
        let mut p = ToolpathParams::hyperbolic_paraboloid();
        p.min_pass_length = 1000.0;
        assert_eq!(generate(&BezierPatch::hyperbolic_paraboloid(), &p), Err(ToolpathError::NoPasses));
    }
}
