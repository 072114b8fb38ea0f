//! The per-job set-up, apart from the machine: the work offset, where the part zero sits, where
//! the work offset is in machine coordinates, the program's units and the tool table
//! (`docs/setup.md` describes every key). A YAML file goes through [`raw`] (plain serde types)
//! and one validating conversion into [`Setup`]; every error points at the offending value
//! with the file's line and column, like those of machine definitions.
//!
//! ```
//! use postpro_machine::setup::{WorkOffset, parse_setup};
//! let text = "work_offset: G54.1 P7\npart_origin: [0, 0, 25 mm]\nunits: inch\n";
//! let setup = parse_setup("job.yaml", text, std::path::Path::new(".")).unwrap();
//! assert_eq!(setup.work_offset, Some(WorkOffset::G54_1(7)));
//! assert_eq!(setup.part_origin.unwrap().z, 25.0);
//! ```

mod offset;
pub mod raw;

use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3};

use crate::error::{Doc, FileKind, MachineError};
use crate::locate::path_text;
pub use crate::model::ProgramUnits;
use crate::tools::ToolTableFormat;
pub use offset::{ACCEPTED as ACCEPTED_WORK_OFFSETS, MAX_G54_1, WorkOffset, WorkOffsetError};

/// One job's set-up; every item is optional (the command line and the machine give defaults).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Setup {
    /// The work offset the program selects.
    pub work_offset: Option<WorkOffset>,
    /// Where the part zero sits relative to the machine's rotation reference (mm), for machines
    /// whose rotary axes carry the part.
    pub part_origin: Option<Vector3<f64>>,
    /// The work offset's position in machine coordinates (mm): only when it is known can the
    /// linear travels be checked.
    pub work_offset_at: Option<Point3<f64>>,
    /// The program's units.
    pub units: Option<ProgramUnits>,
    /// The tool table, resolved against the set-up file's folder.
    pub tool_table: Option<PathBuf>,
}

/// Reads and validates a set-up file; a relative `tool_table` is taken from the file's folder.
pub fn load_setup(path: &Path) -> Result<Setup, MachineError> {
    let text = std::fs::read_to_string(path).map_err(|source| MachineError::Io { path: path.to_path_buf(), source })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    parse_setup(&path.display().to_string(), &text, dir)
}

/// Validates the text of a set-up file; `file` is the name shown in errors and `dir` the folder
/// a relative `tool_table` is taken from (the tool table must exist).
pub fn parse_setup(file: &str, text: &str, dir: &Path) -> Result<Setup, MachineError> {
    let doc = Doc::of(FileKind::Setup, file, text);
    let raw = raw::SetupFile::from_yaml(text).map_err(|e| doc.yaml_error(&e))?;
    let work_offset = match &raw.work_offset {
        None => None,
        Some(text) => Some(text.parse::<WorkOffset>().map_err(|e| {
            let reason = e.reason.map(|r| format!(" ({r})")).unwrap_or_default();
            let at = path!["work_offset"];
            doc.error(
                at,
                format!("{}: `{}` is not a work offset{reason}", path_text(at), e.text),
                format!("expected {}", offset::ACCEPTED),
            )
        })?),
    };
    let vector = |v: &[crate::quantity::Length; 3]| Vector3::new(v[0].0, v[1].0, v[2].0);
    let tool_table = match &raw.tool_table {
        None => None,
        Some(name) => Some(tool_table(&doc, name, dir)?),
    };
    Ok(Setup {
        work_offset,
        part_origin: raw.part_origin.as_ref().map(vector),
        work_offset_at: raw.work_offset_at.as_ref().map(|v| Point3::from(vector(v))),
        units: raw.units.map(ProgramUnits::from),
        tool_table,
    })
}

/// `tool_table`: a `.yaml`, `.yml` or `.csv` file that exists, relative to `dir`.
fn tool_table(doc: &Doc, name: &str, dir: &Path) -> Result<PathBuf, MachineError> {
    let at = path!["tool_table"];
    let fail =
        |message: String, expected: &str| doc.error(at, format!("{}: {message}", path_text(at)), expected.into());
    if name.trim().is_empty() {
        return Err(fail("an empty file name".into(), "expected the tool table's file, relative to this file"));
    }
    let path = dir.join(name);
    if ToolTableFormat::of(&path).is_none() {
        return Err(fail(
            format!("cannot tell the format of the tool table `{name}`"),
            "expected a `.yaml`, `.yml` or `.csv` file",
        ));
    }
    if !path.is_file() {
        return Err(fail(
            format!("no tool table at `{}`", path.display()),
            "expected the tool table's file, relative to this file",
        ));
    }
    Ok(path)
}
