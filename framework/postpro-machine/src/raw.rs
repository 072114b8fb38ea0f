//! The YAML file format as plain serde types, mirroring the file key for key. Every struct
//! denies unknown keys. Quantities are checked for their unit and dimension while they
//! deserialize ([`crate::quantity`]); everything else is checked by [`crate::validate`], the one
//! conversion into the [`crate::model`]. Kinematics never sees these types.
//!
//! Optional keys and their defaults (see `docs/machine-defs.md`):
//! `aliases: []`, `description: ""`, `solver: generic`, `center` (rotary axes only, required
//! there), `home: 0`, `decimals: 3`, `chain.part: []`, `chain.tool: []`,
//! `chain.part_origin: { position: [0, 0, 0] }` (axes parallel to the base frame),
//! `chain.tool_length: 0 mm`, the whole `cnc` section ([`Cnc::default`]) and the whole `policy`
//! section ([`Policy::default`]), each key of which may also be left out on its own;
//! `clearance` (a safe Z at the top of the travel of the linear axis along the spindle, computed
//! by [`crate::validate`]) and `units: mm`.

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};

use crate::quantity::{Angle, AxisQuantity, Feed, Length, LinearAcceleration, LinearJerk, SpindleSpeed, Time};

/// One machine definition file.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineFile {
    /// The name users type.
    pub name: String,
    /// Other names.
    #[serde(default)]
    pub aliases: Vec<String>,
    /// One line for `postpro machines`.
    #[serde(default)]
    pub description: String,
    /// The controller dialect.
    pub dialect: String,
    /// `closed-form`, `generic` (default) or `plugin`.
    #[serde(default)]
    pub solver: Solver,
    /// The axes, in the order the NC program writes them.
    pub axes: Vec<Axis>,
    /// The kinematic chain.
    pub chain: Chain,
    /// CNC parameters (default: [`Cnc::default`]).
    #[serde(default)]
    pub cnc: Cnc,
    /// IKT policy defaults (default: [`Policy::default`]).
    #[serde(default)]
    pub policy: Policy,
    /// `{safe_z: LENGTH}` or `{retract: LENGTH}` (default: a safe Z at the top of the travel of
    /// the linear axis along the spindle).
    #[serde(default)]
    pub clearance: Option<Clearance>,
    /// The program's units by default (default `mm`).
    #[serde(default)]
    pub units: Units,
}

/// `solver:`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Solver {
    /// The hand-derived closed form of the machine with this name.
    ClosedForm,
    /// The generic serial-chain solver.
    #[default]
    Generic,
    /// The compiled kinematics of the plugin that ships the definition.
    Plugin,
}

/// `kind:` of an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AxisKind {
    /// Translates.
    Linear,
    /// Rotates.
    Rotary,
}

/// One entry of `axes:`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// The NC address letter.
    pub letter: String,
    /// `linear` or `rotary`.
    pub kind: AxisKind,
    /// `[x, y, z]`, any length but not zero.
    pub direction: [f64; 3],
    /// `[x, y, z]`: a point on the axis line (rotary axes only).
    #[serde(default)]
    pub center: Option<[Length; 3]>,
    /// `[min, max]` or `endless`.
    pub travel: Travel,
    /// Home position (default 0).
    #[serde(default)]
    pub home: Option<AxisQuantity<0>>,
    /// Maximum velocity.
    pub vmax: AxisQuantity<1>,
    /// Maximum acceleration.
    pub amax: AxisQuantity<2>,
    /// Maximum jerk.
    pub jmax: AxisQuantity<3>,
    /// Decimals in the NC program (default 3).
    #[serde(default = "default_decimals")]
    pub decimals: u8,
    /// A rotary axis's brake: the M codes that lock and unlock it (`{ lock: M10, unlock: M11 }`).
    #[serde(default)]
    pub clamp: Option<Clamp>,
}

/// `clamp:` of a rotary axis.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Clamp {
    /// The code that locks the axis (`M10`).
    pub lock: String,
    /// The code that unlocks it (`M11`).
    pub unlock: String,
}

fn default_decimals() -> u8 {
    3
}

/// `travel:` of an axis.
#[derive(Clone, Debug, PartialEq)]
pub enum Travel {
    /// `[min, max]`.
    Limited(AxisQuantity<0>, AxisQuantity<0>),
    /// `endless`.
    Endless,
}

impl<'de> Deserialize<'de> for Travel {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct TravelVisitor;
        impl<'de> Visitor<'de> for TravelVisitor {
            type Value = Travel;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("`[min, max]` or `endless`")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Travel, E> {
                if v == "endless" { Ok(Travel::Endless) } else { Err(E::invalid_value(de::Unexpected::Str(v), &self)) }
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Travel, A::Error> {
                let min = seq.next_element()?.ok_or_else(|| de::Error::invalid_length(0, &self))?;
                let max = seq.next_element()?.ok_or_else(|| de::Error::invalid_length(1, &self))?;
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(3, &self));
                }
                Ok(Travel::Limited(min, max))
            }
        }
        deserializer.deserialize_any(TravelVisitor)
    }
}

/// `chain:`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Chain {
    /// The linear axes' letters.
    pub linear: Vec<String>,
    /// The part-side rotary axes, from the base to the part (default none).
    #[serde(default)]
    pub part: Vec<String>,
    /// The tool-side rotary axes, from the base to the spindle (default none).
    #[serde(default)]
    pub tool: Vec<String>,
    /// The part frame at all-zero (default: at the origin, parallel to the base frame).
    #[serde(default)]
    pub part_origin: Frame,
    /// The spindle at all-zero.
    pub spindle: Spindle,
    /// Tool length from the spindle nose to the tip (default 0).
    #[serde(default = "zero_length")]
    pub tool_length: Length,
}

fn zero_length() -> Length {
    Length(0.0)
}

/// `part_origin:`: a position and, optionally, the directions of the part frame's x and z axes.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Frame {
    /// `[x, y, z]`.
    pub position: [Length; 3],
    /// The part frame's x axis (default: the base x, or as close to it as `z_axis` allows).
    #[serde(default)]
    pub x_axis: Option<[f64; 3]>,
    /// The part frame's z axis (default: the base z, or as close to it as `x_axis` allows).
    #[serde(default)]
    pub z_axis: Option<[f64; 3]>,
}

impl Default for Frame {
    fn default() -> Self {
        Frame { position: [Length(0.0); 3], x_axis: None, z_axis: None }
    }
}

/// `spindle:`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spindle {
    /// The spindle nose (gauge point) at all-zero.
    pub nose: [Length; 3],
    /// The tool axis (tip → spindle) at all-zero.
    pub direction: [f64; 3],
}

/// `cnc:`. Every key may be left out; the defaults are those of [`Cnc::default`].
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Cnc {
    /// Interpolation cycle time (default 4 ms).
    pub cycle_time: Time,
    /// Blocks the look-ahead sees (default 10).
    pub look_ahead: usize,
    /// Contour tolerance (default 0.01 mm).
    pub contour_tolerance: Length,
    /// Share of the acceleration given to curvature, 0…1 (default 0.5).
    pub curvature_accel_share: f64,
    /// Tangential acceleration limit (default none).
    pub tangential_accel: Option<LinearAcceleration>,
    /// Tangential jerk limit (default none).
    pub tangential_jerk: Option<LinearJerk>,
    /// Smallest programmable feed (default 1 mm/min).
    pub feed_min: Feed,
    /// Largest programmable feed (default: the largest linear-axis `vmax`).
    pub feed_max: Option<Feed>,
    /// The spindle's largest speed (default none: not checked).
    pub spindle_max: Option<SpindleSpeed>,
}

impl Default for Cnc {
    fn default() -> Self {
        Cnc {
            cycle_time: Time(0.004),
            look_ahead: 10,
            contour_tolerance: Length(0.01),
            curvature_accel_share: 0.5,
            tangential_accel: None,
            tangential_jerk: None,
            feed_min: Feed(1.0),
            feed_max: None,
            spindle_max: None,
        }
    }
}

/// `policy:`. Every key may be left out; the defaults are those of [`Policy::default`].
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Policy {
    /// `closest`, `{positive: LETTER}` or `{negative: LETTER}` (default `closest`).
    pub branch: Branch,
    /// `whole-path` (default) or `greedy`.
    pub choice: Choice,
    /// Singular cone half-angle (default 0.5 deg).
    pub singular_cone: Angle,
    /// Within this angle of the pole a branch change between two feed points is a pole passage
    /// (default: the singular cone).
    pub pole_passage: Option<Angle>,
    /// Largest continuous rotary step (default 30 deg).
    pub max_rotary_step: Angle,
    /// `error` (default) or `{retract: LENGTH}`.
    pub on_discontinuity: OnDiscontinuity,
    /// Largest tool-tip deviation (default 0.01 mm).
    pub linearization_tolerance: Length,
    /// Turns an endless rotary axis may wind before it is unwound at a rapid: `N turns`, a bare
    /// number of turns, or `off` (default [`DEFAULT_UNWIND_TURNS`] turns).
    pub unwind: Unwind,
    /// A feed move before any feed is programmed: `error` (default) or `rapid` (written as a
    /// rapid, with a warning).
    pub missing_feed: MissingFeed,
}

/// `missing_feed:`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MissingFeed {
    /// An error naming the line.
    #[default]
    Error,
    /// A rapid, with a warning.
    Rapid,
}

/// The turns an endless rotary axis may wind from its home position by default.
pub const DEFAULT_UNWIND_TURNS: f64 = 2.0;

impl Default for Policy {
    fn default() -> Self {
        Policy {
            branch: Branch::Closest,
            choice: Choice::WholePath,
            singular_cone: Angle(0.5f64.to_radians()),
            pole_passage: None,
            max_rotary_step: Angle(30f64.to_radians()),
            on_discontinuity: OnDiscontinuity::Error,
            linearization_tolerance: Length(0.01),
            unwind: Unwind::Turns(DEFAULT_UNWIND_TURNS),
            missing_feed: MissingFeed::Error,
        }
    }
}

/// `unwind:`: `off`, or a number of turns (`2 turns`, `1 turn`, or a bare number).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unwind {
    /// `off`: an endless axis winds without limit.
    Off,
    /// Turns allowed before unwinding (checked to be above 0 by the validation).
    Turns(f64),
}

impl<'de> Deserialize<'de> for Unwind {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct UnwindVisitor;
        impl<'de> Visitor<'de> for UnwindVisitor {
            type Value = Unwind;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("`off` or a number of turns such as `2 turns`")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Unwind, E> {
                let v = v.trim();
                if v == "off" {
                    return Ok(Unwind::Off);
                }
                let number = v.strip_suffix("turns").or_else(|| v.strip_suffix("turn")).unwrap_or(v);
                match number.trim().parse::<f64>() {
                    Ok(turns) if turns.is_finite() => Ok(Unwind::Turns(turns)),
                    _ => Err(E::invalid_value(de::Unexpected::Str(v), &self)),
                }
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Unwind, E> {
                Ok(Unwind::Turns(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Unwind, E> {
                Ok(Unwind::Turns(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Unwind, E> {
                Ok(Unwind::Turns(v as f64))
            }
        }
        deserializer.deserialize_any(UnwindVisitor)
    }
}

/// `choice:`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Choice {
    /// Dynamic programming over the whole path.
    #[default]
    WholePath,
    /// Point by point.
    Greedy,
}

/// `branch:`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Branch {
    /// `closest`.
    #[default]
    Closest,
    /// `{positive: LETTER}`.
    Positive(String),
    /// `{negative: LETTER}`.
    Negative(String),
}

/// The key of `branch: {positive: …}`.
#[derive(Deserialize)]
#[serde(rename_all = "kebab-case")]
enum BranchKey {
    Positive,
    Negative,
}

impl<'de> Deserialize<'de> for Branch {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct BranchVisitor;
        impl<'de> Visitor<'de> for BranchVisitor {
            type Value = Branch;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("`closest`, `{positive: LETTER}` or `{negative: LETTER}`")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Branch, E> {
                if v == "closest" { Ok(Branch::Closest) } else { Err(E::invalid_value(de::Unexpected::Str(v), &self)) }
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Branch, A::Error> {
                let Some(key) = map.next_key::<BranchKey>()? else {
                    return Err(de::Error::invalid_length(0, &self));
                };
                let letter: String = map.next_value()?;
                if map.next_key::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(2, &self));
                }
                Ok(match key {
                    BranchKey::Positive => Branch::Positive(letter),
                    BranchKey::Negative => Branch::Negative(letter),
                })
            }
        }
        deserializer.deserialize_any(BranchVisitor)
    }
}

/// `on_discontinuity:`.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum OnDiscontinuity {
    /// `error`.
    #[default]
    Error,
    /// `{retract: LENGTH}`.
    Retract(Length),
}

/// The key of `on_discontinuity: {retract: …}`.
#[derive(Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RetractKey {
    Retract,
}

impl<'de> Deserialize<'de> for OnDiscontinuity {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct OnDiscontinuityVisitor;
        impl<'de> Visitor<'de> for OnDiscontinuityVisitor {
            type Value = OnDiscontinuity;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("`error` or `{retract: LENGTH}`")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<OnDiscontinuity, E> {
                if v == "error" {
                    Ok(OnDiscontinuity::Error)
                } else {
                    Err(E::invalid_value(de::Unexpected::Str(v), &self))
                }
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<OnDiscontinuity, A::Error> {
                let Some(RetractKey::Retract) = map.next_key::<RetractKey>()? else {
                    return Err(de::Error::invalid_length(0, &self));
                };
                let clearance: Length = map.next_value()?;
                if map.next_key::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(2, &self));
                }
                Ok(OnDiscontinuity::Retract(clearance))
            }
        }
        deserializer.deserialize_any(OnDiscontinuityVisitor)
    }
}

/// `clearance:`.
#[derive(Clone, Debug, PartialEq)]
pub enum Clearance {
    /// `{safe_z: LENGTH}`: a machine coordinate of the linear axis along the spindle.
    SafeZ(Length),
    /// `{retract: LENGTH}`: a distance along the tool axis.
    Retract(Length),
}

/// The key of `clearance: {…}`.
#[derive(Deserialize)]
#[serde(rename_all = "snake_case")]
enum ClearanceKey {
    SafeZ,
    Retract,
}

impl<'de> Deserialize<'de> for Clearance {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct ClearanceVisitor;
        impl<'de> Visitor<'de> for ClearanceVisitor {
            type Value = Clearance;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("`{safe_z: LENGTH}` or `{retract: LENGTH}`")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Clearance, A::Error> {
                Ok(match one_entry(map, &self)? {
                    (ClearanceKey::SafeZ, z) => Clearance::SafeZ(z),
                    (ClearanceKey::Retract, d) => Clearance::Retract(d),
                })
            }
        }
        deserializer.deserialize_map(ClearanceVisitor)
    }
}

/// The one `key: value` entry of a mapping such as `{retract: 50 mm}`; none or more is an error
/// saying what was `expected`.
fn one_entry<'de, A, K, V>(mut map: A, expected: &dyn de::Expected) -> Result<(K, V), A::Error>
where
    A: MapAccess<'de>,
    K: Deserialize<'de>,
    V: Deserialize<'de>,
{
    let Some(key) = map.next_key::<K>()? else {
        return Err(de::Error::invalid_length(0, expected));
    };
    let value = map.next_value::<V>()?;
    if map.next_key::<de::IgnoredAny>()?.is_some() {
        return Err(de::Error::invalid_length(2, expected));
    }
    Ok((key, value))
}

/// `units:` of a machine or a set-up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// `mm`.
    #[default]
    Mm,
    /// `inch`.
    Inch,
}

impl From<Units> for crate::model::ProgramUnits {
    fn from(u: Units) -> Self {
        match u {
            Units::Mm => crate::model::ProgramUnits::Mm,
            Units::Inch => crate::model::ProgramUnits::Inch,
        }
    }
}

impl MachineFile {
    /// Deserializes a definition (no semantic checks; see [`crate::validate`]).
    pub fn from_yaml(text: &str) -> Result<MachineFile, serde_yaml::Error> {
        serde_yaml::from_str(text)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    #[test]
    fn branch_forms() {
        assert_eq!(serde_yaml::from_str::<Branch>("closest").unwrap(), Branch::Closest);
        assert_eq!(serde_yaml::from_str::<Branch>("{positive: B}").unwrap(), Branch::Positive("B".into()));
        assert_eq!(serde_yaml::from_str::<Branch>("negative: A").unwrap(), Branch::Negative("A".into()));
        let e = serde_yaml::from_str::<Branch>("{positve: B}").unwrap_err().to_string();
        assert!(e.contains("unknown variant `positve`, expected `positive` or `negative`"), "{e}");
        assert!(serde_yaml::from_str::<Branch>("nearest").is_err());
    }

    #[test]
    fn discontinuity_forms() {
        assert_eq!(serde_yaml::from_str::<OnDiscontinuity>("error").unwrap(), OnDiscontinuity::Error);
        assert_eq!(
            serde_yaml::from_str::<OnDiscontinuity>("{retract: 5 mm}").unwrap(),
            OnDiscontinuity::Retract(Length(5.0))
        );
        assert!(serde_yaml::from_str::<OnDiscontinuity>("{retract: 5 deg}").is_err());
    }

    #[test]
    fn clearance_forms() {
        assert_eq!(serde_yaml::from_str::<Clearance>("{safe_z: 0.5 m}").unwrap(), Clearance::SafeZ(Length(500.0)));
        assert_eq!(serde_yaml::from_str::<Clearance>("retract: 2 in").unwrap(), Clearance::Retract(Length(50.8)));
        let e = serde_yaml::from_str::<Clearance>("{safe-z: 5}").unwrap_err().to_string();
        assert!(e.contains("unknown variant `safe-z`, expected `safe_z` or `retract`"), "{e}");
        assert!(serde_yaml::from_str::<Clearance>("{safe_z: 5, retract: 5}").is_err());
        assert!(serde_yaml::from_str::<Clearance>("{}").is_err());
        assert!(serde_yaml::from_str::<Clearance>("safe_z").is_err());
        assert!(serde_yaml::from_str::<Clearance>("{retract: 5 deg}").is_err());
    }

    #[test]
    fn units_forms() {
        assert_eq!(serde_yaml::from_str::<Units>("inch").unwrap(), Units::Inch);
        let e = serde_yaml::from_str::<Units>("inches").unwrap_err().to_string();
        assert!(e.contains("unknown variant `inches`, expected `mm` or `inch`"), "{e}");
    }

    #[test]
    fn unwind_forms() {
        assert_eq!(serde_yaml::from_str::<Unwind>("off").unwrap(), Unwind::Off);
        assert_eq!(serde_yaml::from_str::<Unwind>("2 turns").unwrap(), Unwind::Turns(2.0));
        assert_eq!(serde_yaml::from_str::<Unwind>("1 turn").unwrap(), Unwind::Turns(1.0));
        assert_eq!(serde_yaml::from_str::<Unwind>("1.5turns").unwrap(), Unwind::Turns(1.5));
        assert_eq!(serde_yaml::from_str::<Unwind>("3").unwrap(), Unwind::Turns(3.0));
        let e = serde_yaml::from_str::<Unwind>("2 rev").unwrap_err().to_string();
        assert!(e.contains("expected `off` or a number of turns such as `2 turns`"), "{e}");
        assert!(serde_yaml::from_str::<Unwind>("never").is_err());
        assert!(serde_yaml::from_str::<Unwind>("[1]").is_err());
    }

    #[test]
    fn travel_forms() {
        assert_eq!(serde_yaml::from_str::<Travel>("endless").unwrap(), Travel::Endless);
        assert!(matches!(serde_yaml::from_str::<Travel>("[-1 m, 1 m]").unwrap(), Travel::Limited(..)));
        assert!(serde_yaml::from_str::<Travel>("[1, 2, 3]").is_err());
        assert!(serde_yaml::from_str::<Travel>("[1]").is_err());
        assert!(serde_yaml::from_str::<Travel>("forever").is_err());
    }
}
