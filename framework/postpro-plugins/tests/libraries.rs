//! The plugin host against real libraries: the example plugins and the fixtures of `plugins/`,
//! built by cargo within the test run (`cargo build -p …` into this test's target directory).
//!
//! - the head-head example loads, registers its machine, and its kinematics round-trips
//!   FK∘IK through the C ABI (random poses, every branch, 1e-9) and solves a bundled example
//!   exactly like the definition's chain;
//! - the definitions-only example registers its two machines;
//! - a wrong ABI version, a missing entry symbol, a file that is no library, and each
//!   misbehaving machine (panic, error, no solution, invalid solution, disagreement, broken
//!   definition) is a clear error, after which the next call works.

use std::path::{Path, PathBuf};

use nalgebra::{Point3, Unit, Vector3};
use postpro_kin::{Kinematics, Pose, Solutions, solve, solver_for};
use postpro_machine::model::Machine;
use postpro_machine::{Origin, Registry};
use postpro_plugins::{CallFailure, PluginError, Plugins, Solver, library_file_name};

/// The library of a plugin package.
fn library(package: &str) -> PathBuf {
    let path = tests::built_plugins().join(library_file_name(package));
    assert!(path.is_file(), "{} was built", path.display());
    path
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The bundled example.
fn hypar() -> postpro_cl::Source {
    postpro_cl::Source::from_path(&repo().join("examples/cl/hypar-5axis.cl")).expect("the example")
}

/// A fresh folder for one test.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("postpro-plugins-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    dir
}

/// The plugins of these packages, registered after the built-in machines.
fn loaded(packages: &[&str]) -> (Plugins, Registry, Vec<PluginError>) {
    let mut plugins = Plugins::new();
    for p in packages {
        plugins.load(&library(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    }
    let mut registry = Registry::builtin().expect("built-ins");
    let errors = plugins.register(&mut registry);
    (plugins, registry, errors)
}

fn machine(registry: &Registry, name: &str) -> (Machine, Origin) {
    let e = registry.find(name).unwrap_or_else(|e| panic!("{e}"));
    (e.machine.clone(), e.origin.clone())
}

/// SplitMix64 in [0, 1).
struct Random(u64);

impl Random {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A pose whose tool axis is at most `max_tilt` (rad) from +z, its tip in a 400 mm cube.
    fn pose(&mut self, max_tilt: f64) -> Pose {
        let tilt = max_tilt * self.next();
        let turn = std::f64::consts::TAU * self.next();
        let axis = Vector3::new(tilt.sin() * turn.cos(), tilt.sin() * turn.sin(), tilt.cos());
        let tip = Point3::new(400.0 * self.next() - 200.0, 400.0 * self.next() - 200.0, 400.0 * self.next() - 200.0);
        Pose { tip, axis: Unit::new_normalize(axis) }
    }
}

#[test]
fn the_head_head_plugin_loads_with_its_machine_kinematics_and_template() {
    let (plugins, registry, errors) = loaded(&["plugin-head-head"]);
    assert!(errors.is_empty(), "{errors:?}");
    let p = &plugins.plugins()[0];
    assert_eq!((p.name(), p.version()), ("plugin-head-head", env!("CARGO_PKG_VERSION")));
    assert_eq!(p.definition_files().collect::<Vec<_>>(), ["machines/fork-head-bc.yaml"]);
    assert_eq!(p.kinematics_machines(), ["fork-head-bc"]);
    let templates: Vec<_> = p.templates().collect();
    assert_eq!(templates.len(), 1);
    assert_eq!(templates[0].name, "fork-head-bc");
    assert!(templates[0].text.contains("BEGIN PGM"), "{}", templates[0].text);
    let entry = registry.find("fork-head").expect("by alias");
    assert_eq!(entry.machine.name, "fork-head-bc");
    assert_eq!(entry.origin, Origin::Plugin { library: library("plugin-head-head") });
    assert!(entry.origin.to_string().starts_with("plugin "), "{}", entry.origin);
    assert!(plugins.check(&registry).is_empty());
}

#[test]
fn fk_of_ik_round_trips_through_the_c_abi_on_every_branch() {
    let (plugins, registry, _) = loaded(&["plugin-head-head"]);
    let (m, origin) = machine(&registry, "fork-head-bc");
    let kin = plugins.kinematics(&m, &origin).expect("verified");
    let chain = solver_for(&m);
    let mut random = Random(7);
    let (mut mine, mut reference) = (Solutions::new(), Solutions::new());
    let mut branches = 0;
    for _ in 0..2000 {
        let pose = random.pose(100f64.to_radians());
        kin.try_inverse(&pose, &mut mine).expect("checked solutions");
        // Away from the pole, both branches.
        assert_eq!(mine.len(), 2, "{pose:?}");
        for s in mine.iter() {
            // Forward kinematics through the C ABI too.
            let back = kin.try_forward(&s.joints).expect("forward");
            assert!((back.tip - pose.tip).norm() < 1e-9, "tip {:?} vs {:?}", back.tip, pose.tip);
            assert!((back.axis.into_inner() - pose.axis.into_inner()).norm() < 1e-9, "axis off for {s:?}");
            branches += 1;
        }
        // The same solutions as the definition's chain, through the trait as the policy calls it.
        kin.inverse(&pose, &mut mine);
        chain.inverse(&pose, &mut reference);
        assert_eq!(mine.len(), reference.len());
        for r in reference.iter() {
            let found = mine.iter().any(|s| {
                s.joints.as_slice().iter().zip(r.joints.as_slice()).all(|(a, b)| {
                    let d = (a - b).abs();
                    d < 1e-9 || (d - std::f64::consts::TAU).abs() < 1e-9
                })
            });
            assert!(found, "the chain's {r:?} is not among {mine:?}");
        }
    }
    assert_eq!(branches, 4000);
    assert!(!kin.has_failed());
    assert!(kin.take_error().is_none());
}

#[test]
fn a_bundled_example_solves_exactly_as_with_the_definitions_chain() {
    let (plugins, registry, _) = loaded(&["plugin-head-head"]);
    let (m, origin) = machine(&registry, "fork-head-bc");
    let solver = plugins.solver(&m, &origin).expect("the plugin's kinematics");
    assert!(matches!(solver, Solver::Plugin(_)), "{solver:?}");
    let source = hypar();
    let path = postpro_cl::read(&source);
    let through_plugin = solve(solver.kinematics(), &path, &m.policy).expect("solves");
    assert!(solver.take_error().is_none());
    let chain = solver_for(&m);
    let through_chain = solve(chain.as_ref(), &path, &m.policy).expect("solves");
    assert_eq!(through_plugin.steps.len(), through_chain.steps.len());
    assert!(through_plugin.steps.len() > 2000);
    for (a, b) in through_plugin.steps.iter().zip(&through_chain.steps) {
        for (x, y) in a.joints.as_slice().iter().zip(b.joints.as_slice()) {
            assert!((x - y).abs() < 1e-9, "{a:?} vs {b:?}");
        }
        // Every position puts the tip on the CL point.
        let back = solver.kinematics().forward(&a.joints);
        assert!((back.tip - a.pose.tip).norm() < 1e-9);
    }
    assert_eq!(through_plugin.decisions.len(), through_chain.decisions.len());
}

#[test]
fn the_plugin_gets_the_tool_length_of_the_command_line() {
    let (plugins, registry, _) = loaded(&["plugin-head-head"]);
    let (mut m, origin) = machine(&registry, "fork-head-bc");
    m.chain.tool_length = 42.5;
    let kin = plugins.kinematics(&m, &origin).expect("verified with the other tool length");
    let zero = postpro_kin::Joints::zeros(5);
    // At all-zero the tip is the tool length below the nose (150 mm above the machine zero,
    // 600 mm above the part zero).
    assert!((kin.forward(&zero).tip.z - (150.0 - 42.5 + 600.0)).abs() < 1e-12);
}

#[test]
fn the_definitions_only_plugin_registers_two_machines() {
    let (plugins, registry, errors) = loaded(&["plugin-yaml-machines"]);
    assert!(errors.is_empty(), "{errors:?}");
    let p = &plugins.plugins()[0];
    assert!(p.kinematics_machines().is_empty());
    let lib = library("plugin-yaml-machines");
    for (name, topology) in [("trunnion-ac", "5-axis table-table"), ("shop-vmc-a4", "4-axis (table)")] {
        let (m, origin) = machine(&registry, name);
        assert_eq!(m.topology().label(), topology);
        assert_eq!(origin, Origin::Plugin { library: lib.clone() });
        assert!(matches!(plugins.solver(&m, &origin), Ok(Solver::Built(_))));
    }
    let (m, origin) = machine(&registry, "shop-trunnion-ac");
    let solver = plugins.solver(&m, &origin).expect("the chain");
    let source = hypar();
    solve(solver.kinematics(), &postpro_cl::read(&source), &m.policy).expect("solves");
}

#[test]
fn a_wrong_abi_version_is_refused_by_field_and_the_next_load_works() {
    let mut plugins = Plugins::new();
    let lib = library("fixture-plugin-wrong-abi");
    let e = plugins.load(&lib).expect_err("ABI 7");
    assert!(matches!(e, PluginError::Abi { field: "ABI version", .. }), "{e:?}");
    assert_eq!(e.to_string(), format!("plugin `{}`: ABI version 7, expected 1", lib.display()));
    assert_eq!(e.library(), Some(lib.as_path()));
    assert!(plugins.plugins().is_empty());
    plugins.load(&library("plugin-head-head")).expect("the next plugin loads");
    assert_eq!(plugins.plugins().len(), 1);
}

#[test]
fn a_library_without_the_entry_symbol_is_not_a_plugin() {
    let lib = library("fixture-plugin-no-entry");
    let e = Plugins::new().load(&lib).expect_err("no entry");
    assert_eq!(
        e.to_string(),
        format!("`{}` is not a postpro plugin: it exports no symbol `postpro_plugin_entry`", lib.display())
    );
}

#[test]
fn files_that_are_no_library_or_missing_are_errors() {
    let dir = temp_dir("not-a-library");
    let fake = dir.join(library_file_name("fake"));
    std::fs::write(&fake, "this is text, not a shared library\n").expect("write");
    let mut plugins = Plugins::new();
    let e = plugins.load(&fake).expect_err("not a library");
    assert!(e.to_string().starts_with(&format!("cannot load plugin `{}`: ", fake.display())), "{e}");
    let e = plugins.load(&dir.join("missing.so")).expect_err("missing");
    assert!(matches!(e, PluginError::Io { .. }), "{e:?}");
    assert!(e.to_string().contains("missing.so"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The good machine of the misbehaving fixture still works, and solves a pose.
fn good_machine_works(plugins: &Plugins, registry: &Registry) {
    let (m, origin) = machine(registry, "fixture-good");
    let kin = plugins.kinematics(&m, &origin).expect("fixture-good is fine");
    let pose = Pose { tip: Point3::new(1.0, 2.0, 3.0), axis: Unit::new_normalize(Vector3::new(0.3, 0.2, 1.0)) };
    let mut out = Solutions::new();
    kin.try_inverse(&pose, &mut out).expect("solutions");
    assert_eq!(out.len(), 2);
}

#[test]
fn each_misbehaving_machine_is_a_clear_error_of_its_own() {
    let (plugins, registry, errors) = loaded(&["fixture-plugin-misbehaving"]);
    let lib = library("fixture-plugin-misbehaving");
    let shown = lib.display().to_string();
    // Registration: the broken definition (located in the plugin's text) and the kinematics
    // without a definition; the other machines are registered.
    let messages: Vec<String> = errors.iter().map(ToString::to_string).collect();
    assert_eq!(messages.len(), 2, "{messages:#?}");
    let PluginError::Machine(postpro_machine::MachineError::Definition(d)) = &errors[0] else {
        panic!("{:?}", errors[0])
    };
    assert_eq!(d.file, format!("plugin {shown}: machines/fixture-broken.yaml"));
    assert_eq!((d.line, d.message.as_str()), (7, "axes[2].vmax: `30 m/min` is a linear velocity on a rotary axis"));
    assert_eq!(
        messages[1],
        format!("plugin `{shown}`: it has kinematics for machine `fixture-undefined` but no definition of it")
    );
    assert!(registry.find("fixture-broken").is_err());

    let expect = |name: &str| -> PluginError {
        let (m, origin) = machine(&registry, name);
        let e = plugins.kinematics(&m, &origin).expect_err(name);
        assert_eq!(e.machine(), Some(name));
        // postpro goes on: the next call works.
        good_machine_works(&plugins, &registry);
        e
    };
    let e = expect("fixture-panics");
    assert!(matches!(e, PluginError::Call { call: "inverse", failure: CallFailure::Panicked, .. }), "{e:?}");
    let text = e.to_string();
    assert!(
        text.starts_with(&format!(
            "plugin `{shown}` panicked in `inverse` of machine `fixture-panics`: fixture-panics: a bug in the \
             inverse kinematics (at "
        )),
        "{text}"
    );
    assert!(text.contains("src/lib.rs:"), "the panic's location: {text}");

    let e = expect("fixture-error");
    assert_eq!(
        e.to_string(),
        format!(
            "plugin `{shown}` failed in `inverse` of machine `fixture-error`: fixture-error: the head is not referenced"
        )
    );

    let e = expect("fixture-no-solution");
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("plugin `{shown}` returned no solution for machine `fixture-no-solution` at tip (")),
        "{text}"
    );
    assert!(text.contains("which the definition's chain reaches (X="), "{text}");

    let e = expect("fixture-invalid-solution");
    let text = e.to_string();
    assert!(
        text.starts_with(&format!(
            "plugin `{shown}` returned an invalid solution for machine `fixture-invalid-solution` at tip ("
        )),
        "{text}"
    );
    assert!(text.contains("solution 1 (X=") && text.contains("mm from the pose"), "{text}");

    let e = expect("fixture-disagrees");
    let text = e.to_string();
    assert!(
        text.starts_with(&format!(
            "plugin `{shown}`: the kinematics of machine `fixture-disagrees` disagree with its definition: at X="
        )),
        "{text}"
    );
    assert!(text.contains("(0.500000 mm, 0.000000° apart)"), "{text}");

    let e = expect("fixture-one-branch");
    let text = e.to_string();
    assert!(
        text.starts_with(&format!(
            "plugin `{shown}`: the inverse kinematics of machine `fixture-one-branch` misses a solution: at tip ("
        )),
        "{text}"
    );
    assert!(text.contains("the definition's chain finds X=") && text.contains("the plugin returns X="), "{text}");

    // `check` finds the same six, machine by machine.
    let mut refused: Vec<String> =
        plugins.check(&registry).iter().filter_map(|e| e.machine().map(str::to_string)).collect();
    refused.sort();
    assert_eq!(
        refused,
        [
            "fixture-disagrees",
            "fixture-error",
            "fixture-invalid-solution",
            "fixture-no-solution",
            "fixture-one-branch",
            "fixture-panics"
        ]
    );
}

#[test]
fn a_failure_during_a_solve_is_kept_until_taken() {
    let (plugins, registry, _) = loaded(&["fixture-plugin-misbehaving"]);
    let (m, origin) = machine(&registry, "fixture-panics");
    // Without the check at load, as a plugin that fails only on some poses would.
    let kin = plugins.open_kinematics(&m, &origin).expect("created");
    let source = hypar();
    let result = solve(&kin, &postpro_cl::read(&source), &m.policy);
    assert!(result.is_err(), "the policy finds no solution");
    assert!(kin.has_failed());
    let e = kin.take_error().expect("the panic is kept");
    assert!(e.to_string().contains("panicked in `inverse`"), "{e}");
    assert!(kin.take_error().is_none(), "taken once");
    // The plugin is still usable: its forward kinematics, and the same call fails the same way.
    let zero = postpro_kin::Joints::zeros(5);
    assert!((kin.try_forward(&zero).expect("forward works").tip.z + 100.0).abs() < 1e-12);
    let pose = kin.forward(&zero);
    let mut out = Solutions::new();
    kin.inverse(&pose, &mut out);
    assert!(out.is_empty());
    assert!(matches!(kin.take_error(), Some(PluginError::Call { failure: CallFailure::Panicked, .. })));
    good_machine_works(&plugins, &registry);
}

#[test]
fn a_library_is_loaded_once_and_outlives_the_host_while_used() {
    let lib = library("plugin-head-head");
    let mut plugins = Plugins::new();
    plugins.load(&lib).expect("loads");
    // The same file by another path is the same plugin.
    let other = lib.parent().expect("folder").join(".").join(lib.file_name().expect("name"));
    plugins.load(&other).expect("loads");
    assert_eq!(plugins.plugins().len(), 1);
    let mut registry = Registry::builtin().expect("built-ins");
    assert!(plugins.register(&mut registry).is_empty());
    let (m, origin) = machine(&registry, "fork-head-bc");
    let kin = plugins.kinematics(&m, &origin).expect("verified");
    drop(plugins);
    // The adapter holds the library: it still answers.
    let mut out = Solutions::new();
    kin.try_inverse(&kin.forward(&postpro_kin::Joints::from_slice(&[1.0, 2.0, -600.0, 0.4, 0.3])), &mut out)
        .expect("after the host is gone");
    assert_eq!(out.len(), 2);
}

#[test]
fn a_folder_loads_its_libraries_only() {
    let dir = temp_dir("folder");
    for p in ["plugin-head-head", "plugin-yaml-machines"] {
        std::fs::copy(library(p), dir.join(library_file_name(p))).expect("copy");
    }
    std::fs::write(dir.join("README.txt"), "not a plugin").expect("write");
    let mut plugins = Plugins::new();
    assert!(plugins.load_dir(&dir).is_empty());
    let names: Vec<&str> = plugins.plugins().iter().map(|p| p.name()).collect();
    assert_eq!(names, ["plugin-head-head", "plugin-yaml-machines"]);
    let mut registry = Registry::builtin().expect("built-ins");
    assert!(plugins.register(&mut registry).is_empty());
    assert_eq!(
        registry.find("fork-head-bc").expect("found").origin,
        Origin::Plugin { library: dir.join(library_file_name("plugin-head-head")) }
    );
    let e = Plugins::new().load_dir(&dir.join("missing"));
    assert_eq!(e.len(), 1);
    assert!(matches!(e[0], PluginError::Io { .. }));
    let _ = std::fs::remove_dir_all(&dir);
}
