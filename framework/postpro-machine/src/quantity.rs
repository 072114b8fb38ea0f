//! Physical quantities in machine definitions: a bare number in the key's base unit, or a string
//! `"<number> <unit>"`.
//!
//! | dimension | base unit (bare number) | units |
//! | --- | --- | --- |
//! | length | mm | `mm`, `m`, `in` |
//! | angle | deg | `deg`, `rad`, `rev` |
//! | velocity | mm/s, deg/s (feeds: mm/min) | `<length or angle>/s`, `<length or angle>/min`, `rpm` |
//! | acceleration | mm/s², deg/s² | `<length or angle>/s^2` (or `/s²`, `/min^2`) |
//! | jerk | mm/s³, deg/s³ | `<length or angle>/s^3` (or `/s³`, `/min^3`) |
//! | time | s | `s`, `ms` |
//!
//! The unit is checked against the **dimension** the key expects, and the value is converted to
//! the model's units (mm, rad, s; feeds in mm/min). The checks run while deserializing, in the
//! `Deserialize` impls of the wrapper types below, so that the YAML library attaches the
//! value's line and column to the error.
//!
//! Axis values (`travel`, `home`, `vmax`, `amax`, `jmax`) are linear or angular depending on the
//! axis `kind`, which the deserializer may not have seen yet: they deserialize into
//! [`AxisQuantity`], which checks the unit and the time power (a velocity is a velocity) and keeps
//! the number and unit; the validation converts them once the kind is known.

use std::f64::consts::PI;
use std::fmt;

use serde::de::{self, Deserializer, Visitor};

/// What a unit measures: a length, an angle or a time, divided by a power of time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dimension {
    /// mm, m, in.
    Length,
    /// deg, rad, rev.
    Angle,
    /// s, ms.
    Time,
    /// Length per time.
    LinearVelocity,
    /// Angle per time.
    AngularVelocity,
    /// Length per time².
    LinearAcceleration,
    /// Angle per time².
    AngularAcceleration,
    /// Length per time³.
    LinearJerk,
    /// Angle per time³.
    AngularJerk,
}

impl Dimension {
    /// The dimension with a length (`linear`) or an angle over time to the power `power` (0…3).
    pub fn of(linear: bool, power: u8) -> Option<Dimension> {
        Some(match (linear, power) {
            (true, 0) => Dimension::Length,
            (false, 0) => Dimension::Angle,
            (true, 1) => Dimension::LinearVelocity,
            (false, 1) => Dimension::AngularVelocity,
            (true, 2) => Dimension::LinearAcceleration,
            (false, 2) => Dimension::AngularAcceleration,
            (true, 3) => Dimension::LinearJerk,
            (false, 3) => Dimension::AngularJerk,
            _ => return None,
        })
    }

    /// The name with its article: `a linear velocity`.
    pub fn name(self) -> &'static str {
        match self {
            Dimension::Length => "a length",
            Dimension::Angle => "an angle",
            Dimension::Time => "a time",
            Dimension::LinearVelocity => "a linear velocity",
            Dimension::AngularVelocity => "an angular velocity",
            Dimension::LinearAcceleration => "a linear acceleration",
            Dimension::AngularAcceleration => "an angular acceleration",
            Dimension::LinearJerk => "a linear jerk",
            Dimension::AngularJerk => "an angular jerk",
        }
    }

    /// Two typical values: `` `0.5 m/s` or `30 m/min` ``.
    pub fn examples(self) -> &'static str {
        match self {
            Dimension::Length => "`250 mm` or `0.25 m`",
            Dimension::Angle => "`90 deg` or `1.57 rad`",
            Dimension::Time => "`4 ms` or `0.004 s`",
            Dimension::LinearVelocity => "`0.5 m/s` or `30 m/min`",
            Dimension::AngularVelocity => "`90 deg/s` or `20 rpm`",
            Dimension::LinearAcceleration => "`2.5 m/s^2`",
            Dimension::AngularAcceleration => "`1 rev/s^2`",
            Dimension::LinearJerk => "`50 m/s^3`",
            Dimension::AngularJerk => "`10 rev/s^3`",
        }
    }

    /// The unit of a bare number for this dimension (`mm/s`).
    pub fn base_unit(self) -> &'static str {
        match self {
            Dimension::Length => "mm",
            Dimension::Angle => "deg",
            Dimension::Time => "s",
            Dimension::LinearVelocity => "mm/s",
            Dimension::AngularVelocity => "deg/s",
            Dimension::LinearAcceleration => "mm/s^2",
            Dimension::AngularAcceleration => "deg/s^2",
            Dimension::LinearJerk => "mm/s^3",
            Dimension::AngularJerk => "deg/s^3",
        }
    }

    /// What a bare number in the base unit is worth in model units (mm, rad, s).
    fn base_factor(self) -> f64 {
        match self {
            Dimension::Angle | Dimension::AngularVelocity | Dimension::AngularAcceleration | Dimension::AngularJerk => {
                PI / 180.0
            }
            _ => 1.0,
        }
    }

    /// `expected a linear velocity such as `0.5 m/s` or `30 m/min` (a bare number is in mm/s)`.
    pub fn expected(self) -> String {
        format!("expected {} such as {} (a bare number is in {})", self.name(), self.examples(), self.base_unit())
    }
}

impl fmt::Display for Dimension {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A unit as written, with its dimension and its worth in model units (mm, rad, s, and their
/// quotients by s, s², s³): one unit is `factor / divisor` model units.
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    /// The unit as written (`m/min`).
    pub symbol: String,
    /// What it measures.
    pub dimension: Dimension,
    /// The numerator's worth (`m`: 1000).
    pub factor: f64,
    /// The denominator's worth (`min`: 60; `min^2`: 3600).
    pub divisor: f64,
}

impl Unit {
    /// `number` of this unit in model units (multiplied before dividing: `30 m/min` is exactly
    /// 500 mm/s).
    pub fn to_model(&self, number: f64) -> f64 {
        number * self.factor / self.divisor
    }
}

impl Unit {
    /// Parses a unit symbol: `mm`, `m`, `in`, `deg`, `rad`, `rev`, `s`, `ms`, `rpm`, or a length
    /// or angle unit over `s` or `min`, with `^2`/`²` or `^3`/`³` for accelerations and jerks.
    pub fn parse(symbol: &str) -> Option<Unit> {
        let (dimension, factor, divisor) = match symbol {
            "s" => (Dimension::Time, 1.0, 1.0),
            "ms" => (Dimension::Time, 1.0, 1000.0),
            "rpm" => (Dimension::AngularVelocity, 2.0 * PI, 60.0),
            _ => {
                let (num, den) = match symbol.split_once('/') {
                    Some((n, d)) => (n, Some(d)),
                    None => (symbol, None),
                };
                let (linear, num_factor) = match num {
                    "mm" => (true, 1.0),
                    "m" => (true, 1000.0),
                    "in" => (true, 25.4),
                    "deg" => (false, PI / 180.0),
                    "rad" => (false, 1.0),
                    "rev" => (false, 2.0 * PI),
                    _ => return None,
                };
                let (power, den_factor) = match den {
                    None => (0, 1.0),
                    Some(d) => {
                        let (time, power): (&str, u8) =
                            if let Some(t) = d.strip_suffix("^2").or_else(|| d.strip_suffix('²')) {
                                (t, 2)
                            } else if let Some(t) = d.strip_suffix("^3").or_else(|| d.strip_suffix('³')) {
                                (t, 3)
                            } else {
                                (d, 1)
                            };
                        let seconds: f64 = match time {
                            "s" => 1.0,
                            "min" => 60.0,
                            _ => return None,
                        };
                        (power, seconds.powi(i32::from(power)))
                    }
                };
                (Dimension::of(linear, power)?, num_factor, den_factor)
            }
        };
        Some(Unit { symbol: symbol.to_string(), dimension, factor, divisor })
    }
}

/// A quantity as written: a number and its unit, if any.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    /// The number.
    pub number: f64,
    /// The unit; `None` for a bare number (in the key's base unit).
    pub unit: Option<Unit>,
}

/// What is wrong with a quantity, before the key's expectation is added.
#[derive(Clone, Debug, PartialEq)]
pub enum QuantityError {
    /// Not `<number> [unit]`.
    NotAQuantity(String),
    /// The number is infinite or NaN.
    NotFinite(String),
    /// An unknown unit symbol.
    UnknownUnit(String),
    /// A known unit of the wrong dimension.
    WrongDimension {
        /// The value as written.
        text: String,
        /// Its dimension.
        found: Dimension,
    },
}

impl QuantityError {
    /// What is wrong: ``unknown unit `m/sec` ``.
    pub fn message(&self) -> String {
        match self {
            QuantityError::NotAQuantity(t) => format!("`{t}` is not a number with a unit"),
            QuantityError::NotFinite(t) => format!("`{t}` is not a finite number"),
            QuantityError::UnknownUnit(u) => format!("unknown unit `{u}`"),
            QuantityError::WrongDimension { text, found } => format!("`{text}` is {found}"),
        }
    }

    /// The message with what was expected: `unknown unit `m/sec`, expected a linear velocity …`.
    pub fn with_expected(&self, expected: &str) -> String {
        format!("{}, {expected}", self.message())
    }
}

/// Splits `"<number> <unit>"` (the space is optional: `10mm` reads too).
pub fn parse_written(text: &str) -> Result<Written, QuantityError> {
    let t = text.trim();
    let bytes = t.as_bytes();
    let mut end = 0;
    while end < bytes.len() {
        let c = bytes[end];
        let is_number_char = c.is_ascii_digit()
            || c == b'.'
            || ((c == b'+' || c == b'-') && (end == 0 || matches!(bytes[end - 1], b'e' | b'E')))
            || (matches!(c, b'e' | b'E')
                && end > 0
                && bytes.get(end + 1).is_some_and(|n| n.is_ascii_digit() || *n == b'+' || *n == b'-'));
        if !is_number_char {
            break;
        }
        end += 1;
    }
    let number: f64 = t[..end].parse().map_err(|_| QuantityError::NotAQuantity(t.to_string()))?;
    if !number.is_finite() {
        return Err(QuantityError::NotFinite(t.to_string()));
    }
    let symbol = t[end..].trim();
    if symbol.is_empty() {
        return Ok(Written { number, unit: None });
    }
    let unit = Unit::parse(symbol).ok_or_else(|| QuantityError::UnknownUnit(symbol.to_string()))?;
    Ok(Written { number, unit: Some(unit) })
}

impl Written {
    /// The value in model units for a key that expects `dimension` (a bare number is in the
    /// dimension's base unit).
    pub fn to_model(&self, dimension: Dimension, text: &str) -> Result<f64, QuantityError> {
        match &self.unit {
            None => Ok(self.number * dimension.base_factor()),
            Some(u) if u.dimension == dimension => Ok(u.to_model(self.number)),
            Some(u) => Err(QuantityError::WrongDimension { text: text.trim().to_string(), found: u.dimension }),
        }
    }
}

/// Parses `text` as a quantity of `dimension`, in model units (mm, rad, s).
pub fn parse(text: &str, dimension: Dimension) -> Result<f64, QuantityError> {
    parse_written(text)?.to_model(dimension, text)
}

/// Reads a number or `"<number> <unit>"` and converts it, inside the YAML library's visit of the
/// scalar, so that an error carries the scalar's location.
struct QuantityVisitor<'a, F> {
    expected: &'a str,
    convert: F,
}

impl<T, F: FnOnce(Written, &str) -> Result<T, QuantityError>> QuantityVisitor<'_, F> {
    fn finish<E: de::Error>(self, written: Result<Written, QuantityError>, text: &str) -> Result<T, E> {
        written.and_then(|w| (self.convert)(w, text)).map_err(|e| E::custom(e.with_expected(self.expected)))
    }

    fn number<E: de::Error>(self, n: f64) -> Result<T, E> {
        let text = n.to_string();
        let written = if n.is_finite() {
            Ok(Written { number: n, unit: None })
        } else {
            Err(QuantityError::NotFinite(text.clone()))
        };
        self.finish(written, &text)
    }
}

impl<T, F: FnOnce(Written, &str) -> Result<T, QuantityError>> Visitor<'_> for QuantityVisitor<'_, F> {
    type Value = T;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // serde's messages read `invalid type: …, expected <this>`.
        f.write_str(self.expected.strip_prefix("expected ").unwrap_or(self.expected))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<T, E> {
        self.number(v as f64)
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<T, E> {
        self.number(v as f64)
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<T, E> {
        self.number(v)
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<T, E> {
        self.finish(parse_written(v), v)
    }
}

/// Deserializes a number or `"<number> <unit>"` and converts it with `convert`.
fn deserialize_with<'de, D, T>(
    deserializer: D,
    expected: &str,
    convert: impl FnOnce(Written, &str) -> Result<T, QuantityError>,
) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
{
    deserializer.deserialize_any(QuantityVisitor { expected, convert })
}

/// Deserializes a quantity of one dimension, in model units.
fn deserialize_model<'de, D: Deserializer<'de>>(deserializer: D, dimension: Dimension) -> Result<f64, D::Error> {
    deserialize_with(deserializer, &dimension.expected(), |w, text| w.to_model(dimension, text))
}

macro_rules! fixed_quantity {
    ($(#[$doc:meta])* $name:ident, $dimension:expr) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct $name(pub f64);

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                deserialize_model(deserializer, $dimension).map($name)
            }
        }
    };
}

fixed_quantity!(
    /// A length, in mm (bare numbers: mm).
    Length,
    Dimension::Length
);
fixed_quantity!(
    /// An angle, in rad (bare numbers: degrees).
    Angle,
    Dimension::Angle
);
fixed_quantity!(
    /// A time, in s (bare numbers: s).
    Time,
    Dimension::Time
);
fixed_quantity!(
    /// A path acceleration, in mm/s² (bare numbers: mm/s²).
    LinearAcceleration,
    Dimension::LinearAcceleration
);
fixed_quantity!(
    /// A path jerk, in mm/s³ (bare numbers: mm/s³).
    LinearJerk,
    Dimension::LinearJerk
);

/// A feed, in mm/min (bare numbers: mm/min).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Feed(pub f64);

impl Feed {
    /// What a key expecting a feed expects.
    pub fn expected() -> String {
        "expected a feed (a linear velocity) such as `10 m/min` or `5000 mm/min` (a bare number is in mm/min)".into()
    }
}

impl<'de> serde::Deserialize<'de> for Feed {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        // A bare feed is in mm/min, the unit of the model. Multiplied before dividing: `10 m/min`
        // is exactly 10000 mm/min.
        let convert = |u: &Unit, number: f64| number * u.factor * 60.0 / u.divisor;
        deserialize_in(deserializer, &Feed::expected(), Dimension::LinearVelocity, convert).map(Feed)
    }
}

/// Deserializes a quantity of `dimension` held in a unit of its own: a bare number is in that
/// unit, a number with a unit is converted by `convert`.
fn deserialize_in<'de, D: Deserializer<'de>>(
    deserializer: D,
    expected: &str,
    dimension: Dimension,
    convert: impl FnOnce(&Unit, f64) -> f64,
) -> Result<f64, D::Error> {
    deserialize_with(deserializer, expected, |written, text| match &written.unit {
        None => Ok(written.number),
        Some(u) if u.dimension == dimension => Ok(convert(u, written.number)),
        Some(u) => Err(QuantityError::WrongDimension { text: text.trim().to_string(), found: u.dimension }),
    })
}

/// A spindle speed, in rpm (bare numbers: rpm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpindleSpeed(pub f64);

impl SpindleSpeed {
    /// What a key expecting a spindle speed expects.
    pub fn expected() -> String {
        "expected a spindle speed (an angular velocity) such as `8100 rpm` (a bare number is in rpm)".into()
    }
}

impl<'de> serde::Deserialize<'de> for SpindleSpeed {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        // rad/s in the model's units, then revolutions per minute.
        let convert = |u: &Unit, number: f64| u.to_model(number) * 60.0 / (2.0 * PI);
        deserialize_in(deserializer, &SpindleSpeed::expected(), Dimension::AngularVelocity, convert).map(SpindleSpeed)
    }
}

/// An axis value whose dimension depends on the axis kind: a length for a linear axis, an angle
/// for a rotary one, over time to the power `P` (0: position, 1: velocity, 2: acceleration,
/// 3: jerk). Deserializing checks the unit and the power; [`AxisQuantity::to_model`] checks the
/// kind and converts.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisQuantity<const P: u8> {
    /// The number and unit as written.
    pub written: Written,
    /// The value as written (for messages).
    pub text: String,
}

/// The family name of an axis value of time power `p`: `a length or an angle`.
fn family(p: u8) -> &'static str {
    match p {
        0 => "a length or an angle",
        1 => "a linear or angular velocity",
        2 => "a linear or angular acceleration",
        _ => "a linear or angular jerk",
    }
}

impl<const P: u8> AxisQuantity<P> {
    /// What the key expects when the axis kind is not known yet.
    pub fn expected_any() -> String {
        let (lin, ang) = (Dimension::of(true, P), Dimension::of(false, P));
        match (lin, ang) {
            (Some(l), Some(a)) => format!(
                "expected {} such as {} or {}",
                family(P),
                l.examples().split(" or ").next().unwrap_or_default(),
                a.examples().split(" or ").last().unwrap_or_default()
            ),
            _ => format!("expected {}", family(P)),
        }
    }

    /// The dimension this value must have on a linear (`true`) or rotary axis.
    pub fn dimension(linear: bool) -> Dimension {
        Dimension::of(linear, P).unwrap_or(Dimension::Length)
    }

    /// The value in model units (mm or rad, over s^P) on a linear (`true`) or rotary axis; the
    /// error says what was expected.
    pub fn to_model(&self, linear: bool) -> Result<f64, String> {
        let dimension = Self::dimension(linear);
        self.written.to_model(dimension, &self.text).map_err(|e| e.with_expected(&dimension.expected()))
    }
}

impl<'de, const P: u8> serde::Deserialize<'de> for AxisQuantity<P> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserialize_with(deserializer, &Self::expected_any(), |written, text| {
            if let Some(u) = &written.unit {
                let fits = Dimension::of(true, P) == Some(u.dimension) || Dimension::of(false, P) == Some(u.dimension);
                if !fits {
                    return Err(QuantityError::WrongDimension { text: text.trim().to_string(), found: u.dimension });
                }
            }
            Ok(AxisQuantity { written, text: text.to_string() })
        })
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1.0)
    }

    #[test]
    fn lengths() {
        assert!(close(parse("250 mm", Dimension::Length).unwrap(), 250.0));
        assert!(close(parse("0.25 m", Dimension::Length).unwrap(), 250.0));
        assert!(close(parse("2 in", Dimension::Length).unwrap(), 50.8));
        assert!(close(parse("-1.5e2mm", Dimension::Length).unwrap(), -150.0));
        assert!(close(parse("12", Dimension::Length).unwrap(), 12.0));
    }

    #[test]
    fn angles() {
        assert!(close(parse("90 deg", Dimension::Angle).unwrap(), PI / 2.0));
        assert!(close(parse("1 rad", Dimension::Angle).unwrap(), 1.0));
        assert!(close(parse("0.5 rev", Dimension::Angle).unwrap(), PI));
        assert!(close(parse("180", Dimension::Angle).unwrap(), PI));
    }

    #[test]
    fn velocities_accelerations_jerks() {
        assert!(close(parse("0.5 m/s", Dimension::LinearVelocity).unwrap(), 500.0));
        assert!(close(parse("30 m/min", Dimension::LinearVelocity).unwrap(), 500.0));
        assert!(close(parse("600 mm/min", Dimension::LinearVelocity).unwrap(), 10.0));
        assert!(close(parse("60 rpm", Dimension::AngularVelocity).unwrap(), 2.0 * PI));
        assert!(close(parse("60 rev/min", Dimension::AngularVelocity).unwrap(), 2.0 * PI));
        assert!(close(parse("1 rev/s", Dimension::AngularVelocity).unwrap(), 2.0 * PI));
        assert!(close(parse("180 deg/s", Dimension::AngularVelocity).unwrap(), PI));
        assert!(close(parse("2 rad/s", Dimension::AngularVelocity).unwrap(), 2.0));
        assert!(close(parse("2.5 m/s^2", Dimension::LinearAcceleration).unwrap(), 2500.0));
        assert!(close(parse("2.5 m/s²", Dimension::LinearAcceleration).unwrap(), 2500.0));
        assert!(close(parse("1 rev/s^2", Dimension::AngularAcceleration).unwrap(), 2.0 * PI));
        assert!(close(parse("5 m/s^3", Dimension::LinearJerk).unwrap(), 5000.0));
        assert!(close(parse("5 m/s³", Dimension::LinearJerk).unwrap(), 5000.0));
        assert!(close(parse("10 deg/s^3", Dimension::AngularJerk).unwrap(), 10.0 * PI / 180.0));
        assert!(close(parse("3600 mm/min^2", Dimension::LinearAcceleration).unwrap(), 1.0));
    }

    #[test]
    fn times() {
        assert!(close(parse("3 ms", Dimension::Time).unwrap(), 0.003));
        assert!(close(parse("0.5 s", Dimension::Time).unwrap(), 0.5));
    }

    #[test]
    fn errors() {
        assert_eq!(parse("0.5 m/sec", Dimension::LinearVelocity), Err(QuantityError::UnknownUnit("m/sec".into())));
        assert_eq!(parse("fast", Dimension::LinearVelocity), Err(QuantityError::NotAQuantity("fast".into())));
        assert_eq!(parse("m/s", Dimension::LinearVelocity), Err(QuantityError::NotAQuantity("m/s".into())));
        assert_eq!(
            parse("2 m/s^2", Dimension::LinearVelocity),
            Err(QuantityError::WrongDimension { text: "2 m/s^2".into(), found: Dimension::LinearAcceleration })
        );
        assert_eq!(
            parse("20 rpm", Dimension::LinearVelocity),
            Err(QuantityError::WrongDimension { text: "20 rpm".into(), found: Dimension::AngularVelocity })
        );
        assert!(matches!(parse("1 s/m", Dimension::Time), Err(QuantityError::UnknownUnit(_))));
        assert!(matches!(parse("1 mm/s^4", Dimension::LinearJerk), Err(QuantityError::UnknownUnit(_))));
        let msg = parse("0.5 m/sec", Dimension::LinearVelocity)
            .unwrap_err()
            .with_expected(&Dimension::LinearVelocity.expected());
        assert_eq!(
            msg,
            "unknown unit `m/sec`, expected a linear velocity such as `0.5 m/s` or `30 m/min` (a bare number is in mm/s)"
        );
    }

    #[test]
    fn feeds_deserialize_in_mm_per_min() {
        let f: Feed = serde_yaml::from_str("10 m/min").unwrap();
        assert!(close(f.0, 10_000.0));
        let f: Feed = serde_yaml::from_str("500").unwrap();
        assert!(close(f.0, 500.0));
        let f: Feed = serde_yaml::from_str("1 m/s").unwrap();
        assert!(close(f.0, 60_000.0));
        let f: Feed = serde_yaml::from_str("5000 mm/min").unwrap();
        assert_eq!(f.0, 5000.0);
        let f: Feed = serde_yaml::from_str("2 in/min").unwrap();
        assert!(close(f.0, 50.8));
        assert!(serde_yaml::from_str::<Feed>("1 rpm").is_err());
        let rpm = |text: &str| serde_yaml::from_str::<SpindleSpeed>(text).map(|s| s.0);
        assert_eq!(rpm("8100").ok(), Some(8100.0));
        assert!((rpm("8100 rpm").expect("rpm") - 8100.0).abs() < 1e-9);
        assert!((rpm("135 rev/s").expect("rev/s") - 8100.0).abs() < 1e-9);
        assert!(rpm("8100 mm/min").is_err());
    }

    #[test]
    fn axis_quantities_depend_on_the_kind() {
        let v: AxisQuantity<1> = serde_yaml::from_str("10 m/min").unwrap();
        assert!(close(v.to_model(true).unwrap(), 10_000.0 / 60.0));
        assert!(v.to_model(false).is_err());
        let v: AxisQuantity<1> = serde_yaml::from_str("90").unwrap();
        assert!(close(v.to_model(true).unwrap(), 90.0));
        assert!(close(v.to_model(false).unwrap(), PI / 2.0));
        let e = serde_yaml::from_str::<AxisQuantity<1>>("1 m/s^2").unwrap_err().to_string();
        assert!(e.starts_with("`1 m/s^2` is a linear acceleration, expected a linear or angular velocity"), "{e}");
        let p: AxisQuantity<0> = serde_yaml::from_str("-120 deg").unwrap();
        assert!(close(p.to_model(false).unwrap(), -120f64.to_radians()));
    }
}
