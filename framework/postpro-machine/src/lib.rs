//! # postpro-machine: machine definitions
//!
//! A machine is described in a YAML file (`docs/machine-defs.md` is the reference of every key).
//! The file goes through three layers, each a module:
//!
//! 1. [`raw`]: plain serde types mirroring the file key for key (unknown keys are errors);
//!    [`quantity`] checks each value's unit and dimension while it deserializes, so the YAML
//!    library attaches its line and column;
//! 2. [`validate`]: the one conversion into the [`model`], with every semantic check, each error
//!    pointing at the offending value;
//! 3. [`model`]: the validated [`Machine`] (mm, rad, s) that kinematics and prediction code
//!    against. They never see the serde types.
//!
//! [`Registry`] holds the built-in machines and the user's files, found by name or alias; a file
//! that does not load is [`Skipped`] with its diagnostic, and a name two definitions claim is
//! refused as ambiguous.
//!
//! Two more file formats describe a job rather than a machine, read the same way (plain serde
//! types, one validating conversion, errors at the value): the [`setup`] (work offset, part
//! origin, units, tool table; `docs/setup.md`) and the [`tools`] table (YAML or CSV).
//!
//! Every error is a [`MachineError`], which miette renders with the file, the source line, a
//! caret on the value and what was expected.
//!
//! ```
//! use postpro_machine::{Registry, model::Topology};
//! let registry = Registry::builtin().unwrap();
//! let mikron = &registry.find("mikron").unwrap().machine;
//! assert_eq!(mikron.topology(), Topology::TableTable);
//! assert!(registry.find("mikorn").unwrap_err().to_string().contains("did you mean `mikron`"));
//! ```

mod error;
#[macro_use]
mod locate;
pub mod model;
pub mod quantity;
pub mod raw;
mod registry;
pub mod setup;
pub mod tools;
pub mod validate;

pub use error::{ClashError, DefinitionError, FileKind, MachineError, Skipped};
pub use model::Machine;
pub use registry::{BUILTIN, Entry, Origin, Registry};

use error::Doc;

/// Reads and validates one definition; `file` is the name shown in errors.
pub fn parse(file: &str, text: &str) -> Result<Machine, MachineError> {
    let raw = parse_raw(file, text)?;
    validate::validate(&raw, file, text)
}

/// Reads one definition into the file format, without the semantic checks.
pub fn parse_raw(file: &str, text: &str) -> Result<raw::MachineFile, MachineError> {
    raw::MachineFile::from_yaml(text).map_err(|e| Doc::new(file, text).yaml_error(&e))
}
