//! The crate's one error type, [`PluginError`]: each error is about one plugin library or one
//! machine of it, names the library, and says what to do about it.

use std::fmt;
use std::path::{Path, PathBuf};

use postpro_machine::MachineError;
use postpro_plugin_api::{ABI_VERSION, Status};

/// How a call into a plugin failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CallFailure {
    /// The plugin panicked (caught at the boundary).
    Panicked,
    /// The plugin reported an error.
    Failed,
    /// The plugin refused the host's arguments.
    RefusedArguments,
    /// The plugin returned a status the ABI does not define.
    UnknownStatus(i32),
}

impl CallFailure {
    /// The failure of a status that is not [`Status::OK`].
    pub fn of(status: Status) -> CallFailure {
        match status {
            Status::PANIC => CallFailure::Panicked,
            Status::INVALID_ARGUMENT => CallFailure::RefusedArguments,
            Status::ERROR | Status::OK => CallFailure::Failed,
            Status(other) => CallFailure::UnknownStatus(other),
        }
    }
}

impl fmt::Display for CallFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CallFailure::Panicked => f.write_str("panicked"),
            CallFailure::Failed => f.write_str("failed"),
            CallFailure::RefusedArguments => f.write_str("refused the arguments"),
            CallFailure::UnknownStatus(s) => write!(f, "returned the unknown status {s}"),
        }
    }
}

/// Everything that can go wrong with a plugin. None of it stops postpro: a library that does not
/// load is skipped, a machine whose definition or kinematics is wrong is reported alone.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum PluginError {
    /// A plugin file or folder that cannot be read.
    #[error("cannot read `{}`", path.display())]
    #[diagnostic(code(plugin::io))]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },

    /// The system cannot load the library.
    #[error("cannot load plugin `{}`: {reason}", library.display())]
    #[diagnostic(
        code(plugin::load),
        help(
            "a plugin is a shared library built for this system (`crate-type = [\"cdylib\"]`, a `.{}` file here)",
            std::env::consts::DLL_EXTENSION
        )
    )]
    Open {
        /// The library.
        library: PathBuf,
        /// The system's reason.
        reason: String,
    },

    /// The library does not export the entry symbol.
    #[error("`{}` is not a postpro plugin: it exports no symbol `{symbol}`", library.display())]
    #[diagnostic(
        code(plugin::symbol),
        help("a plugin exports it with `postpro_plugin_api::export_plugin!` (docs/writing-a-plugin.md)")
    )]
    NotAPlugin {
        /// The library.
        library: PathBuf,
        /// The symbol looked for.
        symbol: &'static str,
    },

    /// A field of the entry that must match this postpro does not.
    #[error("plugin `{}`: {field} {found}, expected {expected}", library.display())]
    #[diagnostic(code(plugin::abi))]
    Abi {
        /// The library.
        library: PathBuf,
        /// The field (`ABI version`, `entry struct size`).
        field: &'static str,
        /// Its value in the library.
        found: String,
        /// This postpro's.
        expected: String,
        /// What to do.
        #[help]
        help: String,
    },

    /// Something the library hands over cannot be read (a null pointer, invalid UTF-8, a list
    /// that is too long).
    #[error("plugin `{}`: {what} {problem}", library.display())]
    #[diagnostic(
        code(plugin::malformed),
        help(
            "plugins written with `postpro_plugin_api::export_plugin!` cannot have this; a hand-written entry must follow the ABI of `postpro-plugin-api`"
        )
    )]
    Malformed {
        /// The library.
        library: PathBuf,
        /// Which part (`definition 2`, `the kinematics of `x``).
        what: String,
        /// What is wrong with it.
        problem: String,
    },

    /// A machine definition of the plugin that does not read or does not validate, or whose name
    /// is taken; the file shown is `plugin <library>: <definition>`.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Machine(#[from] MachineError),

    /// A definition says `solver: plugin`, but the plugin has no kinematics for it.
    #[error("plugin `{}`: machine `{machine}` says `solver: plugin` but the plugin has no kinematics for it", library.display())]
    #[diagnostic(
        code(plugin::kinematics),
        help(
            "list its type in `kinematics: [...]` of `export_plugin!`, with `MACHINE = \"{machine}\"`, or write `solver: generic`"
        )
    )]
    MissingKinematics {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
    },

    /// Kinematics for a machine the plugin does not define.
    #[error("plugin `{}`: it has kinematics for machine `{machine}` but no definition of it", library.display())]
    #[diagnostic(
        code(plugin::kinematics),
        help("`PluginKinematics::MACHINE` must be the `name` of one of the plugin's definitions")
    )]
    StrayKinematics {
        /// The library.
        library: PathBuf,
        /// The machine named by the kinematics.
        machine: String,
    },

    /// Kinematics for a machine whose definition does not ask for them.
    #[error("plugin `{}`: it has kinematics for machine `{machine}`, whose definition says `solver: {solver}`", library.display())]
    #[diagnostic(
        code(plugin::kinematics),
        help(
            "write `solver: plugin` in the definition to use the plugin's kinematics; the machine uses `{solver}` meanwhile"
        )
    )]
    NotPluginSolver {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// Its definition's solver.
        solver: String,
    },

    /// The kinematics and the definition count different axes.
    #[error("plugin `{}`: the kinematics of machine `{machine}` has {plugin} axes, its definition {definition}", library.display())]
    #[diagnostic(
        code(plugin::kinematics),
        help("`PluginKinematics::AXES` must be the number of `axes` in the definition")
    )]
    AxisCount {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// The kinematics' count.
        plugin: u32,
        /// The definition's count.
        definition: usize,
    },

    /// A call into the plugin panicked or returned an error.
    #[error("plugin `{}` {failure} in `{call}` of machine `{machine}`: {message}", library.display())]
    #[diagnostic(
        code(plugin::call),
        help("a bug in the plugin, or a configuration it refuses; postpro goes on without it")
    )]
    Call {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// The function (`create`, `forward`, `inverse`).
        call: &'static str,
        /// How it failed.
        failure: CallFailure,
        /// The plugin's message.
        message: String,
    },

    /// `forward` returned a pose that is not one (a non-finite number, a tool axis that is not a
    /// unit vector).
    #[error("plugin `{}` returned an invalid pose from `forward` of machine `{machine}` at {joints}: {problem}", library.display())]
    #[diagnostic(code(plugin::invalid_pose), help("`forward` must return finite numbers and a unit tool axis"))]
    InvalidPose {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// The axis values given.
        joints: String,
        /// What is wrong.
        problem: String,
    },

    /// `inverse` returned a solution that is not one.
    #[error("plugin `{}` returned an invalid solution for machine `{machine}` at {pose}: {problem}", library.display())]
    #[diagnostic(
        code(plugin::invalid_solution),
        help(
            "every solution of `inverse` must have the machine's number of finite axis values, and its forward kinematics must reach the pose (within 1e-6 mm and 1e-6 rad)"
        )
    )]
    InvalidSolution {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// The pose asked for.
        pose: String,
        /// What is wrong.
        problem: String,
    },

    /// `inverse` returned no solution where the definition's chain has one.
    #[error("plugin `{}` returned no solution for machine `{machine}` at {pose}, which the definition's chain reaches ({reached})", library.display())]
    #[diagnostic(
        code(plugin::no_solution),
        help(
            "`inverse` must return every solution (both branches of a 5-axis machine); it returns none only where the tool axis cannot be reached at all"
        )
    )]
    NoSolution {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// The pose asked for.
        pose: String,
        /// A solution of the chain.
        reached: String,
    },

    /// The plugin's kinematics and the definition's chain describe different machines.
    #[error("plugin `{}`: the kinematics of machine `{machine}` disagree with its definition: {detail}", library.display())]
    #[diagnostic(
        code(plugin::disagrees),
        help("the plugin's constants and its YAML definition must describe the same machine; fix whichever is wrong")
    )]
    Disagrees {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// Where and by how much.
        detail: String,
    },

    /// The plugin's inverse misses a solution the definition's chain finds.
    #[error("plugin `{}`: the inverse kinematics of machine `{machine}` misses a solution: {detail}", library.display())]
    #[diagnostic(
        code(plugin::missing_branch),
        help(
            "`inverse` must return every solution: both branches of a 5-axis machine, each with its own branch number"
        )
    )]
    MissingBranch {
        /// The library.
        library: PathBuf,
        /// The machine.
        machine: String,
        /// Where, and what is missing.
        detail: String,
    },

    /// Plugin kinematics asked for a machine that no loaded plugin defines.
    #[error("machine `{machine}` does not come from a loaded plugin")]
    #[diagnostic(code(plugin::not_loaded))]
    NotLoaded {
        /// The machine.
        machine: String,
    },
}

impl PluginError {
    /// An ABI mismatch.
    pub(crate) fn abi(library: &Path, field: &'static str, found: u32, expected: u32, unit: &str) -> PluginError {
        PluginError::Abi {
            library: library.to_path_buf(),
            field,
            found: format!("{found}{unit}"),
            expected: format!("{expected}{unit}"),
            help: format!(
                "the plugin was built against another version of `postpro-plugin-api`: rebuild it against the one of \
                 this postpro (ABI version {ABI_VERSION})"
            ),
        }
    }

    /// The library the error is about, if any.
    pub fn library(&self) -> Option<&Path> {
        match self {
            PluginError::Io { .. } | PluginError::Machine(_) | PluginError::NotLoaded { .. } => None,
            PluginError::Open { library, .. }
            | PluginError::NotAPlugin { library, .. }
            | PluginError::Abi { library, .. }
            | PluginError::Malformed { library, .. }
            | PluginError::MissingKinematics { library, .. }
            | PluginError::StrayKinematics { library, .. }
            | PluginError::NotPluginSolver { library, .. }
            | PluginError::AxisCount { library, .. }
            | PluginError::Call { library, .. }
            | PluginError::InvalidPose { library, .. }
            | PluginError::InvalidSolution { library, .. }
            | PluginError::NoSolution { library, .. }
            | PluginError::Disagrees { library, .. }
            | PluginError::MissingBranch { library, .. } => Some(library),
        }
    }

    /// The machine the error is about, if it is about one machine's kinematics.
    pub fn machine(&self) -> Option<&str> {
        match self {
            PluginError::MissingKinematics { machine, .. }
            | PluginError::NotPluginSolver { machine, .. }
            | PluginError::AxisCount { machine, .. }
            | PluginError::Call { machine, .. }
            | PluginError::InvalidPose { machine, .. }
            | PluginError::InvalidSolution { machine, .. }
            | PluginError::NoSolution { machine, .. }
            | PluginError::Disagrees { machine, .. }
            | PluginError::MissingBranch { machine, .. }
            | PluginError::NotLoaded { machine } => Some(machine),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abi_mismatches_name_the_field() {
        let e = PluginError::abi(Path::new("lib.so"), "entry struct size", 24, 56, " bytes");
        assert_eq!(e.to_string(), "plugin `lib.so`: entry struct size 24 bytes, expected 56 bytes");
        assert_eq!(e.library(), Some(Path::new("lib.so")));
        assert_eq!(e.machine(), None);
    }

    #[test]
    fn statuses_become_failures() {
        assert_eq!(CallFailure::of(Status::PANIC), CallFailure::Panicked);
        assert_eq!(CallFailure::of(Status::ERROR), CallFailure::Failed);
        assert_eq!(CallFailure::of(Status::INVALID_ARGUMENT), CallFailure::RefusedArguments);
        assert_eq!(CallFailure::of(Status(9)).to_string(), "returned the unknown status 9");
    }
}
