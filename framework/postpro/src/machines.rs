//! `postpro machines`: list every known machine (built in, the files of the folders given by
//! `--dir` and `POSTPRO_MACHINE_PATH`, and the plugins: `--plugin FILE`, `POSTPRO_PLUGIN_PATH`,
//! the `plugins` folder beside the binary), or validate one definition with `--check FILE`.
//!
//! The kinematics of every plugin machine with `solver: plugin` is loaded and checked against
//! its definition: a machine whose kinematics is refused is listed with the solver
//! `plugin (refused)` and its error printed. Every problem is printed and the exit code is 1,
//! but the machines that load are listed all the same.

use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use postpro_machine::model::{Clearance, Machine, SolverKind};
use postpro_machine::{Entry, MachineError, Registry};
use postpro_plugins::Plugins;

/// The environment variable with extra machine folders, separated like `PATH` (`:` on Unix).
const PATH_VARIABLE: &str = "POSTPRO_MACHINE_PATH";

/// Arguments of `postpro machines`.
#[derive(Debug, clap::Args)]
pub(crate) struct MachinesArgs {
    /// Print the list as JSON (stable keys) instead of a table.
    #[arg(long, conflicts_with = "check")]
    json: bool,
    /// Also load every `*.yaml` and `*.yml` machine file of this folder (repeatable). The folders
    /// in the environment variable POSTPRO_MACHINE_PATH (colon-separated) are loaded first.
    #[arg(long = "dir", value_name = "DIR")]
    dirs: Vec<PathBuf>,
    /// Also load this plugin library (repeatable) and check its machines' kinematics. The
    /// `plugins` folder beside postpro and the folders in POSTPRO_PLUGIN_PATH are loaded first.
    #[arg(long = "plugin", value_name = "FILE", conflicts_with = "check")]
    plugins: Vec<PathBuf>,
    /// Validate one machine definition file: print its diagnostic and exit with 1 if it has an
    /// error, or print a one-line summary and exit with 0.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
}

pub(crate) fn run(args: &MachinesArgs) -> ExitCode {
    if let Some(file) = &args.check {
        return check(file);
    }
    let mut dirs: Vec<PathBuf> = std::env::var_os(PATH_VARIABLE)
        .map(|v| std::env::split_paths(&v).filter(|p| !p.as_os_str().is_empty()).collect())
        .unwrap_or_default();
    dirs.extend(args.dirs.iter().cloned());
    let (mut registry, skipped) = match Registry::with_dirs(&dirs) {
        Ok(r) => r,
        Err(e) => {
            eprint!("{}", render(&e));
            return ExitCode::from(1);
        }
    };
    // Skipped files are warnings (the others are listed) but still make the exit code 1.
    let mut errors: Vec<String> = skipped.iter().map(|s| crate::report::render(s)).collect();
    let mut plugins = Plugins::new();
    let mut plugin_errors = plugins.discover(&args.plugins);
    plugin_errors.extend(plugins.register(&mut registry));
    plugin_errors.extend(plugins.check(&registry));
    let refused: HashSet<String> =
        plugin_errors.iter().filter_map(|e| e.machine()).map(str::to_ascii_lowercase).collect();
    errors.extend(plugin_errors.iter().map(|e| crate::report::render(e)));
    let mut err = std::io::stderr().lock();
    for e in &errors {
        let _ = err.write_all(e.as_bytes());
    }
    let mut out = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut out, &json(registry.entries(), &refused))
            .map_err(std::io::Error::from)
            .and_then(|()| writeln!(out))
    } else {
        out.write_all(table(registry.entries(), &refused).as_bytes())
    };
    match written {
        // `postpro machines | head`: the reader has what it wanted.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        Err(e) => {
            let _ = writeln!(err, "error: cannot write the list: {e}");
            return ExitCode::from(1);
        }
        Ok(()) => {}
    }
    if errors.is_empty() { ExitCode::SUCCESS } else { ExitCode::from(1) }
}

/// `postpro machines --check FILE`.
fn check(file: &Path) -> ExitCode {
    let text = match std::fs::read_to_string(file) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: cannot read `{}`: {e}", file.display());
            return ExitCode::from(1);
        }
    };
    match postpro_machine::parse(&file.display().to_string(), &text) {
        Ok(m) => {
            // Without a `clearance` key the machine has the default one: say so.
            let default = postpro_machine::parse_raw("", &text).is_ok_and(|r| r.clearance.is_none());
            println!(
                "{}: ok: `{}`, {}, {} solver, {} dialect, axes {}, units {}, {}",
                file.display(),
                m.name,
                m.topology().label(),
                solver(&m),
                m.dialect,
                letters(&m),
                m.units,
                clearance(&m, default)
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprint!("{}", render(&e));
            ExitCode::from(1)
        }
    }
}

/// The miette rendering (file:line:column, the source line, a caret, what was expected),
/// without colours like `postpro check`'s diagnostics.
fn render(e: &MachineError) -> String {
    crate::report::render(e)
}

/// `clearance Z 500 mm (machine coordinates)`, with `(default: …)` when the file has none.
fn clearance(m: &Machine, default: bool) -> String {
    match m.clearance {
        Clearance::SafeZ(z) => {
            let letter = m.spindle_linear_axis().map_or("Z", |i| m.axes[i].letter.as_str());
            let note = if default {
                format!(", the default: the end of the {letter} travel away from the part")
            } else {
                String::new()
            };
            format!("clearance {letter} {} mm (machine coordinates{note})", z + 0.0)
        }
        Clearance::Retract(d) => format!("clearance retract {d} mm along the tool axis"),
    }
}

fn solver(m: &Machine) -> &'static str {
    match m.solver {
        SolverKind::Generic => "generic",
        SolverKind::ClosedForm(_) => "closed-form",
        SolverKind::Plugin => "plugin",
    }
}

/// The solver column: `plugin (refused)` for a plugin machine whose kinematics did not load.
fn solver_cell(m: &Machine, refused: &HashSet<String>) -> &'static str {
    if m.solver == SolverKind::Plugin && refused.contains(&m.name.to_ascii_lowercase()) {
        "plugin (refused)"
    } else {
        solver(m)
    }
}

/// `X Y Z A C`
fn letters(m: &Machine) -> String {
    m.axes.iter().map(|a| a.letter.as_str()).collect::<Vec<_>>().join(" ")
}

/// One row per machine, columns aligned.
fn table(entries: &[Entry], refused: &HashSet<String>) -> String {
    let mut rows: Vec<[String; 6]> =
        vec![["name", "aliases", "topology", "solver", "dialect", "origin"].map(String::from)];
    for e in entries {
        let m = &e.machine;
        let aliases = if m.aliases.is_empty() { "-".to_string() } else { m.aliases.join(", ") };
        rows.push([
            m.name.clone(),
            aliases,
            m.topology().label().to_string(),
            solver_cell(m, refused).to_string(),
            m.dialect.clone(),
            e.origin.to_string(),
        ]);
    }
    let mut widths = [0usize; 6];
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut t = String::new();
    for row in &rows {
        let mut line = String::new();
        for (k, (cell, w)) in row.iter().zip(widths).enumerate() {
            if k + 1 == row.len() {
                line.push_str(cell);
            } else {
                line.push_str(&format!("{cell:<w$}  "));
            }
        }
        t.push_str(line.trim_end());
        t.push('\n');
    }
    t
}

/// The list as JSON: one object per machine with the keys `name`, `aliases`, `description`,
/// `topology`, `solver`, `dialect`, `axes` and `origin`.
fn json(entries: &[Entry], refused: &HashSet<String>) -> serde_json::Value {
    let list = entries
        .iter()
        .map(|e| {
            let m = &e.machine;
            serde_json::json!({
                "name": m.name,
                "aliases": m.aliases,
                "description": m.description,
                "topology": m.topology().label(),
                "solver": solver_cell(m, refused),
                "dialect": m.dialect,
                "axes": m.axes.iter().map(|a| a.letter.as_str()).collect::<Vec<_>>(),
                "origin": e.origin.to_string(),
            })
        })
        .collect();
    serde_json::Value::Array(list)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn builtin() -> Registry {
        Registry::builtin().expect("the built-in machines load")
    }

    #[test]
    fn the_table_has_a_row_per_machine() {
        let r = builtin();
        let t = table(r.entries(), &HashSet::new());
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), r.entries().len() + 1);
        assert!(lines[0].starts_with("name "), "{t}");
        let mikron = lines.iter().find(|l| l.starts_with("mikron-ucp710 ")).expect("a Mikron row");
        for cell in ["mikron", "5-axis table-table", "closed-form", "siemens-840d", "built in"] {
            assert!(mikron.contains(cell), "`{cell}` missing in `{mikron}`");
        }
        assert!(t.contains("5-axis head-head"), "{t}");
    }

    #[test]
    fn the_json_has_stable_keys() {
        let r = builtin();
        let j = json(r.entries(), &HashSet::new());
        let list = j.as_array().expect("an array");
        assert_eq!(list.len(), r.entries().len());
        let keys: Vec<&str> = list[0].as_object().expect("an object").keys().map(String::as_str).collect();
        assert_eq!(keys, ["aliases", "axes", "description", "dialect", "name", "origin", "solver", "topology"]);
        let maho = list.iter().find(|m| m["name"] == "maho600e").expect("maho600e");
        assert_eq!(maho["solver"], "closed-form");
        assert_eq!(maho["origin"], "built in");
        assert_eq!(maho["axes"], serde_json::json!(["X", "Y", "Z", "B", "C"]));
    }

    #[test]
    fn diagnostics_render_without_colour() {
        let e = postpro_machine::parse("m.yaml", "name: x\nnme: y\n").expect_err("an unknown key");
        let shown = render(&e);
        assert!(shown.contains("unknown key `nme`"), "{shown}");
        assert!(shown.contains("[m.yaml:2:1]"), "{shown}");
        assert!(!shown.contains('\u{1b}'), "no escape codes: {shown}");
    }
}
