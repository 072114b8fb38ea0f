//! Tool tables (`--tool-table FILE`): each tool's number, name, length, radius and offset
//! registers, from a YAML or a CSV file (by the file name's extension; `docs/setup.md` describes
//! both). The YAML file goes through [`raw`] (plain serde types); the CSV file through the
//! `csv` crate into the same [`raw::Tool`]s, each value with its cell's place. One check then
//! turns either into a [`ToolTable`]; every error names the file, line and column of the value
//! (for a CSV file, the row and the cell) and what was expected.
//!
//! ```
//! use postpro_machine::tools::{ToolTableFormat, parse_tool_table};
//! let csv = "number,name,length,diameter\n1,D10 ball,85.2,10\n2,drill 6.8,3.5 in,6.8\n";
//! let table = parse_tool_table("tools.csv", csv, ToolTableFormat::Csv).unwrap();
//! assert!((table.get(2).unwrap().length.unwrap() - 88.9).abs() < 1e-9); // 3.5 in
//! assert_eq!(table.get(2).unwrap().name.as_deref(), Some("drill 6.8"));
//! assert_eq!(table.get(1).unwrap().radius, Some(5.0));
//! assert_eq!(table.get(1).unwrap().length_register(), 1);
//! ```

mod csv_table;
pub mod raw;

use std::collections::HashMap;
use std::path::Path;

use crate::error::{Doc, FileKind, MachineError, line_column};
use crate::locate::{Span, locate};

/// A tool table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ToolTable {
    /// The tools, in the file's order; their numbers are unique.
    pub tools: Vec<ToolEntry>,
}

impl ToolTable {
    /// The tool with this number.
    pub fn get(&self, number: u32) -> Option<&ToolEntry> {
        self.tools.iter().find(|t| t.number == number)
    }
}

/// One tool.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ToolEntry {
    /// The tool number (`T`), ≥ 1.
    pub number: u32,
    /// A name or description.
    pub name: Option<String>,
    /// From the spindle nose (gauge line) to the tip (mm), > 0.
    pub length: Option<f64>,
    /// The cutter radius (mm), ≥ 0 (half the `diameter` where that was given).
    pub radius: Option<f64>,
    /// The length offset register as written ([`ToolEntry::length_register`] has the default).
    pub h: Option<u32>,
    /// The radius offset register as written ([`ToolEntry::radius_register`] has the default).
    pub d: Option<u32>,
}

impl ToolEntry {
    /// The length offset register: `h`, or the tool number.
    pub fn length_register(&self) -> u32 {
        self.h.unwrap_or(self.number)
    }

    /// The radius offset register: `d`, or the tool number.
    pub fn radius_register(&self) -> u32 {
        self.d.unwrap_or(self.number)
    }
}

/// The two file formats of a tool table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToolTableFormat {
    /// `.yaml` or `.yml`.
    Yaml,
    /// `.csv`.
    Csv,
}

impl ToolTableFormat {
    /// The format of a file, by its extension (without case).
    pub fn of(path: &Path) -> Option<ToolTableFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "yaml" | "yml" => Some(ToolTableFormat::Yaml),
            "csv" => Some(ToolTableFormat::Csv),
            _ => None,
        }
    }
}

/// Reads and checks a tool table, YAML or CSV by the file's extension.
pub fn load_tool_table(path: &Path) -> Result<ToolTable, MachineError> {
    let format = ToolTableFormat::of(path).ok_or_else(|| MachineError::ToolTableFormat { path: path.to_path_buf() })?;
    let text = std::fs::read_to_string(path).map_err(|source| MachineError::Io { path: path.to_path_buf(), source })?;
    parse_tool_table(&path.display().to_string(), &text, format)
}

/// Checks the text of a tool table; `file` is the name shown in errors. A leading byte-order
/// mark (spreadsheets write one) is dropped.
pub fn parse_tool_table(file: &str, text: &str, format: ToolTableFormat) -> Result<ToolTable, MachineError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let doc = Doc::of(FileKind::ToolTable, file, text);
    match format {
        ToolTableFormat::Yaml => {
            let raw = raw::ToolFile::from_yaml(text).map_err(|e| {
                let mut error = doc.yaml_error(&e);
                if let MachineError::Definition(d) = &mut error
                    && d.message == "invalid type: sequence"
                {
                    d.help = Some("a YAML tool table lists its tools under `tools:`".into());
                }
                error
            })?;
            check(&doc, &raw.tools, &|i, key| locate(text, path!["tools", i, key]))
        }
        ToolTableFormat::Csv => {
            let rows = csv_table::read(&doc)?;
            let tools: Vec<raw::Tool> = rows.iter().map(|r| r.tool.clone()).collect();
            check(&doc, &tools, &|i, key| rows[i].span(key))
        }
    }
}

/// The one check of both formats: unique numbers and length registers, a radius or a diameter
/// but not both, a positive length, no negative radius. `span(i, key)` is where the value `key`
/// of tool `i` is written (the tool itself where it is not).
fn check(doc: &Doc, tools: &[raw::Tool], span: &dyn Fn(usize, &str) -> Span) -> Result<ToolTable, MachineError> {
    let line = |i: usize, key: &str| line_column(&doc.text, span(i, key).offset).0;
    let mut numbers: HashMap<u32, usize> = HashMap::new();
    let mut registers: HashMap<u32, usize> = HashMap::new();
    let mut entries = Vec::with_capacity(tools.len());
    for (i, t) in tools.iter().enumerate() {
        let n = t.number.0;
        if let Some(&first) = numbers.get(&n) {
            return Err(doc.error_with_context(
                span(i, "number"),
                format!("tool {n} is defined twice, on lines {} and {}", line(first, "number"), line(i, "number")),
                "expected each tool number once".into(),
                (span(first, "number"), format!("tool {n} first defined here")),
            ));
        }
        numbers.insert(n, i);
        let length = t.length.map(|l| l.0);
        if let Some(l) = length
            && l <= 0.0
        {
            return Err(doc.error_at(
                span(i, "length"),
                format!("tool {n}: length {} mm is not positive", l + 0.0),
                "expected the length from the spindle nose (gauge line) to the tip, above 0; leave it out when unknown"
                    .into(),
                None,
            ));
        }
        let radius = match (t.radius, t.diameter) {
            (Some(_), Some(_)) => {
                return Err(doc.error_at(
                    span(i, "diameter"),
                    format!("tool {n} has both `radius` and `diameter`"),
                    "expected one of them (the diameter is halved into the radius)".into(),
                    None,
                ));
            }
            (Some(r), None) => Some((r.0, "radius")),
            (None, Some(d)) => Some((d.0 / 2.0, "diameter")),
            (None, None) => None,
        };
        if let Some((r, key)) = radius
            && r < 0.0
        {
            return Err(doc.error_at(
                span(i, key),
                format!("tool {n}: negative {key}"),
                format!("expected a {key} of 0 or more"),
                None,
            ));
        }
        let entry = ToolEntry {
            number: n,
            name: t.name.clone(),
            length,
            radius: radius.map(|(r, _)| r),
            h: t.h.map(|h| h.0),
            d: t.d.map(|d| d.0),
        };
        let h = entry.length_register();
        if let Some(&first) = registers.get(&h) {
            let (key, other_key) = (register_key(&tools[i]), register_key(&tools[first]));
            return Err(doc.error_with_context(
                span(i, key),
                format!(
                    "tool {n} uses the length register H{h} of tool {} (line {})",
                    tools[first].number.0,
                    line(first, other_key)
                ),
                "expected a length register no other tool uses (`h` defaults to the tool number)".into(),
                (span(first, other_key), format!("H{h} of tool {}", tools[first].number.0)),
            ));
        }
        registers.insert(h, i);
        entries.push(entry);
    }
    Ok(ToolTable { tools: entries })
}

/// Where a tool's length register is written: `h`, or `number` where it defaults to it.
fn register_key(tool: &raw::Tool) -> &'static str {
    if tool.h.is_some() { "h" } else { "number" }
}
