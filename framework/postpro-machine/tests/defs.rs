//! Data-driven tests of machine definitions: every `tests/defs/err_*.yaml` fails with a
//! diagnostic whose rendering (no colours, 100 columns) is pinned by an insta snapshot; every
//! `tests/defs/ok_*.yaml`, built-in and example definition loads, and the models of the built-in
//! ones are pinned (in model units) so that a change of a unit conversion shows.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use postpro_machine::model::{Machine, Travel};
use postpro_machine::{BUILTIN, MachineError, Origin, Registry};

/// The miette rendering as `postpro machines --check` prints it, without colours.
fn render(e: &MachineError) -> String {
    let mut out = String::new();
    miette::GraphicalReportHandler::new_themed(miette::GraphicalTheme::unicode_nocolor())
        .with_width(100)
        .render_report(&mut out, e)
        .expect("renders");
    out
}

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
    s
}

#[test]
fn builtin_models_are_pinned() {
    let registry = Registry::builtin().expect("built-ins load");
    for entry in registry.entries() {
        insta::assert_snapshot!(format!("model_{}", entry.machine.name), summary(&entry.machine));
    }
}

/// A fresh folder under the system's temporary folder.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("postpro-machine-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

#[test]
fn load_dir_keeps_the_good_files_and_returns_the_errors() {
    let dir = temp_dir("load-dir");
    let good = std::fs::read_to_string(crate_dir().join("tests/defs/ok_base.yaml")).expect("ok_base");
    std::fs::write(dir.join("a-good.yaml"), &good).expect("write");
    std::fs::write(dir.join("b-other.yml"), good.replace("name: test-machine", "name: other")).expect("write");
    std::fs::write(dir.join("c-broken.yaml"), good.replace("vmax: 30 rpm", "vmax: 30 furlongs")).expect("write");
    std::fs::write(dir.join("d-clash.yaml"), good.replace("name: test-machine", "name: test-machine\naliases: [maho]"))
        .expect("write");
    std::fs::write(dir.join("notes.txt"), "not a machine").expect("write");

    let mut registry = Registry::builtin().expect("built-ins");
    let builtins = registry.entries().len();
    let errors = registry.load_dir(&dir);
    assert_eq!(registry.entries().len(), builtins + 2);
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert!(errors[0].to_string().contains("unknown unit `furlongs`"), "{}", errors[0]);
    assert!(
        errors[1].to_string().starts_with("the name `test-machine` of machine `test-machine`"),
        "the clash is reported: {}",
        errors[1]
    );
    let entry = registry.find("OTHER").expect("found without case");
    assert_eq!(entry.origin, Origin::File(dir.join("b-other.yml")));
    assert!(registry.load_dir(&dir.join("missing")).first().is_some_and(|e| matches!(e, MachineError::Io { .. })));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn load_file_reports_the_path() {
    let mut registry = Registry::new();
    let err = registry.load_file(Path::new("no/such/file.yaml")).expect_err("missing file");
    assert!(err.to_string().starts_with("cannot read `no/such/file.yaml`"), "{err}");
    let path = crate_dir().join("tests/defs/ok_base.yaml");
    let entry = registry.load_file(&path).expect("loads");
    assert_eq!(entry.origin, Origin::File(path.clone()));
    let again = registry.load_file(&path).expect_err("a second time clashes");
    let shown = render(&again);
    assert!(shown.contains("already used by machine `test-machine`"), "{shown}");
}
