//! # postpro-plugins: machines from dynamically loaded libraries
//!
//! A shop adds a machine as a shared library built with `postpro-plugin-api` (see
//! `docs/writing-a-plugin.md`): its YAML definitions and, where it wants, its own compiled
//! kinematics. This crate is the host side:
//!
//! 1. [`Plugins::discover`] loads the libraries of the `plugins` folder beside the running
//!    binary, of the folders in `POSTPRO_PLUGIN_PATH`, and the files given (`--plugin FILE`);
//!    [`Plugins::load`] one library. The ABI version is checked first, then the entry's size;
//!    each mismatch names the field ("ABI version 7, expected 1").
//! 2. [`Plugins::register`] adds the plugins' machines to a [`Registry`] with
//!    [`Origin::Plugin`], so `postpro machines` shows the library; a definition that does not
//!    validate is an error with the file `plugin <library>: <definition>`.
//! 3. [`Plugins::kinematics`] gives a machine's compiled kinematics as a [`Kinematics`]
//!    ([`KinematicsAdapter`]), verified against the definition's chain first.
//!
//! **Nothing a plugin does stops postpro**: a library that does not load, a definition that
//! does not validate, a panic inside the plugin, an error status, an invalid solution: each is
//! a [`PluginError`] for that library or that machine, and the other machines work.
//!
//! All `unsafe` code, and the invariants it rests on, is in one module (`ffi.rs`). **Lifetime
//! rule:** a library stays loaded as long as anything that may call into it lives: the
//! [`Plugins`] that loaded it, and every [`KinematicsAdapter`] created from it (each holds the
//! library), even after the [`Plugins`] is dropped.

mod adapter;
mod error;
mod ffi;

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use postpro_kin::Kinematics;
use postpro_machine::model::{Machine, SolverKind};
use postpro_machine::{Origin, Registry};

pub use adapter::{AXIS_TOLERANCE, KinematicsAdapter, SAMPLES, TIP_TOLERANCE};
pub use error::{CallFailure, PluginError};

/// The environment variable with plugin folders, separated like `PATH` (`:` on Unix).
pub const PATH_VARIABLE: &str = "POSTPRO_PLUGIN_PATH";

/// The folder beside the running binary whose libraries are loaded.
pub const BESIDE_BINARY: &str = "plugins";

/// The file name cargo gives the library of a `cdylib` crate on this system:
/// `libplugin_head_head.so` for `plugin-head-head` on Linux, `plugin_head_head.dll` on Windows.
pub fn library_file_name(crate_name: &str) -> String {
    format!("{}{}{}", std::env::consts::DLL_PREFIX, crate_name.replace('-', "_"), std::env::consts::DLL_SUFFIX)
}

/// True for a file name with this system's library extension (`.so`, `.dylib`, `.dll`).
pub fn is_library(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == std::env::consts::DLL_EXTENSION)
}

/// A template a plugin ships, for the NC emitter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Template {
    /// Its name.
    pub name: String,
    /// Its text.
    pub text: String,
}

/// One loaded plugin library.
pub struct Plugin {
    path: PathBuf,
    canonical: PathBuf,
    name: String,
    version: String,
    definitions: Vec<(String, Result<String, ffi::Malformed>)>,
    templates: Vec<Result<Template, ffi::Malformed>>,
    kinematics: Vec<Result<Arc<ffi::KinTable>, ffi::Malformed>>,
}

impl std::fmt::Debug for Plugin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Plugin")
            .field("path", &self.path)
            .field("name", &self.name)
            .field("version", &self.version)
            .field("definitions", &self.definitions.len())
            .field("kinematics", &self.kinematics_machines())
            .finish()
    }
}

impl Plugin {
    /// The library file, as given or found.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The plugin's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The plugin's own version.
    pub fn version(&self) -> &str {
        &self.version
    }

    /// The shown names of its machine definitions (`machines/fork-head-bc.yaml`).
    pub fn definition_files(&self) -> impl Iterator<Item = &str> {
        self.definitions.iter().map(|(f, _)| f.as_str())
    }

    /// The machines it has compiled kinematics for.
    pub fn kinematics_machines(&self) -> Vec<&str> {
        self.kinematics.iter().flatten().map(|t| t.machine.as_str()).collect()
    }

    /// Its templates (those that read).
    pub fn templates(&self) -> impl Iterator<Item = &Template> {
        self.templates.iter().flatten()
    }

    /// The file name errors in a definition show: `plugin <library>: <definition>`.
    fn label(&self, file: &str) -> String {
        format!("plugin {}: {file}", self.path.display())
    }

    fn malformed(&self, m: &ffi::Malformed) -> PluginError {
        PluginError::Malformed { library: self.path.clone(), what: m.what.clone(), problem: m.problem.clone() }
    }

    fn table(&self, machine: &str) -> Option<&Arc<ffi::KinTable>> {
        self.kinematics.iter().flatten().find(|t| t.machine.eq_ignore_ascii_case(machine))
    }
}

/// The loaded plugins.
#[derive(Debug, Default)]
pub struct Plugins {
    plugins: Vec<Plugin>,
}

impl Plugins {
    /// No plugin.
    pub fn new() -> Plugins {
        Plugins::default()
    }

    /// The loaded plugins, in the order they were loaded.
    pub fn plugins(&self) -> &[Plugin] {
        &self.plugins
    }

    /// Loads one library (a library already loaded, by whatever path, is not loaded twice). A
    /// library that does not load, is not a plugin or has another ABI is an error, and nothing
    /// of it is kept. Problems with single items (a definition, a kinematics table) are reported
    /// by [`Plugins::register`].
    pub fn load(&mut self, path: &Path) -> Result<&Plugin, PluginError> {
        let metadata = std::fs::metadata(path).map_err(|source| PluginError::Io { path: path.into(), source })?;
        if !metadata.is_file() {
            return Err(PluginError::Io {
                path: path.into(),
                source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file"),
            });
        }
        let canonical = path.canonicalize().map_err(|source| PluginError::Io { path: path.into(), source })?;
        if let Some(i) = self.plugins.iter().position(|p| p.canonical == canonical) {
            return Ok(&self.plugins[i]);
        }
        let opened = ffi::open(&ffi::explicit(path))?;
        self.plugins.push(Plugin {
            path: path.to_path_buf(),
            canonical,
            name: opened.name,
            version: opened.version,
            definitions: opened.definitions,
            templates: opened.templates.into_iter().map(|t| t.map(|(name, text)| Template { name, text })).collect(),
            kinematics: opened.kinematics,
        });
        Ok(self.plugins.last().expect("a plugin was just pushed"))
    }

    /// Loads every library (this system's extension) of a folder, in file-name order. Returns
    /// the errors; the libraries that load are kept.
    pub fn load_dir(&mut self, dir: &Path) -> Vec<PluginError> {
        let listing = match std::fs::read_dir(dir) {
            Ok(l) => l,
            Err(source) => return vec![PluginError::Io { path: dir.to_path_buf(), source }],
        };
        let mut errors = Vec::new();
        let mut files = Vec::new();
        for entry in listing {
            match entry {
                Ok(e) if is_library(&e.path()) && e.path().is_file() => files.push(e.path()),
                Ok(_) => {}
                Err(source) => errors.push(PluginError::Io { path: dir.to_path_buf(), source }),
            }
        }
        files.sort();
        for path in files {
            if let Err(e) = self.load(&path) {
                errors.push(e);
            }
        }
        errors
    }

    /// The folders searched for plugins: `plugins` beside the running binary (if it exists),
    /// then those of `POSTPRO_PLUGIN_PATH`.
    pub fn search_path() -> Vec<PathBuf> {
        let mut dirs = Vec::new();
        if let Some(dir) = std::env::current_exe().ok().and_then(|exe| exe.parent().map(|p| p.join(BESIDE_BINARY)))
            && dir.is_dir()
        {
            dirs.push(dir);
        }
        if let Some(v) = std::env::var_os(PATH_VARIABLE) {
            dirs.extend(std::env::split_paths(&v).filter(|p| !p.as_os_str().is_empty()));
        }
        dirs
    }

    /// Loads the plugins of [`Plugins::search_path`], then the `files` (`--plugin FILE`).
    /// Returns the errors; the libraries that load are kept.
    pub fn discover(&mut self, files: &[PathBuf]) -> Vec<PluginError> {
        let mut errors = Vec::new();
        for dir in Plugins::search_path() {
            errors.extend(self.load_dir(&dir));
        }
        for file in files {
            if let Err(e) = self.load(file) {
                errors.push(e);
            }
        }
        errors
    }

    /// Adds every plugin's machines to the registry ([`Origin::Plugin`]). Returns the errors,
    /// each about one library or machine: a definition that does not read or validate or whose
    /// name is taken (not added), an unreadable template, and kinematics that do not match the
    /// definitions (`solver: plugin` without kinematics, kinematics without a definition or for
    /// a definition that does not say `solver: plugin`, another number of axes).
    pub fn register(&self, registry: &mut Registry) -> Vec<PluginError> {
        let mut errors = Vec::new();
        for plugin in &self.plugins {
            let origin = Origin::Plugin { library: plugin.path.clone() };
            let mut defined: HashSet<String> = HashSet::new();
            for (file, text) in &plugin.definitions {
                let text = match text {
                    Ok(t) => t,
                    Err(m) => {
                        errors.push(plugin.malformed(m));
                        continue;
                    }
                };
                let machine = match registry.load_str(&plugin.label(file), text, origin.clone()) {
                    Ok(entry) => entry.machine.clone(),
                    Err(e) => {
                        errors.push(e.into());
                        continue;
                    }
                };
                defined.insert(machine.name.to_ascii_lowercase());
                let table = plugin.table(&machine.name);
                match (machine.solver, table) {
                    (SolverKind::Plugin, None) => errors.push(PluginError::MissingKinematics {
                        library: plugin.path.clone(),
                        machine: machine.name.clone(),
                    }),
                    (SolverKind::Plugin, Some(t)) if t.axis_count as usize != machine.axes.len() => {
                        errors.push(PluginError::AxisCount {
                            library: plugin.path.clone(),
                            machine: machine.name.clone(),
                            plugin: t.axis_count,
                            definition: machine.axes.len(),
                        });
                    }
                    (SolverKind::Generic | SolverKind::ClosedForm(_), Some(_)) => {
                        errors.push(PluginError::NotPluginSolver {
                            library: plugin.path.clone(),
                            machine: machine.name.clone(),
                            solver: match machine.solver {
                                SolverKind::Generic => "generic".into(),
                                _ => "closed-form".into(),
                            },
                        });
                    }
                    _ => {}
                }
            }
            for item in &plugin.kinematics {
                match item {
                    Err(m) => errors.push(plugin.malformed(m)),
                    Ok(t) if !defined.contains(&t.machine.to_ascii_lowercase()) => {
                        // Unless the definition is there but failed (already reported).
                        let named = plugin.definitions.iter().any(|(_, text)| {
                            text.as_ref()
                                .ok()
                                .and_then(|y| postpro_machine::parse_raw("", y).ok())
                                .is_some_and(|raw| raw.name.eq_ignore_ascii_case(&t.machine))
                        });
                        if !named {
                            errors.push(PluginError::StrayKinematics {
                                library: plugin.path.clone(),
                                machine: t.machine.clone(),
                            });
                        }
                    }
                    Ok(_) => {}
                }
            }
            for t in &plugin.templates {
                if let Err(m) = t {
                    errors.push(plugin.malformed(m));
                }
            }
        }
        errors
    }

    /// The compiled kinematics of a machine from a loaded plugin (`origin` is its registry
    /// entry's; the machine as it will be used, with the command line's tool length), verified
    /// against the machine's chain ([`KinematicsAdapter::verify`]).
    pub fn kinematics(&self, machine: &Machine, origin: &Origin) -> Result<KinematicsAdapter, PluginError> {
        let adapter = self.open_kinematics(machine, origin)?;
        adapter.verify()?;
        Ok(adapter)
    }

    /// [`Plugins::kinematics`] without the verification: for diagnosis and tests. Every call is
    /// still checked.
    pub fn open_kinematics(&self, machine: &Machine, origin: &Origin) -> Result<KinematicsAdapter, PluginError> {
        let not_loaded = || PluginError::NotLoaded { machine: machine.name.clone() };
        let Origin::Plugin { library } = origin else {
            return Err(not_loaded());
        };
        let plugin = self.plugins.iter().find(|p| &p.path == library).ok_or_else(not_loaded)?;
        let Some(table) = plugin.table(&machine.name) else {
            return Err(PluginError::MissingKinematics { library: library.clone(), machine: machine.name.clone() });
        };
        if table.axis_count as usize != machine.axes.len() {
            return Err(PluginError::AxisCount {
                library: library.clone(),
                machine: machine.name.clone(),
                plugin: table.axis_count,
                definition: machine.axes.len(),
            });
        }
        let instance = table.create(machine.chain.tool_length).map_err(|e| PluginError::Call {
            library: library.clone(),
            machine: machine.name.clone(),
            call: "create",
            failure: CallFailure::of(e.status),
            message: e.message,
        })?;
        Ok(KinematicsAdapter::new(machine.clone(), instance, library))
    }

    /// The kinematics of a registry entry: the plugin's (verified) for `solver: plugin` from a
    /// loaded plugin, otherwise [`postpro_kin::solver_for`] (for `solver: plugin` outside a
    /// plugin, the generic chain of the definition).
    pub fn solver(&self, machine: &Machine, origin: &Origin) -> Result<Solver, PluginError> {
        match (machine.solver, origin) {
            (SolverKind::Plugin, Origin::Plugin { .. }) => {
                Ok(Solver::Plugin(Box::new(self.kinematics(machine, origin)?)))
            }
            _ => Ok(Solver::Built(postpro_kin::solver_for(machine))),
        }
    }

    /// Verifies the kinematics of every plugin machine of the registry that asks for them;
    /// returns the errors (see [`PluginError::machine`] for the machine of each).
    pub fn check(&self, registry: &Registry) -> Vec<PluginError> {
        let mut errors = Vec::new();
        for e in registry.entries() {
            let Origin::Plugin { library } = &e.origin else { continue };
            if e.machine.solver != SolverKind::Plugin {
                continue;
            }
            let has_table = self.plugins.iter().any(|p| &p.path == library && p.table(&e.machine.name).is_some());
            if !has_table {
                // Reported by `register`.
                continue;
            }
            if let Err(err) = self.kinematics(&e.machine, &e.origin) {
                errors.push(err);
            }
        }
        errors
    }
}

/// A machine's kinematics: built in postpro, or a plugin's.
pub enum Solver {
    /// A solver of `postpro-kin`.
    Built(Box<dyn Kinematics>),
    /// A plugin's compiled kinematics.
    Plugin(Box<KinematicsAdapter>),
}

impl std::fmt::Debug for Solver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Solver::Built(k) => write!(f, "Built({})", k.machine().name),
            Solver::Plugin(a) => write!(f, "Plugin({a:?})"),
        }
    }
}

impl Solver {
    /// As a [`Kinematics`].
    pub fn kinematics(&self) -> &dyn Kinematics {
        match self {
            Solver::Built(k) => k.as_ref(),
            Solver::Plugin(a) => a.as_ref(),
        }
    }

    /// The error a plugin met during use, if any (always none for a built-in solver); see
    /// [`KinematicsAdapter::take_error`].
    pub fn take_error(&self) -> Option<PluginError> {
        match self {
            Solver::Built(_) => None,
            Solver::Plugin(a) => a.take_error(),
        }
    }
}
