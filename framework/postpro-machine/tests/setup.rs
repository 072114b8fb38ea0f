//! Data-driven tests of the job files: every `tests/setups/*.yaml` and `tests/tools/*.{yaml,csv}`
//! is read from disk as the command line reads it (`load_setup`, `load_tool_table`); an `ok_*`
//! file's result and an `err_*` file's rendered diagnostic (no colours, 100 columns) are pinned
//! by insta snapshots. File names in errors are relative to the crate (the tests' working
//! folder).

mod support;

use std::path::Path;

use postpro_machine::setup::{WorkOffset, load_setup};
use postpro_machine::tools::{ToolTable, load_tool_table};
use postpro_machine::{FileKind, MachineError};
use support::render;

/// The path as the tests name it: relative to the crate folder.
fn relative(path: &Path) -> &Path {
    path.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap_or(path)
}

fn is_ok_case(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n.to_string_lossy().starts_with("ok_"))
}

/// The error must be a located diagnostic of `kind`.
fn located(err: &MachineError, kind: FileKind, name: &Path) {
    match err {
        MachineError::Definition(d) => {
            assert_eq!(d.kind, kind, "{}", name.display());
            assert!(d.line >= 1 && d.column >= 1, "{}", name.display());
        }
        e => panic!("{}: not a located diagnostic: {e:?}", name.display()),
    }
}

#[test]
fn setup_files() {
    insta::glob!("setups/*.yaml", |path| {
        let path = relative(path);
        match load_setup(path) {
            Ok(setup) if is_ok_case(path) => insta::assert_debug_snapshot!(setup),
            Ok(setup) => panic!("{} loads: {setup:?}", path.display()),
            Err(e) if is_ok_case(path) => panic!("{} does not load:\n{}", path.display(), render(&e)),
            Err(e) => {
                located(&e, FileKind::Setup, path);
                insta::assert_snapshot!(render(&e));
            }
        }
    });
}

#[test]
fn tool_tables() {
    insta::glob!("tools/*.{yaml,csv}", |path| {
        let path = relative(path);
        match load_tool_table(path) {
            Ok(table) if is_ok_case(path) => insta::assert_snapshot!(listing(&table)),
            Ok(table) => panic!("{} loads: {table:?}", path.display()),
            Err(e) if is_ok_case(path) => panic!("{} does not load:\n{}", path.display(), render(&e)),
            Err(e) => {
                located(&e, FileKind::ToolTable, path);
                insta::assert_snapshot!(render(&e));
            }
        }
    });
}

/// A length in mm to 1e-9 (`3.5 in` is 88.89999999999999 mm in binary).
fn mm(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{} mm", (v * 1e9).round() / 1e9))
}

/// One line per tool, with the registers' defaults applied.
fn listing(table: &ToolTable) -> String {
    let mut out = String::new();
    for t in &table.tools {
        out += &format!(
            "T{} name {:?} length {} radius {} h {:?} d {:?} -> H{} D{}\n",
            t.number,
            t.name,
            mm(t.length),
            mm(t.radius),
            t.h,
            t.d,
            t.length_register(),
            t.radius_register()
        );
    }
    out
}

#[test]
fn a_setup_takes_its_tool_table_from_its_folder() {
    let setup = load_setup(Path::new("tests/setups/ok_all_keys.yaml")).expect("loads");
    assert_eq!(setup.work_offset, Some(WorkOffset::G54_1(7)));
    let tools = setup.tool_table.expect("a tool table");
    assert_eq!(tools, Path::new("tests/setups/tools.csv"));
    let table = load_tool_table(&tools).expect("the set-up's tool table loads");
    assert_eq!(table.get(1).and_then(|t| t.radius), Some(5.0));
}

#[test]
fn the_csv_and_yaml_tables_of_one_shop_agree() {
    let yaml = load_tool_table(Path::new("tests/tools/ok_shop.yaml")).expect("YAML");
    let csv = load_tool_table(Path::new("tests/tools/ok_shop.csv")).expect("CSV");
    assert_eq!(yaml, csv);
    assert_eq!(mm(csv.get(2).and_then(|t| t.length)), "88.9 mm");
    assert_eq!(csv.get(12).map(|t| (t.length_register(), t.radius_register())), Some((32, 52)));
    assert_eq!(csv.get(7).map(|t| (t.length_register(), t.radius_register())), Some((7, 7)));
    assert!(csv.get(8).is_none());
}

#[test]
fn files_that_are_not_there_or_not_tables() {
    let e = load_setup(Path::new("tests/setups/missing.yaml")).expect_err("no such file");
    assert!(e.to_string().starts_with("cannot read `tests/setups/missing.yaml`"), "{e}");
    let e = load_tool_table(Path::new("tests/tools/missing.csv")).expect_err("no such file");
    assert!(e.to_string().starts_with("cannot read `tests/tools/missing.csv`"), "{e}");
    let e = load_tool_table(Path::new("tests/setups/ok_all_keys.txt")).expect_err("not a table format");
    assert_eq!(e.to_string(), "cannot tell the format of the tool table `tests/setups/ok_all_keys.txt`");
}
