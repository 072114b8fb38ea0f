//! The tools of a program: for every tool change of the CL file, the tool's number, name, length
//! and radius offset registers, diameter, corner radius and length, from the CL file (`LOADTL`,
//! `LOAD/TOOL`, `TLDATA`, `CUTTER`, NX `TOOL PATH/…,TOOL,name`) and from the shop's tool table,
//! whose entries win: it is what the machine's controller holds.

use postpro_cl::{Item, ItemKind, Span, ToolPath, ToolShape};
use postpro_machine::model::Machine;
use postpro_machine::tools::ToolTable;

use crate::Warning;
use crate::block::Mode;

/// One tool of the program.
#[derive(Clone, Debug, PartialEq)]
pub struct Tool {
    /// Tool number (`T`).
    pub number: u32,
    /// Name, when the CL file or the tool table gives one.
    pub name: Option<String>,
    /// Length-offset register (`H`): the tool table's, the CL file's `ADJUST`, or the number.
    pub length_register: u32,
    /// Radius-offset register (`D`): the tool table's, or the number.
    pub radius_register: u32,
    /// Diameter (mm), when known.
    pub diameter: Option<f64>,
    /// Corner radius (mm), when known.
    pub corner_radius: Option<f64>,
    /// Length from the spindle nose to the tip (mm), when known.
    pub length: Option<f64>,
}

/// The tools of a program and where each is loaded.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tooling {
    /// The tools, one per number, in order of first use.
    pub tools: Vec<Tool>,
    /// Each tool change: the item index of its `ItemKind::ToolChange` in the tool path (or, for a
    /// tool the CL file never loads, of its first motion) and the tool (index into `tools`).
    pub changes: Vec<Change>,
}

/// One tool change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Change {
    /// The item the tool is loaded at.
    pub item: usize,
    /// Its CL statement.
    pub span: Span,
    /// The tool: an index into [`Tooling::tools`].
    pub tool: usize,
    /// The CL file loads no tool before its first motion: this one is assumed, and written.
    pub assumed: bool,
}

impl Tooling {
    /// The tool loaded at item `item`, if a change happens there.
    pub fn change_at(&self, item: usize) -> Option<&Change> {
        self.changes.binary_search_by_key(&item, |c| c.item).ok().map(|i| &self.changes[i])
    }
}

/// The tools of `path`, with `table`'s entries over the CL file's, and what had to be assumed.
pub fn tooling(path: &ToolPath, table: Option<&ToolTable>) -> (Tooling, Vec<Warning>) {
    let mut reader = ToolingReader::new(table);
    for item in &path.items {
        reader.item(item);
    }
    reader.finish()
}

/// Finds the tools of a tool path as its items come (see [`tooling`]).
#[derive(Clone, Debug)]
pub struct ToolingReader<'a> {
    table: Option<&'a ToolTable>,
    out: Tooling,
    warnings: Vec<Warning>,
    /// The geometry given since the last change (NX, SOLIDWORKS: before the change; Fusion:
    /// before too; Creo and CATIA give none): it belongs to the next change, or to the current
    /// tool when no change follows before the motion.
    shape: Option<ToolShape>,
    /// The change whose geometry may still follow.
    pending: Option<usize>,
    moved: bool,
    /// Items so far.
    count: usize,
}

impl<'a> ToolingReader<'a> {
    /// Before the first item, with the shop's tool table if any.
    pub fn new(table: Option<&'a ToolTable>) -> ToolingReader<'a> {
        ToolingReader {
            table,
            out: Tooling::default(),
            warnings: Vec::new(),
            shape: None,
            pending: None,
            moved: false,
            count: 0,
        }
    }

    /// The next item of the tool path.
    pub fn item(&mut self, item: &Item) {
        let k = self.count;
        self.count += 1;
        let (out, table) = (&mut self.out, self.table);
        match &item.kind {
            ItemKind::ToolShape(s) => match self.pending {
                // After the change, before its first motion (CUTTER after LOADTL): this tool's.
                Some(c) => {
                    let tool = out.changes[c].tool;
                    fill_shape(&mut out.tools[tool], s, table);
                }
                None => self.shape = Some(*s),
            },
            ItemKind::ToolChange(t) => {
                let tool = tool_index(&mut out.tools, t.number, t.name.clone(), t.adjust, table);
                if let Some(s) = self.shape.take() {
                    fill_shape(&mut out.tools[tool], &s, table);
                }
                out.changes.push(Change { item: k, span: item.span, tool, assumed: false });
                self.pending = Some(out.changes.len() - 1);
            }
            ItemKind::Move(_) | ItemKind::Arc(_) | ItemKind::Nurbs(_) => {
                if !self.moved && out.changes.is_empty() {
                    // No tool loaded before the first motion: the only tool of the table, or T1
                    // until the CL file loads one (`finish`).
                    let only = table.filter(|t| t.tools.len() == 1).map(|t| t.tools[0].number);
                    let tool = tool_index(&mut out.tools, only.unwrap_or(1), None, None, table);
                    if let Some(s) = self.shape.take() {
                        fill_shape(&mut out.tools[tool], &s, table);
                    }
                    out.changes.push(Change { item: k, span: item.span, tool, assumed: true });
                }
                self.moved = true;
                self.pending = None;
            }
            _ => {}
        }
    }

    /// The tools and their changes, and what had to be assumed: a tool the CL file moves before
    /// it loads one is the tool table's only one, else the first tool the file loads (the move is
    /// the way to its change: CATIA's tool-change macro goes to the change point first), else T1.
    pub fn finish(mut self) -> (Tooling, Vec<Warning>) {
        let out = &mut self.out;
        if !out.changes.first().is_some_and(|c| c.assumed) {
            return (self.out, self.warnings);
        }
        let only_tool = self.table.is_some_and(|t| t.tools.len() == 1);
        let first_loaded = out.changes.iter().find(|c| !c.assumed).map(|c| c.tool);
        let from = match first_loaded {
            _ if only_tool => "the only tool of the tool table",
            Some(loaded) => {
                let assumed = std::mem::replace(&mut out.changes[0].tool, loaded);
                if assumed != loaded && out.changes.iter().all(|c| c.tool != assumed) {
                    // The assumed T1 goes; what the CL file gave of its geometry is the tool's.
                    let gone = out.tools.remove(assumed);
                    let tool = &mut out.tools[if loaded > assumed { loaded - 1 } else { loaded }];
                    tool.diameter = tool.diameter.or(gone.diameter);
                    tool.corner_radius = tool.corner_radius.or(gone.corner_radius);
                    tool.length = tool.length.or(gone.length);
                    for c in &mut out.changes {
                        c.tool -= usize::from(c.tool > assumed);
                    }
                }
                "the first tool it loads"
            }
            None => "assumed",
        };
        let first = out.changes[0];
        let number = out.tools[first.tool].number;
        self.warnings.push(Warning {
            span: first.span,
            message: format!(
                "the CL file loads no tool before its first move: T{number} ({from}) is written; \
                 load the tool in the CL file (LOADTL, LOAD/TOOL) or give a tool table with one tool"
            ),
        });
        (self.out, self.warnings)
    }
}

/// The index of tool `number` in `tools`, added (with the table's entry) if new.
fn tool_index(
    tools: &mut Vec<Tool>,
    number: u32,
    name: Option<String>,
    adjust: Option<u32>,
    table: Option<&ToolTable>,
) -> usize {
    if let Some(i) = tools.iter().position(|t| t.number == number) {
        if tools[i].name.is_none() {
            tools[i].name = name;
        }
        return i;
    }
    let entry = table.and_then(|t| t.get(number));
    tools.push(Tool {
        number,
        name: entry.and_then(|e| e.name.clone()).or(name),
        length_register: entry.and_then(|e| e.h).or(adjust).unwrap_or(number),
        radius_register: entry.map_or(number, |e| e.radius_register()),
        diameter: entry.and_then(|e| e.radius).map(|r| 2.0 * r),
        corner_radius: None,
        length: entry.and_then(|e| e.length),
    });
    tools.len() - 1
}

/// The CL file's geometry for a tool, where the tool table gives none.
fn fill_shape(tool: &mut Tool, shape: &ToolShape, table: Option<&ToolTable>) {
    let entry = table.and_then(|t| t.get(tool.number));
    if entry.and_then(|e| e.radius).is_none() {
        tool.diameter = Some(shape.diameter);
    }
    tool.corner_radius = Some(shape.corner_radius);
    if entry.and_then(|e| e.length).is_none()
        && let Some(l) = shape.length.filter(|l| *l > 0.0)
    {
        tool.length = Some(l);
    }
}

/// The tool length each tool is solved with in `mode` on `machine`: 0 where the controller
/// applies it along the spindle (no rotary axis turns the tool), else the tool's own (the tool
/// table's, the CL file's, or the machine definition's when it gives one). `Err(tool)` for a
/// tool whose length is needed and unknown (a head machine in a joint mode); in TCP mode the
/// controller applies it, and the prediction takes the machine definition's.
pub fn kinematic_lengths(machine: &Machine, tooling: &Tooling, mode: Mode) -> Result<Vec<f64>, usize> {
    let head = !machine.chain.tool.is_empty();
    tooling
        .tools
        .iter()
        .enumerate()
        .map(|(i, t)| {
            if !head {
                return Ok(0.0);
            }
            let default = (machine.chain.tool_length > 0.0).then_some(machine.chain.tool_length);
            match t.length.or(default) {
                Some(l) => Ok(l),
                None if mode == Mode::Tcp => Ok(machine.chain.tool_length),
                None => Err(i),
            }
        })
        .collect()
}
