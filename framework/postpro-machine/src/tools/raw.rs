//! The YAML tool table as plain serde types (`docs/setup.md`): a `tools:` list, each tool a
//! mapping that denies unknown keys. Lengths are checked while they deserialize
//! ([`crate::quantity`]; a bare number is in mm), numbers and registers are whole numbers ≥ 1.
//! The CSV reader (`csv.rs`) fills the same [`Tool`]; [`super`] checks both the same way.

use std::fmt;

use serde::Deserialize;
use serde::de::{self, Deserializer, Visitor};

use crate::quantity::Length;

/// One YAML tool table.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolFile {
    /// The tools, in the file's order.
    pub tools: Vec<Tool>,
}

/// One tool, as written.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    /// The tool number (`T`).
    pub number: Positive,
    /// A name or description.
    #[serde(default)]
    pub name: Option<String>,
    /// From the spindle nose (gauge line) to the tip.
    #[serde(default)]
    pub length: Option<Length>,
    /// The cutter radius.
    #[serde(default)]
    pub radius: Option<Length>,
    /// The cutter diameter (instead of `radius`).
    #[serde(default)]
    pub diameter: Option<Length>,
    /// The length offset register (default: the tool number).
    #[serde(default)]
    pub h: Option<Positive>,
    /// The radius offset register (default: the tool number).
    #[serde(default)]
    pub d: Option<Positive>,
}

/// A whole number from 1 to 4294967295 (a tool number or an offset register).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Positive(pub u32);

/// What a [`Positive`] expects.
pub const POSITIVE: &str = "a whole number from 1 to 4294967295";

impl Positive {
    /// Reads one from text (a CSV cell).
    pub fn parse(text: &str) -> Option<Positive> {
        let t = text.trim();
        if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        t.parse().ok().filter(|&n| n > 0).map(Positive)
    }
}

impl<'de> Deserialize<'de> for Positive {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct PositiveVisitor;
        impl Visitor<'_> for PositiveVisitor {
            type Value = Positive;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(POSITIVE)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Positive, E> {
                match u32::try_from(v) {
                    Ok(n) if n > 0 => Ok(Positive(n)),
                    _ => Err(E::invalid_value(de::Unexpected::Unsigned(v), &self)),
                }
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Positive, E> {
                match u64::try_from(v) {
                    Ok(v) => self.visit_u64(v),
                    Err(_) => Err(E::invalid_value(de::Unexpected::Signed(v), &self)),
                }
            }
        }
        deserializer.deserialize_u64(PositiveVisitor)
    }
}

impl ToolFile {
    /// Deserializes a YAML tool table (no semantic checks).
    pub fn from_yaml(text: &str) -> Result<ToolFile, serde_yaml::Error> {
        serde_yaml::from_str(text)
    }
}
