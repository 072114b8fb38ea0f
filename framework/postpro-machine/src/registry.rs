//! The registry: every machine postpro knows, by name and alias, with where it comes from.
//!
//! The built-in definitions (`machine-defs/*.yaml` and `machine-defs/examples/*.yaml`) are
//! compiled into the binary; users add files ([`Registry::load_file`]) and folders
//! ([`Registry::load_dir`], [`Registry::with_dirs`]); a plugin loader adds machines with
//! [`Registry::load_str`] and [`Registry::add`]. Names and aliases are compared without case and
//! must be unique across the registry: a later definition that reuses a name or alias is refused
//! with an error naming both origins, and the name becomes **ambiguous**: [`Registry::find`]
//! refuses it, naming every definition that claims it, instead of quietly taking the first.
//! A folder's files are loaded one by one: a file that does not load is returned as a
//! [`Skipped`] warning (with its diagnostic) and the others load all the same.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use miette::{NamedSource, SourceSpan};

use crate::error::{ClashError, MachineError, Skipped};
use crate::locate::{Seg, locate};
use crate::model::Machine;

/// Where a machine definition comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Compiled into postpro (`machine-defs/`).
    BuiltIn,
    /// A YAML file given by the user.
    File(PathBuf),
    /// A dynamically loaded plugin.
    Plugin {
        /// The plugin's library file.
        library: PathBuf,
    },
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::BuiltIn => f.write_str("built in"),
            Origin::File(path) => write!(f, "{}", path.display()),
            Origin::Plugin { library } => write!(f, "plugin {}", library.display()),
        }
    }
}

/// The built-in definitions: (path relative to the repository, text).
pub const BUILTIN: &[(&str, &str)] = &[
    ("machine-defs/maho600e.yaml", include_str!("../../../machine-defs/maho600e.yaml")),
    ("machine-defs/mikron-ucp710.yaml", include_str!("../../../machine-defs/mikron-ucp710.yaml")),
    ("machine-defs/haas-umc750.yaml", include_str!("../../../machine-defs/haas-umc750.yaml")),
    ("machine-defs/examples/3axis-vmc.yaml", include_str!("../../../machine-defs/examples/3axis-vmc.yaml")),
    ("machine-defs/examples/4axis-a-table.yaml", include_str!("../../../machine-defs/examples/4axis-a-table.yaml")),
    (
        "machine-defs/examples/head-head-nutating.yaml",
        include_str!("../../../machine-defs/examples/head-head-nutating.yaml"),
    ),
    ("machine-defs/examples/head-table.yaml", include_str!("../../../machine-defs/examples/head-table.yaml")),
    (
        "machine-defs/examples/maho600e-generic.yaml",
        include_str!("../../../machine-defs/examples/maho600e-generic.yaml"),
    ),
    (
        "machine-defs/examples/mikron-ucp710-generic.yaml",
        include_str!("../../../machine-defs/examples/mikron-ucp710-generic.yaml"),
    ),
    (
        "machine-defs/examples/table-table-trunnion.yaml",
        include_str!("../../../machine-defs/examples/table-table-trunnion.yaml"),
    ),
];

/// One machine in the registry.
#[derive(Clone, Debug)]
pub struct Entry {
    /// The validated machine.
    pub machine: Machine,
    /// Where it comes from.
    pub origin: Origin,
    /// The definition's shown name and text, for errors that point into it (none for plugins).
    source: Option<(String, Arc<str>)>,
}

impl Entry {
    /// The definition's YAML text, if the machine comes from one.
    pub fn source_text(&self) -> Option<&str> {
        self.source.as_ref().map(|(_, t)| &**t)
    }

    /// The machine's name followed by its aliases.
    fn names(&self) -> impl Iterator<Item = &str> {
        std::iter::once(self.machine.name.as_str()).chain(self.machine.aliases.iter().map(String::as_str))
    }
}

/// Every known machine, in the order they were added.
#[derive(Clone, Debug, Default)]
pub struct Registry {
    entries: Vec<Entry>,
    /// Names (and aliases) that more than one definition claims.
    ambiguous: Vec<Ambiguity>,
}

/// A name claimed by more than one definition.
#[derive(Clone, Debug)]
struct Ambiguity {
    name: String,
    /// Machine name and origin of each claimant, first loaded first.
    claims: Vec<(String, Origin)>,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Registry {
        Registry::default()
    }

    /// The built-in machines (the two papers' machines and the examples). An error here is a bug
    /// in a built-in file; the tests load every one.
    pub fn builtin() -> Result<Registry, MachineError> {
        let mut registry = Registry::new();
        for (file, text) in BUILTIN {
            registry.load_str(file, text, Origin::BuiltIn)?;
        }
        Ok(registry)
    }

    /// The built-in machines, then every definition file of `dirs` in order
    /// ([`Registry::load_dir`]), with the files that were passed over and why. The error is a
    /// broken built-in (a bug).
    pub fn with_dirs(dirs: &[PathBuf]) -> Result<(Registry, Vec<Skipped>), MachineError> {
        let mut registry = Registry::builtin()?;
        let mut skipped = Vec::new();
        for dir in dirs {
            skipped.extend(registry.load_dir(dir));
        }
        Ok((registry, skipped))
    }

    /// Parses, validates and adds one definition; `file` is the name shown in errors.
    pub fn load_str(&mut self, file: &str, text: &str, origin: Origin) -> Result<&Entry, MachineError> {
        let machine = crate::parse(file, text)?;
        self.insert(Entry { machine, origin, source: Some((file.to_string(), Arc::from(text))) })
    }

    /// Reads, validates and adds one YAML file (origin [`Origin::File`]).
    pub fn load_file(&mut self, path: &Path) -> Result<&Entry, MachineError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| MachineError::Io { path: path.to_path_buf(), source })?;
        self.load_str(&path.display().to_string(), &text, Origin::File(path.to_path_buf()))
    }

    /// Adds every `*.yaml` and `*.yml` file of a folder (not its subfolders), in file-name order.
    /// Returns the files that do not load, each with its error (a diagnostic in the file, a name
    /// that another definition claims, an unreadable file), and the folder itself if it cannot
    /// be read; the good files are added all the same.
    pub fn load_dir(&mut self, dir: &Path) -> Vec<Skipped> {
        let skip = |path: &Path, error| Skipped { path: path.to_path_buf(), error };
        let listing = match std::fs::read_dir(dir) {
            Ok(l) => l,
            Err(source) => return vec![skip(dir, MachineError::Io { path: dir.to_path_buf(), source })],
        };
        let mut errors = Vec::new();
        let mut files = Vec::new();
        for entry in listing {
            match entry {
                Ok(e) => {
                    let path = e.path();
                    let yaml = path.extension().is_some_and(|x| x == "yaml" || x == "yml");
                    if yaml && path.is_file() {
                        files.push(path);
                    }
                }
                Err(source) => errors.push(skip(dir, MachineError::Io { path: dir.to_path_buf(), source })),
            }
        }
        files.sort();
        for path in files {
            if let Err(e) = self.load_file(&path) {
                errors.push(skip(&path, e));
            }
        }
        errors
    }

    /// Adds a machine that does not come from YAML text (a plugin's).
    pub fn add(&mut self, machine: Machine, origin: Origin) -> Result<&Entry, MachineError> {
        self.insert(Entry { machine, origin, source: None })
    }

    /// Adds `entry` unless one of its names is taken; every taken name becomes ambiguous. The
    /// same machine from the same origin (a file given twice) is the entry already there.
    fn insert(&mut self, entry: Entry) -> Result<&Entry, MachineError> {
        if let Some(i) = self.entries.iter().position(|e| e.origin == entry.origin && e.machine == entry.machine) {
            return Ok(&self.entries[i]);
        }
        let mut clash = None;
        for (k, name) in entry.names().enumerate() {
            let Some(first) = self.entries.iter().find(|e| e.names().any(|n| n.eq_ignore_ascii_case(name))) else {
                continue;
            };
            let claim = (entry.machine.name.clone(), entry.origin.clone());
            match self.ambiguous.iter_mut().find(|a| a.name.eq_ignore_ascii_case(name)) {
                Some(a) => a.claims.push(claim),
                None => self.ambiguous.push(Ambiguity {
                    name: name.to_string(),
                    claims: vec![(first.machine.name.clone(), first.origin.clone()), claim],
                }),
            }
            if clash.is_none() {
                clash = Some((k, name, first));
            }
        }
        if let Some((k, name, first)) = clash {
            let (source_code, span) = match &entry.source {
                Some((file, text)) => {
                    let path: &[Seg<'_>] =
                        if k == 0 { &[Seg::Key("name")] } else { &[Seg::Key("aliases"), Seg::Index(k - 1)] };
                    let s = locate(text, path);
                    (
                        Some(NamedSource::new(file.clone(), Arc::clone(text))),
                        Some(SourceSpan::new(s.offset.into(), s.len)),
                    )
                }
                None => (None, None),
            };
            return Err(MachineError::Clash(Box::new(ClashError {
                name: name.to_string(),
                machine: entry.machine.name.clone(),
                origin: entry.origin.clone(),
                first_machine: first.machine.name.clone(),
                first_origin: first.origin.clone(),
                source_code,
                span,
            })));
        }
        self.entries.push(entry);
        Ok(self.entries.last().expect("an entry was just pushed"))
    }

    /// The machine with this name or alias (without case); [`MachineError::Ambiguous`] when
    /// more than one definition claims it, [`MachineError::UnknownMachine`] with the nearest
    /// names when none does.
    pub fn find(&self, name: &str) -> Result<&Entry, MachineError> {
        if let Some(a) = self.ambiguous.iter().find(|a| a.name.eq_ignore_ascii_case(name)) {
            return Err(MachineError::Ambiguous { name: name.to_string(), claims: a.claims.clone() });
        }
        if let Some(e) = self.entries.iter().find(|e| e.names().any(|n| n.eq_ignore_ascii_case(name))) {
            return Ok(e);
        }
        Err(MachineError::UnknownMachine { name: name.to_string(), suggestions: self.suggestions(name) })
    }

    /// Up to three names or aliases close to `name`, best first.
    fn suggestions(&self, name: &str) -> Vec<String> {
        let wanted = name.to_ascii_lowercase();
        let mut scored: Vec<(f64, &str)> = self
            .entries
            .iter()
            .flat_map(Entry::names)
            .map(|n| {
                let lower = n.to_ascii_lowercase();
                let mut score = strsim::jaro_winkler(&wanted, &lower);
                if wanted.len() >= 3 && (lower.contains(&wanted) || wanted.contains(&lower)) {
                    score = score.max(0.9);
                }
                (score, n)
            })
            .filter(|(s, _)| *s >= 0.75)
            .collect();
        scored.sort_by(|a, b| b.0.total_cmp(&a.0).then_with(|| a.1.cmp(b.1)));
        scored.into_iter().take(3).map(|(_, n)| n.to_string()).collect()
    }

    /// Every machine, in the order they were added (built-ins first).
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;
    use crate::model::{ClosedForm, SolverKind, Topology};

    #[test]
    fn builtins_load() {
        let r = Registry::builtin().unwrap();
        assert_eq!(r.entries().len(), BUILTIN.len());
        assert!(r.entries().iter().all(|e| e.origin == Origin::BuiltIn));
        let m = &r.find("MIKRON").unwrap().machine;
        assert_eq!(m.solver, SolverKind::ClosedForm(ClosedForm::MikronUcp710));
        let m = &r.find("maho600e").unwrap().machine;
        assert_eq!(m.solver, SolverKind::ClosedForm(ClosedForm::Maho600e));
        assert_eq!(m.topology(), Topology::TableTable);
    }

    #[test]
    fn every_definition_file_is_embedded() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut on_disk = Vec::new();
        for dir in ["machine-defs", "machine-defs/examples"] {
            for e in std::fs::read_dir(root.join(dir)).unwrap() {
                let path = e.unwrap().path();
                if path.extension().is_some_and(|x| x == "yaml" || x == "yml") {
                    on_disk.push(format!("{dir}/{}", path.file_name().unwrap().to_string_lossy()));
                }
            }
        }
        on_disk.sort();
        let mut embedded: Vec<String> = BUILTIN.iter().map(|(f, _)| f.to_string()).collect();
        embedded.sort();
        assert_eq!(embedded, on_disk, "add every new file of machine-defs/ to registry::BUILTIN");
        for (file, text) in BUILTIN {
            assert_eq!(*text, std::fs::read_to_string(root.join(file)).unwrap(), "{file}");
        }
    }

    #[test]
    fn unknown_names_get_suggestions() {
        let r = Registry::builtin().unwrap();
        let e = r.find("mikorn").unwrap_err();
        let MachineError::UnknownMachine { suggestions, .. } = &e else { panic!("{e}") };
        assert_eq!(suggestions.first().map(String::as_str), Some("mikron"));
        assert!(e.to_string().starts_with("unknown machine `mikorn`; did you mean `mikron`"), "{e}");
        let e = r.find("ucp710").unwrap_err();
        let MachineError::UnknownMachine { suggestions, .. } = &e else { panic!("{e}") };
        assert!(suggestions.contains(&"mikron-ucp710".to_string()), "{suggestions:?}");
        let e = r.find("zzzzzz").unwrap_err();
        assert_eq!(e.to_string(), "unknown machine `zzzzzz`");
    }

    #[test]
    fn clashes_name_both_origins() {
        let mut r = Registry::builtin().unwrap();
        let (_, maho) = BUILTIN[0];
        let text = maho
            .replace("aliases: [maho]", "aliases: [MIKRON]")
            .replace("name: maho600e", "name: other")
            .replace("solver: closed-form", "solver: generic");
        let e = r.load_str("mine.yaml", &text, Origin::File("mine.yaml".into())).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the name `MIKRON` of machine `other` (mine.yaml) is already used by machine `mikron-ucp710` (built in)"
        );
        let MachineError::Clash(c) = &e else { panic!("{e}") };
        let span = c.span.unwrap();
        assert_eq!(&text[span.offset()..span.offset() + span.len()], "MIKRON");
        // The name no longer finds the first machine; its other names do.
        assert_eq!(
            r.find("mikron").unwrap_err().to_string(),
            "the machine name `mikron` is ambiguous: machine `mikron-ucp710` (built in) and machine `other` \
             (mine.yaml) both claim it"
        );
        assert_eq!(r.find("mikron-ucp710").unwrap().machine.name, "mikron-ucp710");
        let n = r.entries().len();
        let m = r.find("maho").unwrap().machine.clone();
        let e = r.add(m, Origin::Plugin { library: "libmaho.so".into() }).unwrap_err();
        assert!(e.to_string().ends_with("(plugin libmaho.so) is already used by machine `maho600e` (built in)"), "{e}");
        assert_eq!(r.entries().len(), n);
        // Both its name and its alias are taken: both are ambiguous.
        assert!(matches!(r.find("MAHO600E"), Err(MachineError::Ambiguous { .. })));
        let Err(MachineError::Ambiguous { claims, .. }) = r.find("maho") else { panic!("maho is ambiguous") };
        assert_eq!(claims[1], ("maho600e".to_string(), Origin::Plugin { library: "libmaho.so".into() }));
        // A third claimant is named too.
        let third = maho.replace("name: maho600e", "name: third").replace("solver: closed-form", "solver: generic");
        assert!(r.load_str("third.yaml", &third, Origin::File("third.yaml".into())).is_err());
        let e = r.find("maho").unwrap_err().to_string();
        assert!(e.ends_with("(plugin libmaho.so) and machine `third` (third.yaml) all claim it"), "{e}");
    }
}
