//! Data-driven tests of machine definitions: every `tests/defs/err_*.yaml` fails with a
//! diagnostic whose rendering (no colours, 100 columns) is pinned by an insta snapshot; every
//! `tests/defs/ok_*.yaml`, built-in and example definition loads, and the models of the built-in
//! ones are pinned (in model units, with their clearance) so that a change of a unit conversion
//! shows. Every folder of `tests/registry/` is loaded as a machine folder: the files it skips
//! (rendered warnings) and what its names find (machines or rendered errors) are pinned too.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use postpro_machine::model::{Machine, Travel};
use postpro_machine::{BUILTIN, MachineError, Origin, Registry};

mod support;

use support::render;

/// The crate folder, so that file names in snapshots are relative to it.
fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn relative(path: &Path) -> String {
    path.strip_prefix(crate_dir()).unwrap_or(path).to_string_lossy().replace('\\', "/")
}

#[test]
fn error_cases_render_with_the_expected_value() {
    insta::glob!("defs/err_*.yaml", |path| {
        let text = std::fs::read_to_string(path).expect("the case reads");
        let name = relative(path);
        let err = match postpro_machine::parse(&name, &text) {
            Ok(m) => panic!("{name} loads as `{}`", m.name),
            Err(e) => e,
        };
        assert!(matches!(err, MachineError::Definition(_)), "{name}: {err:?}");
        insta::assert_snapshot!(render(&err));
    });
}

#[test]
fn ok_cases_load() {
    let mut n = 0;
    for entry in std::fs::read_dir(crate_dir().join("tests/defs")).expect("tests/defs") {
        let path = entry.expect("entry").path();
        let file = path.file_name().expect("a name").to_string_lossy().to_string();
        if file.starts_with("ok_") {
            let text = std::fs::read_to_string(&path).expect("reads");
            if let Err(e) = postpro_machine::parse(&relative(&path), &text) {
                panic!("{file} does not load:\n{}", render(&e));
            }
            n += 1;
        }
    }
    assert!(n > 0, "no ok_ case");
}

#[test]
fn every_builtin_and_example_loads() {
    for (file, text) in BUILTIN {
        if let Err(e) = postpro_machine::parse(file, text) {
            panic!("{file} does not load:\n{}", render(&e));
        }
    }
    let registry = Registry::builtin().expect("the built-ins load together (no name clash)");
    assert_eq!(registry.entries().len(), BUILTIN.len());
    let labels: Vec<&str> = registry.entries().iter().map(|e| e.machine.topology().label()).collect();
    for topology in ["3-axis", "4-axis (table)", "5-axis table-table", "5-axis head-head", "5-axis head-table"] {
        assert!(labels.contains(&topology), "no built-in {topology} machine: {labels:?}");
    }
}

/// The model in its units (mm, rad, s; feeds in mm/min), one line per item.
fn summary(m: &Machine) -> String {
    let mut s = String::new();
    let v = |v: &nalgebra::Vector3<f64>| format!("[{:.6}, {:.6}, {:.6}]", v.x + 0.0, v.y + 0.0, v.z + 0.0);
    let _ = writeln!(s, "name        {} (aliases: {})", m.name, m.aliases.join(", "));
    let _ = writeln!(s, "topology    {}", m.topology().label());
    let _ = writeln!(s, "solver      {:?}", m.solver);
    let _ = writeln!(s, "dialect     {}", m.dialect);
    for a in &m.axes {
        let travel = match a.travel {
            Travel::Limited { min, max } => format!("[{min:.6}, {max:.6}]"),
            Travel::Endless => "endless".to_string(),
        };
        let _ = writeln!(
            s,
            "axis {:<3}  {:?} dir {} center {} travel {travel} home {:.6} vmax {:.6} amax {:.6} jmax {:.6} decimals {}",
            a.letter,
            a.kind,
            v(&a.direction),
            v(&a.center.coords),
            a.home,
            a.vmax,
            a.amax,
            a.jmax,
            a.decimals
        );
    }
    let c = &m.chain;
    let letters = |ix: &[usize]| ix.iter().map(|&i| m.axes[i].letter.as_str()).collect::<Vec<_>>().join(" ");
    let _ = writeln!(
        s,
        "chain       linear [{}] part [{}] tool [{}]",
        letters(&c.linear),
        letters(&c.part),
        letters(&c.tool)
    );
    let o = &c.part_origin;
    let _ = writeln!(
        s,
        "part origin {} x {} z {}",
        v(&o.translation.vector),
        v(&(o.rotation * nalgebra::Vector3::x())),
        v(&(o.rotation * nalgebra::Vector3::z()))
    );
    let _ = writeln!(
        s,
        "spindle     nose {} direction {} tool length {:.6} tip {}",
        v(&c.spindle_nose.coords),
        v(&c.tool_direction),
        c.tool_length,
        v(&c.tool_tip().coords)
    );
    let _ = writeln!(s, "cnc         {:?}", m.cnc);
    let _ = writeln!(s, "policy      {:?}", m.policy);
    let along = m.spindle_linear_axis().map_or("none".to_string(), |i| m.axes[i].letter.clone());
    let _ = writeln!(s, "clearance   {:?} (spindle axis {along}) units {:?}", m.clearance, m.units);
    s
}

#[test]
fn builtin_models_are_pinned() {
    let registry = Registry::builtin().expect("built-ins load");
    for entry in registry.entries() {
        insta::assert_snapshot!(format!("model_{}", entry.machine.name), summary(&entry.machine));
    }
}

/// Every folder of `tests/registry/` is loaded over the built-ins as `--machine-dir` loads it:
/// the snapshot pins the machines it adds, the files it skips with their rendered warnings, and
/// what each name of its `find.txt` finds (a machine and its origin, or the rendered error).
#[test]
fn registry_folders() {
    insta::glob!("registry/*/find.txt", |find| {
        let dir = find.parent().expect("a folder");
        let dir = dir.strip_prefix(crate_dir()).unwrap_or(dir);
        let (registry, skipped) = Registry::with_dirs(&[dir.to_path_buf()]).expect("built-ins load");
        let mut report = String::from("loaded:\n");
        for e in registry.entries().iter().filter(|e| e.origin != Origin::BuiltIn) {
            let _ = writeln!(report, "  {} ({})", e.machine.name, e.origin);
        }
        report += "skipped:\n";
        for s in &skipped {
            assert!(s.to_string().starts_with(&format!("skipped `{}", dir.display())), "{s}");
            report += &render(s);
        }
        for name in std::fs::read_to_string(find).expect("find.txt").lines() {
            match registry.find(name) {
                Ok(e) => {
                    let _ = writeln!(report, "find {name}: {} ({})", e.machine.name, e.origin);
                }
                Err(e) => {
                    let _ = writeln!(report, "find {name}:");
                    report += &render(&e);
                }
            }
        }
        insta::assert_snapshot!(report);
    });
}

#[test]
fn a_folder_that_cannot_be_read_is_skipped() {
    let (registry, skipped) = Registry::with_dirs(&[PathBuf::from("tests/registry/missing")]).expect("built-ins");
    assert_eq!(registry.entries().len(), BUILTIN.len());
    assert_eq!(skipped.len(), 1);
    assert!(matches!(skipped[0].error, MachineError::Io { .. }), "{:?}", skipped[0]);
    assert!(skipped[0].to_string().starts_with("skipped `tests/registry/missing`: cannot read"), "{}", skipped[0]);
}

#[test]
fn load_file_reports_the_path() {
    let mut registry = Registry::new();
    let err = registry.load_file(Path::new("no/such/file.yaml")).expect_err("missing file");
    assert!(err.to_string().starts_with("cannot read `no/such/file.yaml`"), "{err}");
    let path = crate_dir().join("tests/defs/ok_base.yaml");
    let entry = registry.load_file(&path).expect("loads");
    assert_eq!(entry.origin, Origin::File(path.clone()));
    // The same file again (`--machine FILE` also in `--machine-dir`) is the same machine.
    assert_eq!(registry.load_file(&path).expect("the same file loads again").origin, Origin::File(path.clone()));
    assert_eq!(registry.entries().len(), 1);
    assert_eq!(registry.find("test-machine").expect("not ambiguous").origin, Origin::File(path.clone()));
    // A copy of it elsewhere claims its name.
    let copy = std::env::temp_dir().join(format!("postpro-machine-copy-{}.yaml", std::process::id()));
    std::fs::copy(&path, &copy).expect("copy");
    let clash = registry.load_file(&copy).expect_err("a copy clashes");
    let _ = std::fs::remove_file(&copy);
    let shown = render(&clash);
    assert!(shown.contains("already used by machine `test-machine`"), "{shown}");
    assert!(matches!(registry.find("test-machine"), Err(MachineError::Ambiguous { .. })));
}
