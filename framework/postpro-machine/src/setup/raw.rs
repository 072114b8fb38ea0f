//! The set-up file as plain serde types, key for key (`docs/setup.md`). Every key may be left
//! out; unknown keys are errors. Lengths are checked while they deserialize
//! ([`crate::quantity`]); the rest by [`super::parse_setup`], the one conversion into
//! [`super::Setup`].

use serde::Deserialize;

use crate::quantity::Length;
use crate::raw::Units;

/// One set-up file.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetupFile {
    /// `G54`, `G54.1 P7`, `G505`, `G59.3`, `preset 3`…
    #[serde(default)]
    pub work_offset: Option<String>,
    /// `[x, y, z]`: the part zero relative to the machine's rotation reference.
    #[serde(default)]
    pub part_origin: Option<[Length; 3]>,
    /// `[x, y, z]`: the work offset's position in machine coordinates.
    #[serde(default)]
    pub work_offset_at: Option<[Length; 3]>,
    /// `mm` or `inch`: the program's units.
    #[serde(default)]
    pub units: Option<Units>,
    /// The tool table's path, relative to the set-up file.
    #[serde(default)]
    pub tool_table: Option<String>,
}

impl SetupFile {
    /// Deserializes a set-up (no semantic checks). An empty file (or one with only comments)
    /// is a set-up that says nothing.
    pub fn from_yaml(text: &str) -> Result<SetupFile, serde_yaml::Error> {
        Ok(serde_yaml::from_str::<Option<SetupFile>>(text)?.unwrap_or_default())
    }
}
