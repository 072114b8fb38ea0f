//! The one conversion from the file format ([`crate::raw::MachineFile`]) to the model
//! ([`crate::model::Machine`]), with every semantic check.
//!
//! Each check that fails becomes a [`MachineError`] pointing at the offending value. These checks
//! run after deserialization, when the YAML library no longer tells where a value was: the error
//! is located by walking the text down the value's path (`axes`, `3`, `vmax`) with the YAML
//! library itself (see `locate.rs`); a value that was left out (a default) points at the mapping
//! that lacks it. The first problem found is reported; the checks run in the file's order
//! (name, dialect, axes one by one, chain, cnc, policy, solver).

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::error::{Doc, MachineError};
use crate::locate::{Seg, path_text};
use crate::model::{
    Axis, AxisKind, BranchPreference, Chain, Clearance, ClosedForm, CncParams, Machine, OnDiscontinuity, PathChoice,
    PolicyDefaults, SolverKind, Travel, spindle_linear_axis,
};
use crate::quantity::{AxisQuantity, Dimension};
use crate::raw;

/// The controller dialects the NC output knows.
pub const DIALECTS: &[&str] = &["siemens-840d", "fanuc", "haas", "heidenhain", "linuxcnc"];

/// The machines with a hand-derived closed-form solver, by name.
pub const CLOSED_FORMS: &[(&str, ClosedForm)] =
    &[("mikron-ucp710", ClosedForm::MikronUcp710), ("maho600e", ClosedForm::Maho600e)];

/// The closed form of the machine with this name (case-insensitive), if there is one.
pub fn closed_form_for(name: &str) -> Option<ClosedForm> {
    CLOSED_FORMS.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)).map(|&(_, c)| c)
}

/// The most axes a machine may have on its rotary side (3-, 4- and 5-axis machines).
pub const MAX_ROTARY_AXES: usize = 2;

/// Largest number of NC decimals.
pub const MAX_DECIMALS: u8 = 9;

/// Below this norm a direction vector counts as zero.
const ZERO: f64 = 1e-9;

/// Tolerance on unit vectors for "parallel", "perpendicular" and "independent".
const ANGLE_TOL: f64 = 1e-6;

/// Validates a deserialized definition into the model. `file` is the name shown in errors and
/// `text` the definition's text (to point at the offending value).
pub fn validate(raw: &raw::MachineFile, file: &str, text: &str) -> Result<Machine, MachineError> {
    let doc = Doc::new(file, text);
    Validator { doc: &doc, raw }.run()
}

struct Validator<'a> {
    doc: &'a Doc,
    raw: &'a raw::MachineFile,
}

/// A direction written as three numbers: non-zero and finite, normalised.
fn unit(v: &[f64; 3]) -> Option<Unit<Vector3<f64>>> {
    let v = Vector3::from(*v);
    if v.iter().all(|c| c.is_finite()) && v.norm() > ZERO { Some(Unit::new_normalize(v)) } else { None }
}

fn point(p: &[crate::quantity::Length; 3]) -> Point3<f64> {
    Point3::new(p[0].0, p[1].0, p[2].0)
}

/// A value in the unit users read: mm or deg.
fn show(v: f64, linear: bool) -> String {
    if linear { format!("{} mm", round(v)) } else { format!("{} deg", round(v.to_degrees())) }
}

fn round(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

/// `` `X`, `Y` and `Z` ``
fn list(items: &[&str]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("`{s}`")).collect();
    match quoted.as_slice() {
        [] => "none".to_string(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

/// True for a plain name: letters, digits, `-`, `_`, `.`, not empty.
fn plain_name(s: &str) -> bool {
    !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
}

impl Validator<'_> {
    /// An error at the value at `path`; the message starts with the path (`axes[3].vmax: …`),
    /// like the YAML library's.
    fn err(&self, path: &[Seg<'_>], message: String, expected: impl Into<String>) -> MachineError {
        self.doc.error(path, format!("{}: {message}", path_text(path)), expected.into())
    }

    /// [`Validator::err`] with a help text.
    fn err_help(&self, path: &[Seg<'_>], message: String, expected: impl Into<String>, help: String) -> MachineError {
        self.doc.error_help(path, format!("{}: {message}", path_text(path)), expected.into(), help)
    }

    fn run(&self) -> Result<Machine, MachineError> {
        let raw = self.raw;
        self.names()?;
        if !DIALECTS.contains(&raw.dialect.as_str()) {
            return Err(self.err(
                path!["dialect"],
                format!("unknown dialect `{}`", raw.dialect),
                format!("expected one of {}", list(DIALECTS)),
            ));
        }
        let axes = self.axes()?;
        let chain = self.chain(&axes)?;
        let cnc = self.cnc(&axes, &chain)?;
        let policy = self.policy(&axes)?;
        let solver = self.solver(&axes, &chain)?;
        let clearance = self.clearance(&axes, &chain)?;
        Ok(Machine {
            name: raw.name.clone(),
            aliases: raw.aliases.clone(),
            description: raw.description.clone(),
            dialect: raw.dialect.clone(),
            axes,
            chain,
            cnc,
            policy,
            solver,
            clearance,
            units: raw.units.into(),
        })
    }

    fn names(&self) -> Result<(), MachineError> {
        let raw = self.raw;
        let expected = "expected a name of letters, digits, `-`, `_` or `.` (no spaces)";
        if !plain_name(&raw.name) {
            return Err(self.err(path!["name"], format!("invalid machine name `{}`", raw.name), expected));
        }
        for (i, alias) in raw.aliases.iter().enumerate() {
            if !plain_name(alias) {
                return Err(self.err(path!["aliases", i], format!("invalid alias `{alias}`"), expected));
            }
            let earlier = std::iter::once(&raw.name).chain(&raw.aliases[..i]);
            if let Some(same) = earlier.into_iter().find(|n| n.eq_ignore_ascii_case(alias)) {
                return Err(self.err(
                    path!["aliases", i],
                    format!("alias `{alias}` repeats `{same}`"),
                    "expected a name or alias used once (names and aliases ignore case)",
                ));
            }
        }
        Ok(())
    }

    fn axes(&self) -> Result<Vec<Axis>, MachineError> {
        let mut axes: Vec<Axis> = Vec::with_capacity(self.raw.axes.len());
        let mut rotaries = 0;
        for (i, a) in self.raw.axes.iter().enumerate() {
            let letter_ok = a.letter.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && a.letter.chars().all(|c| c.is_ascii_alphanumeric());
            if !letter_ok {
                return Err(self.err(
                    path!["axes", i, "letter"],
                    format!("invalid axis letter `{}`", a.letter),
                    "expected an NC address such as `X`, `A` or `X2` (a letter, then letters or digits)",
                ));
            }
            if let Some(j) = axes.iter().position(|b| b.letter.eq_ignore_ascii_case(&a.letter)) {
                return Err(self.err(
                    path!["axes", i, "letter"],
                    format!("axis letter `{}` is used twice (axes[{j}] and axes[{i}])", a.letter),
                    "expected a letter that no other axis has",
                ));
            }
            let linear = a.kind == raw::AxisKind::Linear;
            if !linear {
                rotaries += 1;
                if rotaries > MAX_ROTARY_AXES {
                    return Err(self.err_help(
                        path!["axes", i, "kind"],
                        format!("axis `{}` is a third rotary axis", a.letter),
                        format!("expected at most {MAX_ROTARY_AXES} rotary axes"),
                        "postpro handles 3-, 4- and 5-axis machines: 1 to 3 linear axes and at most 2 rotary ones"
                            .into(),
                    ));
                }
            }
            let Some(direction) = unit(&a.direction) else {
                return Err(self.err(
                    path!["axes", i, "direction"],
                    format!("axis `{}` has a zero direction", a.letter),
                    "expected a non-zero vector `[x, y, z]` (it is normalised)",
                ));
            };
            let center = match (&a.center, linear) {
                (Some(c), false) => point(c),
                (None, true) => Point3::origin(),
                (Some(_), true) => {
                    return Err(self.err(
                        path!["axes", i, "center"],
                        format!("linear axis `{}` has a `center`", a.letter),
                        "expected `center` on rotary axes only",
                    ));
                }
                (None, false) => {
                    return Err(self.err(
                        path!["axes", i, "center"],
                        format!("rotary axis `{}` has no `center`", a.letter),
                        "expected `center: [x, y, z]`, a point on the axis line with every axis at zero",
                    ));
                }
            };
            let travel = self.travel(i, a, linear)?;
            let home = match &a.home {
                Some(h) => self.quantity(path!["axes", i, "home"], h, linear)?,
                None => 0.0,
            };
            if !travel.contains(home) {
                let (min, max) = match travel {
                    Travel::Limited { min, max } => (min, max),
                    Travel::Endless => (0.0, 0.0),
                };
                return Err(self.err(
                    path!["axes", i, "home"],
                    format!("home {} of axis `{}` is outside its travel", show(home, linear), a.letter),
                    format!(
                        "expected a home position from {} to {} (`home` defaults to 0)",
                        show(min, linear),
                        show(max, linear)
                    ),
                ));
            }
            let vmax = self.positive(path!["axes", i, "vmax"], &a.vmax, linear, "vmax")?;
            let amax = self.positive(path!["axes", i, "amax"], &a.amax, linear, "amax")?;
            let jmax = self.positive(path!["axes", i, "jmax"], &a.jmax, linear, "jmax")?;
            if a.decimals > MAX_DECIMALS {
                return Err(self.err(
                    path!["axes", i, "decimals"],
                    format!("{} decimals for axis `{}`", a.decimals, a.letter),
                    format!("expected 0 to {MAX_DECIMALS} decimals"),
                ));
            }
            let clamp = match &a.clamp {
                None => None,
                Some(_) if linear => {
                    return Err(self.err(
                        path!["axes", i, "clamp"],
                        format!("linear axis `{}` has a `clamp`", a.letter),
                        "expected `clamp` on rotary axes only",
                    ));
                }
                Some(c) => {
                    for (field, code) in [("lock", &c.lock), ("unlock", &c.unlock)] {
                        if !is_m_code(code) {
                            return Err(self.err(
                                path!["axes", i, "clamp", field],
                                format!("`{code}` is not an M code"),
                                "expected an M code such as `M10`",
                            ));
                        }
                    }
                    Some(crate::model::Clamp {
                        lock: c.lock.to_ascii_uppercase(),
                        unlock: c.unlock.to_ascii_uppercase(),
                    })
                }
            };
            axes.push(Axis {
                letter: a.letter.clone(),
                kind: if linear { AxisKind::Linear } else { AxisKind::Rotary },
                direction,
                center,
                travel,
                home,
                vmax,
                amax,
                jmax,
                decimals: a.decimals,
                clamp,
            });
        }
        Ok(axes)
    }

    /// An axis value in model units, checked against the axis kind.
    fn quantity<const P: u8>(&self, path: &[Seg<'_>], q: &AxisQuantity<P>, linear: bool) -> Result<f64, MachineError> {
        q.to_model(linear).map_err(|message| {
            let (what, expected) = match message.find(", expected ") {
                Some(k) => (message[..k].to_string(), message[k + 2..].to_string()),
                None => (message.clone(), String::new()),
            };
            let kind = if linear { "linear" } else { "rotary" };
            self.err(path, format!("{what} on a {kind} axis"), expected)
        })
    }

    /// A dynamic limit: converted and positive.
    fn positive<const P: u8>(
        &self,
        path: &[Seg<'_>],
        q: &AxisQuantity<P>,
        linear: bool,
        key: &str,
    ) -> Result<f64, MachineError> {
        let v = self.quantity(path, q, linear)?;
        if v > 0.0 {
            Ok(v)
        } else {
            let dimension = AxisQuantity::<P>::dimension(linear);
            Err(self.err(
                path,
                format!("`{key}` must be positive, not `{}`", q.text.trim()),
                format!("expected {} greater than zero", dimension.name()),
            ))
        }
    }

    fn travel(&self, i: usize, a: &raw::Axis, linear: bool) -> Result<Travel, MachineError> {
        match &a.travel {
            raw::Travel::Endless if linear => Err(self.err(
                path!["axes", i, "travel"],
                format!("linear axis `{}` cannot be endless", a.letter),
                "expected `[min, max]` for a linear axis (only rotary axes may be `endless`)",
            )),
            raw::Travel::Endless => Ok(Travel::Endless),
            raw::Travel::Limited(min, max) => {
                let min = self.quantity(path!["axes", i, "travel", 0], min, linear)?;
                let max = self.quantity(path!["axes", i, "travel", 1], max, linear)?;
                if min < max {
                    Ok(Travel::Limited { min, max })
                } else {
                    Err(self.err(
                        path!["axes", i, "travel"],
                        format!(
                            "the travel of axis `{}` is empty: min {} is not below max {}",
                            a.letter,
                            show(min, linear),
                            show(max, linear)
                        ),
                        "expected `[min, max]` with min < max",
                    ))
                }
            }
        }
    }

    fn chain(&self, axes: &[Axis]) -> Result<Chain, MachineError> {
        let c = &self.raw.chain;
        let letters: Vec<&str> = axes.iter().map(|a| a.letter.as_str()).collect();
        let mut used = vec![false; axes.len()];
        let mut resolve =
            |section: &'static str, names: &[String], want: AxisKind| -> Result<Vec<usize>, MachineError> {
                let mut out = Vec::with_capacity(names.len());
                for (k, name) in names.iter().enumerate() {
                    let Some(idx) = axes.iter().position(|a| a.letter.eq_ignore_ascii_case(name)) else {
                        return Err(self.err(
                            path!["chain", section, k],
                            format!("unknown axis `{name}`"),
                            format!("expected one of the axes {}", list(&letters)),
                        ));
                    };
                    if axes[idx].kind != want {
                        let (is, should) = match want {
                            AxisKind::Linear => ("rotary", "a linear axis"),
                            AxisKind::Rotary => ("linear", "a rotary axis"),
                        };
                        return Err(self.err(
                            path!["chain", section, k],
                            format!("axis `{name}` is {is}"),
                            format!("expected {should} in `chain.{section}`"),
                        ));
                    }
                    if used[idx] {
                        return Err(self.err(
                            path!["chain", section, k],
                            format!("axis `{name}` appears twice in the chain"),
                            "expected each axis once in `chain.linear`, `chain.part` or `chain.tool`",
                        ));
                    }
                    used[idx] = true;
                    out.push(idx);
                }
                Ok(out)
            };
        let linear = resolve("linear", &c.linear, AxisKind::Linear)?;
        let part = resolve("part", &c.part, AxisKind::Rotary)?;
        let tool = resolve("tool", &c.tool, AxisKind::Rotary)?;
        if let Some(i) = used.iter().position(|u| !u) {
            return Err(self.err(
                path!["axes", i, "letter"],
                format!("axis `{}` is not in the chain", axes[i].letter),
                match axes[i].kind {
                    AxisKind::Linear => "expected every linear axis in `chain.linear`",
                    AxisKind::Rotary => "expected every rotary axis in `chain.part` or `chain.tool`",
                },
            ));
        }
        if linear.is_empty() || linear.len() > 3 {
            return Err(self.err(
                path!["chain", "linear"],
                format!("{} linear axes", linear.len()),
                "expected 1 to 3 linear axes",
            ));
        }
        let d: Vec<Vector3<f64>> = linear.iter().map(|&i| axes[i].direction.into_inner()).collect();
        let independent = match d.as_slice() {
            [_] => true,
            [a, b] => a.cross(b).norm() > ANGLE_TOL,
            [a, b, c] => Matrix3::from_columns(&[*a, *b, *c]).determinant().abs() > ANGLE_TOL,
            _ => false,
        };
        if !independent {
            let names: Vec<&str> = linear.iter().map(|&i| axes[i].letter.as_str()).collect();
            return Err(self.err(
                path!["chain", "linear"],
                format!("the directions of the linear axes {} are not linearly independent", list(&names)),
                "expected linear axes that move in independent directions",
            ));
        }
        let part_origin = self.part_origin()?;
        let Some(tool_direction) = unit(&c.spindle.direction) else {
            return Err(self.err(
                path!["chain", "spindle", "direction"],
                "the spindle direction is zero".into(),
                "expected a non-zero vector `[x, y, z]` from the tool tip to the spindle",
            ));
        };
        if c.tool_length.0 < 0.0 {
            return Err(self.err(
                path!["chain", "tool_length"],
                format!("negative tool length {}", show(c.tool_length.0, true)),
                "expected a tool length of zero or more",
            ));
        }
        Ok(Chain {
            linear,
            part,
            tool,
            part_origin,
            spindle_nose: point(&c.spindle.nose),
            tool_direction,
            tool_length: c.tool_length.0,
        })
    }

    fn part_origin(&self) -> Result<Isometry3<f64>, MachineError> {
        let f = &self.raw.chain.part_origin;
        let position = point(&f.position);
        let zero = |key: &'static str| {
            self.err(
                path!["chain", "part_origin", key],
                format!("the part frame's `{key}` is zero"),
                "expected a non-zero vector `[x, y, z]`",
            )
        };
        let x = f.x_axis.as_ref().map(|v| unit(v).ok_or_else(|| zero("x_axis"))).transpose()?;
        let z = f.z_axis.as_ref().map(|v| unit(v).ok_or_else(|| zero("z_axis"))).transpose()?;
        // The missing axis is the base one made perpendicular to the given one.
        let perpendicular = |given: &Unit<Vector3<f64>>, base: Vector3<f64>| {
            let v = base - given.into_inner() * given.dot(&base);
            if v.norm() > ANGLE_TOL { Some(Unit::new_normalize(v)) } else { None }
        };
        let (x, z) = match (x, z) {
            (None, None) => (Vector3::x_axis(), Vector3::z_axis()),
            (Some(x), None) => match perpendicular(&x, Vector3::z()) {
                Some(z) => (x, z),
                None => {
                    return Err(self.err(
                        path!["chain", "part_origin", "x_axis"],
                        "the part frame's `x_axis` is along the base z axis".into(),
                        "expected `z_axis` too when `x_axis` is along z",
                    ));
                }
            },
            (None, Some(z)) => match perpendicular(&z, Vector3::x()) {
                Some(x) => (x, z),
                None => {
                    return Err(self.err(
                        path!["chain", "part_origin", "z_axis"],
                        "the part frame's `z_axis` is along the base x axis".into(),
                        "expected `x_axis` too when `z_axis` is along x",
                    ));
                }
            },
            (Some(x), Some(z)) => {
                if x.dot(&z).abs() > ANGLE_TOL {
                    return Err(self.err(
                        path!["chain", "part_origin", "z_axis"],
                        format!(
                            "the part frame's `x_axis` and `z_axis` are {:.2}° apart",
                            x.dot(&z).clamp(-1.0, 1.0).acos().to_degrees()
                        ),
                        "expected `z_axis` perpendicular to `x_axis`",
                    ));
                }
                // Exactly perpendicular.
                (perpendicular(&z, x.into_inner()).unwrap_or(x), z)
            }
        };
        let y = z.cross(&x);
        let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x.into_inner(), y, z.into_inner()]));
        Ok(Isometry3::from_parts(Translation3::from(position.coords), UnitQuaternion::from_rotation_matrix(&rotation)))
    }

    fn cnc(&self, axes: &[Axis], chain: &Chain) -> Result<CncParams, MachineError> {
        let c = &self.raw.cnc;
        if c.cycle_time.0 <= 0.0 {
            return Err(self.err(
                path!["cnc", "cycle_time"],
                format!("a cycle time of {} s", c.cycle_time.0),
                "expected a positive cycle time such as `4 ms`",
            ));
        }
        if c.look_ahead == 0 {
            return Err(self.err(
                path!["cnc", "look_ahead"],
                "a look-ahead of 0 blocks".into(),
                "expected at least 1 block",
            ));
        }
        if c.contour_tolerance.0 < 0.0 {
            return Err(self.err(
                path!["cnc", "contour_tolerance"],
                format!("negative contour tolerance {}", show(c.contour_tolerance.0, true)),
                "expected a contour tolerance of zero or more",
            ));
        }
        if !(0.0..=1.0).contains(&c.curvature_accel_share) {
            return Err(self.err(
                path!["cnc", "curvature_accel_share"],
                format!("curvature acceleration share {}", c.curvature_accel_share),
                "expected a share from 0 to 1",
            ));
        }
        for (key, value) in [
            ("tangential_accel", c.tangential_accel.map(|a| (a.0, Dimension::LinearAcceleration))),
            ("tangential_jerk", c.tangential_jerk.map(|j| (j.0, Dimension::LinearJerk))),
        ] {
            if let Some((v, dimension)) = value
                && v <= 0.0
            {
                return Err(self.err(
                    path!["cnc", key],
                    format!("`{key}` must be positive, not {v} {}", dimension.base_unit()),
                    format!("expected {} greater than zero, or no `{key}`", dimension.name()),
                ));
            }
        }
        if let Some(s) = c.spindle_max
            && !(s.0 > 0.0 && s.0.is_finite())
        {
            return Err(self.err(
                path!["cnc", "spindle_max"],
                format!("largest spindle speed {} rpm", s.0),
                "expected a positive spindle speed such as `8100 rpm`, or no `spindle_max`",
            ));
        }
        if c.feed_min.0 <= 0.0 {
            return Err(self.err(
                path!["cnc", "feed_min"],
                format!("smallest feed {} mm/min", c.feed_min.0),
                "expected a positive feed such as `1 mm/min`",
            ));
        }
        let feed_max = match c.feed_max {
            Some(f) => f.0,
            // The fastest linear axis, in mm/min.
            None => chain.linear.iter().map(|&i| axes[i].vmax * 60.0).fold(0.0, f64::max),
        };
        if c.feed_min.0 >= feed_max {
            let (path, expected) = if c.feed_max.is_some() {
                (path!["cnc", "feed_max"], "expected `feed_max` above `feed_min`")
            } else {
                (path!["cnc", "feed_min"], "expected `feed_min` below `feed_max` (default: the largest linear `vmax`)")
            };
            return Err(self.err(
                path,
                format!("feed_min {} mm/min is not below feed_max {} mm/min", round(c.feed_min.0), round(feed_max)),
                expected,
            ));
        }
        Ok(CncParams {
            cycle_time: c.cycle_time.0,
            look_ahead: c.look_ahead,
            contour_tolerance: c.contour_tolerance.0,
            curvature_accel_share: c.curvature_accel_share,
            tangential_accel: c.tangential_accel.map(|a| a.0),
            tangential_jerk: c.tangential_jerk.map(|j| j.0),
            feed_min: c.feed_min.0,
            feed_max,
            spindle_max: c.spindle_max.map(|s| s.0),
        })
    }

    fn policy(&self, axes: &[Axis]) -> Result<PolicyDefaults, MachineError> {
        let p = &self.raw.policy;
        let branch = match &p.branch {
            raw::Branch::Closest => BranchPreference::Closest,
            raw::Branch::Positive(l) | raw::Branch::Negative(l) => {
                let key = if matches!(p.branch, raw::Branch::Positive(_)) { "positive" } else { "negative" };
                let rotary: Vec<&str> =
                    axes.iter().filter(|a| a.kind == AxisKind::Rotary).map(|a| a.letter.as_str()).collect();
                let Some(axis) = axes.iter().find(|a| a.letter.eq_ignore_ascii_case(l) && a.kind == AxisKind::Rotary)
                else {
                    let what = if axes.iter().any(|a| a.letter.eq_ignore_ascii_case(l)) {
                        format!("`{l}` is a linear axis")
                    } else {
                        format!("unknown axis `{l}`")
                    };
                    let expected = if rotary.is_empty() {
                        "expected `branch: closest` on a machine without rotary axes".to_string()
                    } else {
                        format!("expected a rotary axis: {}", list(&rotary))
                    };
                    return Err(self.err(path!["policy", "branch", key], what, expected));
                };
                if key == "positive" {
                    BranchPreference::Positive(axis.letter.clone())
                } else {
                    BranchPreference::Negative(axis.letter.clone())
                }
            }
        };
        if !(p.singular_cone.0 > 0.0 && p.singular_cone.0 < std::f64::consts::FRAC_PI_2) {
            return Err(self.err(
                path!["policy", "singular_cone"],
                format!("singular cone of {}", show(p.singular_cone.0, false)),
                "expected a half-angle above 0 and below 90 deg, such as `0.5 deg`",
            ));
        }
        let pole_passage = p.pole_passage.map_or(p.singular_cone.0, |a| a.0);
        if !(pole_passage >= p.singular_cone.0 && pole_passage < std::f64::consts::FRAC_PI_2) {
            return Err(self.err(
                path!["policy", "pole_passage"],
                format!("pole passage of {}", show(pole_passage, false)),
                format!(
                    "expected an angle from the singular cone ({}) to below 90 deg, such as `2 deg`",
                    show(p.singular_cone.0, false)
                ),
            ));
        }
        if p.max_rotary_step.0 <= 0.0 {
            return Err(self.err(
                path!["policy", "max_rotary_step"],
                format!("largest rotary step of {}", show(p.max_rotary_step.0, false)),
                "expected an angle above 0, such as `30 deg`",
            ));
        }
        let on_discontinuity = match p.on_discontinuity {
            raw::OnDiscontinuity::Error => OnDiscontinuity::Error,
            raw::OnDiscontinuity::Retract(c) if c.0 > 0.0 => OnDiscontinuity::Retract { clearance: c.0 },
            raw::OnDiscontinuity::Retract(c) => {
                return Err(self.err(
                    path!["policy", "on_discontinuity", "retract"],
                    format!("retract distance {}", show(c.0, true)),
                    "expected a positive retract distance such as `50 mm`",
                ));
            }
        };
        if p.linearization_tolerance.0 <= 0.0 {
            return Err(self.err(
                path!["policy", "linearization_tolerance"],
                format!("linearization tolerance {}", show(p.linearization_tolerance.0, true)),
                "expected a positive tolerance such as `0.01 mm`",
            ));
        }
        let unwind = match p.unwind {
            raw::Unwind::Off => None,
            raw::Unwind::Turns(turns) if turns > 0.0 => Some(turns),
            raw::Unwind::Turns(turns) => {
                return Err(self.err(
                    path!["policy", "unwind"],
                    format!("unwinding after {turns} turns"),
                    "expected a number of turns above 0 such as `2 turns`, or `off`",
                ));
            }
        };
        Ok(PolicyDefaults {
            branch,
            choice: match p.choice {
                raw::Choice::WholePath => PathChoice::WholePath,
                raw::Choice::Greedy => PathChoice::Greedy,
            },
            singular_cone: p.singular_cone.0,
            pole_passage,
            max_rotary_step: p.max_rotary_step.0,
            on_discontinuity,
            linearization_tolerance: p.linearization_tolerance.0,
            unwind,
            missing_feed: match p.missing_feed {
                raw::MissingFeed::Error => crate::model::MissingFeed::Error,
                raw::MissingFeed::Rapid => crate::model::MissingFeed::Rapid,
            },
        })
    }

    fn solver(&self, axes: &[Axis], chain: &Chain) -> Result<SolverKind, MachineError> {
        match self.raw.solver {
            raw::Solver::Generic => return Ok(SolverKind::Generic),
            // Any shape: the plugin's kinematics is checked against this chain when it loads.
            raw::Solver::Plugin => return Ok(SolverKind::Plugin),
            raw::Solver::ClosedForm => {}
        }
        let names: Vec<&str> = CLOSED_FORMS.iter().map(|(n, _)| *n).collect();
        let Some(form) = closed_form_for(&self.raw.name) else {
            return Err(self.err_help(
                path!["solver"],
                format!("machine `{}` has no closed-form solver", self.raw.name),
                "expected `solver: generic`",
                format!("closed forms exist for the machines named {} only", list(&names)),
            ));
        };
        let (first_name, first) = match form {
            ClosedForm::MikronUcp710 => ("x", Vector3::x()),
            ClosedForm::Maho600e => ("y", Vector3::y()),
        };
        let help = format!(
            "the closed form of `{}` needs linear axes along +x, +y, +z, two part-side rotary axes (the first \
             about ±{first_name}, the second about ±z), no tool-side rotary axis and the tool along +z; \
             use `solver: generic` for another shape",
            self.raw.name
        );
        let fail = |path: &[Seg<'_>], message: String, expected: String| {
            Err(self.err_help(path, message, expected, help.clone()))
        };
        let parallel = |u: &Unit<Vector3<f64>>, v: Vector3<f64>| u.dot(&v) >= 1.0 - ANGLE_TOL;
        let antiparallel = |u: &Unit<Vector3<f64>>, v: Vector3<f64>| parallel(u, v) || parallel(u, -v);
        if !chain.tool.is_empty() {
            return fail(
                path!["chain", "tool"],
                format!("the closed form of `{}` has no tool-side rotary axis", self.raw.name),
                "expected `tool: []`".into(),
            );
        }
        if chain.part.len() != 2 {
            return fail(
                path!["chain", "part"],
                format!(
                    "the closed form of `{}` needs two part-side rotary axes, not {}",
                    self.raw.name,
                    chain.part.len()
                ),
                "expected two part-side rotary axes, base first".into(),
            );
        }
        if chain.linear.len() != 3 {
            return fail(
                path!["chain", "linear"],
                format!("the closed form of `{}` needs three linear axes", self.raw.name),
                "expected three linear axes along +x, +y and +z".into(),
            );
        }
        for (k, (&i, (base, name))) in
            chain.linear.iter().zip([(Vector3::x(), "+x"), (Vector3::y(), "+y"), (Vector3::z(), "+z")]).enumerate()
        {
            if !parallel(&axes[i].direction, base) {
                return fail(
                    path!["axes", i, "direction"],
                    format!(
                        "linear axis `{}` (the {} in `chain.linear`) is not along {name}",
                        axes[i].letter,
                        ["first", "second", "third"][k]
                    ),
                    format!("expected `direction: {}` for the closed form", vector_text(base)),
                );
            }
        }
        for (k, (axis, name)) in [(first, first_name), (Vector3::z(), "z")].into_iter().enumerate() {
            let i = chain.part[k];
            if !antiparallel(&axes[i].direction, axis) {
                return fail(
                    path!["axes", i, "direction"],
                    format!(
                        "the {} part-side rotary axis `{}` does not turn about ±{name}",
                        if k == 0 { "first" } else { "second" },
                        axes[i].letter
                    ),
                    format!("expected `direction: {}` or `{}`", vector_text(axis), vector_text(-axis)),
                );
            }
        }
        if !parallel(&chain.tool_direction, Vector3::z()) {
            return fail(
                path!["chain", "spindle", "direction"],
                "the tool direction is not +z".into(),
                "expected `direction: [0, 0, 1]` for the closed form".into(),
            );
        }
        Ok(SolverKind::ClosedForm(form))
    }

    /// `clearance`: a safe Z within the travel of the linear axis along the spindle, or a
    /// positive retract; by default a safe Z at the end of that travel away from the part.
    fn clearance(&self, axes: &[Axis], chain: &Chain) -> Result<Clearance, MachineError> {
        let axis = spindle_linear_axis(axes, chain);
        match (&self.raw.clearance, axis) {
            (Some(raw::Clearance::Retract(d)), _) if d.0 > 0.0 => Ok(Clearance::Retract(d.0)),
            (Some(raw::Clearance::Retract(d)), _) => Err(self.err(
                path!["clearance", "retract"],
                format!("retract distance {}", show(d.0, true)),
                "expected a positive distance along the tool axis, such as `50 mm`",
            )),
            (Some(raw::Clearance::SafeZ(_)) | None, None) => {
                let letters: Vec<&str> = chain.linear.iter().map(|&i| axes[i].letter.as_str()).collect();
                let message = format!(
                    "no linear axis ({}) is parallel to the spindle direction {}",
                    list(&letters),
                    vector_text(chain.tool_direction.into_inner())
                );
                let expected = "expected `clearance: { retract: LENGTH }`, a distance along the tool axis";
                match self.raw.clearance {
                    Some(_) => Err(self.err(path!["clearance", "safe_z"], message, expected)),
                    None => Err(self.err_help(
                        path!["clearance"],
                        message,
                        expected,
                        "without such an axis there is no default safe height: give `clearance`".into(),
                    )),
                }
            }
            (Some(raw::Clearance::SafeZ(z)), Some(i)) => {
                let a = &axes[i];
                // A linear axis's travel is limited (checked with the axes).
                let Travel::Limited { min, max } = a.travel else { return Ok(Clearance::SafeZ(z.0)) };
                if a.travel.contains(z.0) {
                    return Ok(Clearance::SafeZ(z.0));
                }
                Err(self.err(
                    path!["clearance", "safe_z"],
                    format!("safe Z {} is beyond the travel of axis `{}`", show(z.0, true), a.letter),
                    format!(
                        "expected a machine coordinate of `{}` from {} to {}, near the end away from the part",
                        a.letter,
                        show(min, true),
                        show(max, true)
                    ),
                ))
            }
            (None, Some(i)) => Ok(Clearance::SafeZ(default_safe_z(&axes[i], chain))),
        }
    }
}

/// The end of the spindle axis's travel that takes the tool away from the part: the top when the
/// axis moves the tool along the spindle direction (tip → spindle), the bottom otherwise.
fn default_safe_z(axis: &Axis, chain: &Chain) -> f64 {
    match axis.travel {
        Travel::Limited { max, .. } if axis.direction.dot(&chain.tool_direction) > 0.0 => max,
        Travel::Limited { min, .. } => min,
        // A linear axis's travel is limited (checked with the axes).
        Travel::Endless => 0.0,
    }
}

/// `[0, -1, 0]`
fn vector_text(v: Vector3<f64>) -> String {
    // `+ 0.0` turns -0 into 0.
    format!("[{}, {}, {}]", v.x + 0.0, v.y + 0.0, v.z + 0.0)
}

/// `M` and digits (`M10`, `m11`, `M1.2`).
fn is_m_code(code: &str) -> bool {
    let mut chars = code.chars();
    matches!(chars.next(), Some('M' | 'm'))
        && !code[1..].is_empty()
        && code[1..].chars().all(|c| c.is_ascii_digit() || c == '.')
        && code[1..].starts_with(|c: char| c.is_ascii_digit())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;
    use crate::error::DefinitionError;

    /// A valid 5-axis table-table machine; the tests change one thing each.
    const BASE: &str = "\
name: test-tt
dialect: fanuc
solver: generic
axes:
  - { letter: X, kind: linear, direction: [1, 0, 0], travel: [-300, 300], vmax: 30 m/min, amax: 2 m/s^2, jmax: 20 m/s^3 }
  - { letter: Y, kind: linear, direction: [0, 1, 0], travel: [-200, 200], vmax: 30 m/min, amax: 2 m/s^2, jmax: 20 m/s^3 }
  - { letter: Z, kind: linear, direction: [0, 0, 1], travel: [-300, 100], vmax: 30 m/min, amax: 2 m/s^2, jmax: 20 m/s^3 }
  - { letter: A, kind: rotary, direction: [1, 0, 0], center: [0, 0, -100], travel: [-120, 30], vmax: 20 rpm, amax: 1 rev/s^2, jmax: 10 rev/s^3 }
  - { letter: C, kind: rotary, direction: [0, 0, 1], center: [0, 0, -150], travel: endless, vmax: 30 rpm, amax: 1 rev/s^2, jmax: 10 rev/s^3 }
chain:
  linear: [X, Y, Z]
  part: [A, C]
  spindle: { nose: [0, 0, 0], direction: [0, 0, 1] }
";

    fn load(text: &str) -> Result<Machine, MachineError> {
        crate::parse("test.yaml", text)
    }

    /// The error's message, label and the text under the caret.
    fn fails(text: &str) -> (String, String, String) {
        match load(text) {
            Ok(_) => panic!("loads:\n{text}"),
            Err(MachineError::Definition(e)) => {
                let DefinitionError { message, expected, span, .. } = *e;
                let at = text[span.offset()..span.offset() + span.len()].to_string();
                (message, expected, at)
            }
            Err(e) => panic!("{e}"),
        }
    }

    fn with(from: &str, to: &str) -> String {
        assert!(BASE.contains(from), "{from}");
        BASE.replacen(from, to, 1)
    }

    #[test]
    fn the_base_loads_with_the_defaults() {
        let m = load(BASE).unwrap();
        assert_eq!(m.solver, SolverKind::Generic);
        assert_eq!(m.chain.part, vec![3, 4]);
        assert_eq!(m.axes[0].decimals, 3);
        assert!((m.axes[3].vmax - 20.0 * std::f64::consts::TAU / 60.0).abs() < 1e-12);
        assert_eq!(m.axes[3].travel, Travel::Limited { min: (-120f64).to_radians(), max: 30f64.to_radians() });
        assert_eq!(m.cnc.feed_max, 30_000.0);
        assert_eq!(m.cnc.cycle_time, 0.004);
        assert_eq!(m.policy.branch, BranchPreference::Closest);
        assert_eq!(m.chain.part_origin, Isometry3::identity());
        assert_eq!(m.chain.tool_length, 0.0);
    }

    #[test]
    fn duplicate_letters() {
        let (m, e, at) = fails(&with("letter: Y", "letter: x"));
        assert_eq!(
            (m.as_str(), e.as_str(), at.as_str()),
            (
                "axes[1].letter: axis letter `x` is used twice (axes[0] and axes[1])",
                "expected a letter that no other axis has",
                "x"
            )
        );
    }

    #[test]
    fn bad_letters() {
        assert_eq!(fails(&with("letter: Y", "letter: ''")).2, "''");
        assert_eq!(fails(&with("letter: Y", "letter: 2Y")).2, "2Y");
    }

    #[test]
    fn zero_direction() {
        let (m, _, at) = fails(&with("direction: [0, 1, 0]", "direction: [0, 0, 0]"));
        assert_eq!((m.as_str(), at.as_str()), ("axes[1].direction: axis `Y` has a zero direction", "[0, 0, 0]"));
    }

    #[test]
    fn directions_are_normalised() {
        let m = load(&with("direction: [0, 1, 0]", "direction: [0, 3, 0]")).unwrap();
        assert_eq!(m.axes[1].direction.into_inner(), Vector3::y());
    }

    #[test]
    fn empty_travel() {
        let (m, _, at) = fails(&with("travel: [-200, 200]", "travel: [200 mm, 0.2 m]"));
        assert_eq!(m, "axes[1].travel: the travel of axis `Y` is empty: min 200 mm is not below max 200 mm");
        assert_eq!(at, "[200 mm, 0.2 m]");
    }

    #[test]
    fn rotary_travel_may_exceed_a_turn() {
        let m = load(&with("travel: [-120, 30]", "travel: [-2 rev, 2 rev]")).unwrap();
        assert_eq!(
            m.axes[3].travel,
            Travel::Limited { min: -4.0 * std::f64::consts::PI, max: 4.0 * std::f64::consts::PI }
        );
    }

    #[test]
    fn linear_travel_is_not_endless() {
        assert_eq!(fails(&with("travel: [-200, 200]", "travel: endless")).2, "endless");
    }

    #[test]
    fn dimension_depends_on_the_kind() {
        let (m, e, at) = fails(&with("vmax: 20 rpm", "vmax: 20 m/min"));
        assert_eq!(m, "axes[3].vmax: `20 m/min` is a linear velocity on a rotary axis");
        assert!(e.starts_with("expected an angular velocity such as"), "{e}");
        assert_eq!(at, "20 m/min");
        let (m, _, at) = fails(&with("travel: [-300, 100]", "travel: [-300 mm, 100 deg]"));
        assert_eq!((m.as_str(), at.as_str()), ("axes[2].travel[1]: `100 deg` is an angle on a linear axis", "100 deg"));
    }

    #[test]
    fn limits_are_positive() {
        let (m, _, at) = fails(&with("amax: 2 m/s^2", "amax: 0 m/s^2"));
        assert_eq!((m.as_str(), at.as_str()), ("axes[0].amax: `amax` must be positive, not `0 m/s^2`", "0 m/s^2"));
        assert_eq!(fails(&with("jmax: 20 m/s^3", "jmax: -1")).2, "-1");
    }

    #[test]
    fn home_within_travel() {
        let (m, _, at) = fails(&with("travel: [-120, 30]", "travel: [-120, 30], home: 45 deg"));
        assert_eq!(
            (m.as_str(), at.as_str()),
            ("axes[3].home: home 45 deg of axis `A` is outside its travel", "45 deg")
        );
    }

    #[test]
    fn decimals() {
        let (_, e, at) = fails(&with("jmax: 20 m/s^3 }", "jmax: 20 m/s^3, decimals: 10 }"));
        assert_eq!((e.as_str(), at.as_str()), ("expected 0 to 9 decimals", "10"));
    }

    #[test]
    fn centres() {
        let (m, _, at) = fails(&with("center: [0, 0, -100], ", ""));
        assert_eq!(m, "axes[3].center: rotary axis `A` has no `center`");
        assert!(at.starts_with("{ letter: A"), "{at}");
        let (m, _, at) =
            fails(&with("direction: [1, 0, 0], travel", "direction: [1, 0, 0], center: [0, 0, 0], travel"));
        assert_eq!((m.as_str(), at.as_str()), ("axes[0].center: linear axis `X` has a `center`", "[0, 0, 0]"));
    }

    #[test]
    fn chain_letters() {
        let (m, e, at) = fails(&with("part: [A, C]", "part: [A, W]"));
        assert_eq!(m, "chain.part[1]: unknown axis `W`");
        assert_eq!(e, "expected one of the axes `X`, `Y`, `Z`, `A` and `C`");
        assert_eq!(at, "W");
        let (m, _, at) = fails(&with("part: [A, C]", "part: [A, Z]"));
        assert_eq!((m.as_str(), at.as_str()), ("chain.part[1]: axis `Z` is linear", "Z"));
        let (m, _, at) = fails(&with("linear: [X, Y, Z]", "linear: [X, Y, A]"));
        assert_eq!((m.as_str(), at.as_str()), ("chain.linear[2]: axis `A` is rotary", "A"));
        let (m, _, _) = fails(&with("part: [A, C]", "part: [A, A]"));
        assert_eq!(m, "chain.part[1]: axis `A` appears twice in the chain");
        let (m, _, at) = fails(&with("part: [A, C]", "part: [A]"));
        assert_eq!((m.as_str(), at.as_str()), ("axes[4].letter: axis `C` is not in the chain", "C"));
    }

    #[test]
    fn tool_side_axes() {
        let m = load(&with("part: [A, C]", "part: [C]\n  tool: [A]")).unwrap();
        assert_eq!(m.chain.tool, vec![3]);
        assert_eq!(m.topology(), crate::model::Topology::HeadTable);
    }

    #[test]
    fn linear_independence() {
        let text = with("direction: [0, 0, 1], travel", "direction: [1, 1, 0], travel");
        let (m, _, at) = fails(&text);
        assert_eq!(m, "chain.linear: the directions of the linear axes `X`, `Y` and `Z` are not linearly independent");
        assert_eq!(at, "[X, Y, Z]");
        // Two axes are fine, and so is a non-orthogonal but independent set.
        let two = BASE.replace("linear: [X, Y, Z]", "linear: [X, Y]").replace(
            "  - { letter: Z, kind: linear, direction: [0, 0, 1], travel: [-300, 100], vmax: 30 m/min, amax: 2 m/s^2, jmax: 20 m/s^3 }\n",
            "",
        );
        // Neither has a linear axis along the spindle, hence no default clearance.
        let retract = "clearance: { retract: 50 mm }\n";
        assert_eq!(load(&format!("{two}{retract}")).unwrap().chain.linear, vec![0, 1]);
        let skewed = with("direction: [0, 0, 1], travel", "direction: [0, 1, 1], travel");
        assert!(load(&format!("{skewed}{retract}")).is_ok());
    }

    #[test]
    fn clearance() {
        // By default, a safe Z at the top of the Z travel (`[-300, 100]`).
        let m = load(BASE).unwrap();
        assert_eq!((m.clearance, m.spindle_linear_axis()), (Clearance::SafeZ(100.0), Some(2)));
        assert_eq!(m.units, crate::model::ProgramUnits::Mm);
        // The bottom when Z moves the tool towards the part.
        let down = with("direction: [0, 0, 1], travel", "direction: [0, 0, -1], travel");
        assert_eq!(load(&down).unwrap().clearance, Clearance::SafeZ(-300.0));
        let m = load(&format!("{BASE}clearance: {{ safe_z: 0.05 m }}\nunits: inch\n")).unwrap();
        assert_eq!((m.clearance, m.units), (Clearance::SafeZ(50.0), crate::model::ProgramUnits::Inch));
        let m = load(&format!("{BASE}clearance: {{ retract: 2 in }}\n")).unwrap();
        assert_eq!(m.clearance, Clearance::Retract(50.8));
        let (m, e, at) = fails(&format!("{BASE}clearance: {{ safe_z: 150 mm }}\n"));
        assert_eq!(
            (m.as_str(), e.as_str(), at.as_str()),
            (
                "clearance.safe_z: safe Z 150 mm is beyond the travel of axis `Z`",
                "expected a machine coordinate of `Z` from -300 mm to 100 mm, near the end away from the part",
                "150 mm"
            )
        );
        assert_eq!(fails(&format!("{BASE}clearance: {{ retract: 0 }}\n")).2, "0");
        // Without a linear axis along the spindle: no default, and no safe Z.
        let skewed = with("direction: [0, 0, 1], travel", "direction: [0, 1, 1], travel");
        let (m, _, at) = fails(&skewed);
        assert_eq!(m, "clearance: no linear axis (`X`, `Y` and `Z`) is parallel to the spindle direction [0, 0, 1]");
        assert_eq!(at, "name: test-tt");
        let (_, e, at) = fails(&format!("{skewed}clearance: {{ safe_z: 0 }}\n"));
        assert_eq!(
            (e.as_str(), at.as_str()),
            ("expected `clearance: { retract: LENGTH }`, a distance along the tool axis", "0")
        );
    }

    #[test]
    fn too_many_rotaries() {
        let text = BASE.replace(
            "chain:",
            "  - { letter: B, kind: rotary, direction: [0, 1, 0], center: [0, 0, 0], travel: endless, vmax: 1 rpm, amax: 1 rev/s^2, jmax: 1 rev/s^3 }\nchain:",
        );
        let (m, e, at) = fails(&text);
        assert_eq!(
            (m.as_str(), e.as_str(), at.as_str()),
            ("axes[5].kind: axis `B` is a third rotary axis", "expected at most 2 rotary axes", "rotary")
        );
    }

    #[test]
    fn spindle_and_tool_length() {
        let (m, _, at) = fails(&with("direction: [0, 0, 1] }", "direction: [0, 0, 0] }"));
        assert_eq!((m.as_str(), at.as_str()), ("chain.spindle.direction: the spindle direction is zero", "[0, 0, 0]"));
        let (m, _, at) = fails(&with("direction: [0, 0, 1] }\n", "direction: [0, 0, 1] }\n  tool_length: -5 mm\n"));
        assert_eq!((m.as_str(), at.as_str()), ("chain.tool_length: negative tool length -5 mm", "-5 mm"));
    }

    #[test]
    fn part_origin_frames() {
        let m = load(&with("  spindle:", "  part_origin: { position: [1, 2, 3], z_axis: [0, -1, 0] }\n  spindle:"))
            .unwrap();
        let o = m.chain.part_origin;
        assert!((o * Vector3::z() - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
        assert!((o * Vector3::x() - Vector3::x()).norm() < 1e-12);
        assert!((o * Point3::origin() - Point3::new(1.0, 2.0, 3.0)).norm() < 1e-12);
        let (m, _, at) = fails(&with(
            "  spindle:",
            "  part_origin: { position: [0, 0, 0], x_axis: [1, 0, 0], z_axis: [1, 0, 1] }\n  spindle:",
        ));
        assert_eq!(
            (m.as_str(), at.as_str()),
            ("chain.part_origin.z_axis: the part frame's `x_axis` and `z_axis` are 45.00° apart", "[1, 0, 1]")
        );
        let m = load(&with(
            "  spindle:",
            "  part_origin: { position: [0, 0, 0], x_axis: [0, 1, 0], z_axis: [1, 0, 0] }\n  spindle:",
        ))
        .unwrap();
        let o = m.chain.part_origin;
        assert!((o * Vector3::y() - Vector3::z()).norm() < 1e-12);
    }

    #[test]
    fn cnc_checks() {
        let cnc = |body: &str| format!("{BASE}cnc:\n{body}\n");
        let (_, _, at) = fails(&cnc("  curvature_accel_share: 1.5"));
        assert_eq!(at, "1.5");
        let (_, _, at) = fails(&cnc("  cycle_time: 0 ms"));
        assert_eq!(at, "0 ms");
        let (m, _, at) = fails(&cnc("  feed_min: 10 m/min\n  feed_max: 5 m/min"));
        assert_eq!(
            (m.as_str(), at.as_str()),
            ("cnc.feed_max: feed_min 10000 mm/min is not below feed_max 5000 mm/min", "5 m/min")
        );
        let (_, e, at) = fails(&cnc("  feed_min: 40 m/min"));
        assert!(e.contains("default"), "{e}");
        assert_eq!(at, "40 m/min");
        let (_, _, at) = fails(&cnc("  look_ahead: 0"));
        assert_eq!(at, "0");
        let (_, _, at) = fails(&cnc("  tangential_jerk: 0 m/s^3"));
        assert_eq!(at, "0 m/s^3");
        let m = load(&cnc("  feed_max: 12 m/min\n  tangential_accel: 5 m/s^2")).unwrap();
        assert_eq!((m.cnc.feed_max, m.cnc.tangential_accel, m.cnc.look_ahead), (12_000.0, Some(5000.0), 10));
        assert_eq!(m.cnc.spindle_max, None);
        let (m, e, at) = fails(&cnc("  spindle_max: 0 rpm"));
        assert_eq!((m.as_str(), at.as_str()), ("cnc.spindle_max: largest spindle speed 0 rpm", "0 rpm"));
        assert!(e.contains("8100 rpm"), "{e}");
        let (_, e, at) = fails(&cnc("  spindle_max: 8100 mm/min"));
        assert!(e.contains("spindle speed"), "{e}");
        assert_eq!(at, "8100 mm/min");
        let m = load(&cnc("  spindle_max: 12000")).unwrap();
        assert_eq!(m.cnc.spindle_max, Some(12_000.0));
    }

    #[test]
    fn policy_checks() {
        let policy = |body: &str| format!("{BASE}policy:\n{body}\n");
        let (m, e, at) = fails(&policy("  branch: { positive: X }"));
        assert_eq!(
            (m.as_str(), e.as_str(), at.as_str()),
            ("policy.branch.positive: `X` is a linear axis", "expected a rotary axis: `A` and `C`", "X")
        );
        let (m, _, _) = fails(&policy("  branch: { negative: B }"));
        assert_eq!(m, "policy.branch.negative: unknown axis `B`");
        let m = load(&policy("  branch: { negative: a }\n  on_discontinuity: { retract: 2 in }")).unwrap();
        assert_eq!(m.policy.branch, BranchPreference::Negative("A".into()));
        assert_eq!(m.policy.on_discontinuity, OnDiscontinuity::Retract { clearance: 50.8 });
        assert_eq!(fails(&policy("  singular_cone: 0")).2, "0");
        assert_eq!(fails(&policy("  singular_cone: 90 deg")).2, "90 deg");
        assert_eq!(fails(&policy("  max_rotary_step: -1 deg")).2, "-1 deg");
        assert_eq!(fails(&policy("  linearization_tolerance: 0 mm")).2, "0 mm");
        assert_eq!(fails(&policy("  on_discontinuity: { retract: 0 mm }")).2, "0 mm");
        assert_eq!(fails(&policy("  unwind: 0 turns")).2, "0 turns");
        assert_eq!(fails(&policy("  unwind: -1")).2, "-1");
        assert_eq!(load(&policy("  unwind: off")).unwrap().policy.unwind, None);
        assert_eq!(load(&policy("  unwind: 3 turns")).unwrap().policy.unwind, Some(3.0));
        assert_eq!(load(BASE).unwrap().policy.unwind, Some(2.0));
    }

    #[test]
    fn names_and_dialects() {
        let (m, _, at) = fails(&with("name: test-tt", "name: test tt"));
        assert_eq!((m.as_str(), at.as_str()), ("name: invalid machine name `test tt`", "test tt"));
        let (m, _, at) = fails(&with("name: test-tt", "name: test-tt\naliases: [tt, TEST-TT]"));
        assert_eq!((m.as_str(), at.as_str()), ("aliases[1]: alias `TEST-TT` repeats `test-tt`", "TEST-TT"));
        let (m, e, at) = fails(&with("dialect: fanuc", "dialect: fanuk"));
        assert_eq!(m, "dialect: unknown dialect `fanuk`");
        assert_eq!(e, "expected one of `siemens-840d`, `fanuc`, `haas`, `heidenhain` and `linuxcnc`");
        assert_eq!(at, "fanuk");
    }

    #[test]
    fn closed_form_only_for_known_names() {
        let (m, _, at) = fails(&with("solver: generic", "solver: closed-form"));
        assert_eq!((m.as_str(), at.as_str()), ("solver: machine `test-tt` has no closed-form solver", "closed-form"));
    }

    #[test]
    fn plugin_solver_takes_any_shape() {
        let m = load(&with("solver: generic", "solver: plugin")).unwrap();
        assert_eq!(m.solver, SolverKind::Plugin);
        let head_table = with("solver: generic", "solver: plugin").replace("part: [A, C]", "part: [C]\n  tool: [A]");
        assert_eq!(load(&head_table).unwrap().solver, SolverKind::Plugin);
    }

    #[test]
    fn closed_form_shape() {
        let mikron = with("solver: generic", "solver: closed-form").replace("name: test-tt", "name: mikron-ucp710");
        assert_eq!(load(&mikron).unwrap().solver, SolverKind::ClosedForm(ClosedForm::MikronUcp710));
        let maho = mikron.replace("name: mikron-ucp710", "name: maho600e");
        let (m, e, at) = fails(&maho);
        assert_eq!(m, "axes[3].direction: the first part-side rotary axis `A` does not turn about ±y");
        assert_eq!(e, "expected `direction: [0, 1, 0]` or `[0, -1, 0]`");
        assert_eq!(at, "[1, 0, 0]");
        let (m, _, at) = fails(&mikron.replace("part: [A, C]", "part: [C, A]"));
        assert_eq!(
            (m.as_str(), at.as_str()),
            ("axes[4].direction: the first part-side rotary axis `C` does not turn about ±x", "[0, 0, 1]")
        );
        let (_, _, at) = fails(&mikron.replace("part: [A, C]", "part: [A]\n  tool: [C]"));
        assert_eq!(at, "[C]");
        let (_, _, at) = fails(&mikron.replace("direction: [0, 0, 1] }", "direction: [0, 0, -1] }"));
        assert_eq!(at, "[0, 0, -1]");
    }
}
