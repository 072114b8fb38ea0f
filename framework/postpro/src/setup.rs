//! The job's set-up on the command line: how the CL file is read (`--cl-units`, `--arc-sense`),
//! and what this job adds to the machine (`--setup FILE.yaml`, `--work-offset`, `--part-origin`,
//! `--tool-table`, `--units`). The set-up file gives defaults; the options override it; the
//! machine definition is the default of both.

use std::path::PathBuf;

use nalgebra::{Point3, Vector3};
use postpro_cl::{ArcSense, LengthUnit, ReadOptions};
use postpro_machine::model::{Machine, ProgramUnits};
use postpro_machine::setup::{Setup, WorkOffset, load_setup};
use postpro_machine::tools::{ToolTable, load_tool_table};

use crate::report;

/// How the CL file is read.
#[derive(Debug, Default, clap::Args)]
pub(crate) struct ReadArgs {
    /// The CL file's length unit, whatever it declares (Creo and Fusion write `UNITS/INCHES`
    /// over millimetre data).
    #[arg(long, value_enum, value_name = "mm|inch")]
    cl_units: Option<UnitArg>,
    /// The sense of CIRCLE and MOVARC arcs about their axis vector as written, instead of the CAM
    /// system's convention (NX and Makino: clockwise; SOLIDWORKS, Fusion, Creo:
    /// counter-clockwise).
    #[arg(long, value_enum, value_name = "cw|ccw")]
    arc_sense: Option<SenseArg>,
}

/// A length unit on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum UnitArg {
    Mm,
    Inch,
}

/// An arc sense on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum SenseArg {
    Cw,
    Ccw,
}

impl ReadArgs {
    /// The reader's options.
    pub(crate) fn options(&self) -> ReadOptions {
        ReadOptions {
            arc_sense: self.arc_sense.map(|s| match s {
                SenseArg::Cw => ArcSense::Cw,
                SenseArg::Ccw => ArcSense::Ccw,
            }),
            cl_units: self.cl_units.map(|u| match u {
                UnitArg::Mm => LengthUnit::Mm,
                UnitArg::Inch => LengthUnit::Inch,
            }),
        }
    }
}

/// What this job adds to the machine.
#[derive(Debug, Default, clap::Args)]
pub(crate) struct SetupArgs {
    #[command(flatten)]
    pub(crate) read: ReadArgs,
    /// A set-up file (YAML: `work_offset`, `part_origin`, `work_offset_at`, `units`,
    /// `tool_table`; docs/setup.md); the options below override it.
    #[arg(long, value_name = "FILE.yaml")]
    setup: Option<PathBuf>,
    /// The work offset the program is written in: `G54`…`G59`, `G54.1 P7`, `G505`, `G59.1`,
    /// `preset 3` (Heidenhain); default `G54` (Heidenhain: `preset 1`).
    #[arg(long, value_name = "CODE", value_parser = parse_work_offset)]
    work_offset: Option<WorkOffset>,
    /// Where the part zero sits from the machine's rotation reference (the intersection of its
    /// table axes), mm, for machines whose rotary axes carry the part; default the machine
    /// definition's `part_origin`.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_xyz, allow_hyphen_values = true)]
    part_origin: Option<Vector3<f64>>,
    /// The shop's tool table (YAML or CSV: number, name, length, radius, h, d; docs/setup.md):
    /// each tool's offsets and length.
    #[arg(long, value_name = "FILE")]
    tool_table: Option<PathBuf>,
    /// The units the program is written in (default the machine definition's).
    #[arg(long, value_enum, value_name = "mm|inch")]
    units: Option<UnitArg>,
    /// Every warning is an error: nothing is written where one was given.
    #[arg(long)]
    pub(crate) strict: bool,
}

fn parse_work_offset(s: &str) -> Result<WorkOffset, String> {
    s.parse::<WorkOffset>().map_err(|e| e.to_string())
}

fn parse_xyz(s: &str) -> Result<Vector3<f64>, String> {
    let values: Vec<f64> = s
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected three numbers in mm separated by commas (`0,0,-85.3`), found `{s}`"))?;
    match values[..] {
        [x, y, z] if values.iter().all(|v| v.is_finite()) => Ok(Vector3::new(x, y, z)),
        _ => Err(format!("expected three numbers in mm separated by commas (`0,0,-85.3`), found `{s}`")),
    }
}

/// The set-up in effect: the file's, with the options over it.
#[derive(Clone, Debug, Default)]
pub(crate) struct JobSetup {
    /// The work offset asked for (`None`: the dialect's default).
    pub(crate) work_offset: Option<WorkOffset>,
    /// The part zero from the rotation reference.
    pub(crate) part_origin: Option<Vector3<f64>>,
    /// The work offset's position in machine coordinates.
    pub(crate) work_offset_at: Option<Point3<f64>>,
    /// The program's units (`None`: the machine's).
    pub(crate) units: Option<ProgramUnits>,
    /// The tool table.
    pub(crate) tool_table: Option<ToolTable>,
}

impl JobSetup {
    /// The program's units on `machine`.
    pub(crate) fn units(&self, machine: &Machine) -> ProgramUnits {
        self.units.unwrap_or(machine.units)
    }
}

impl SetupArgs {
    /// The set-up in effect, or the rendered error of the file that does not load.
    pub(crate) fn load(&self) -> Result<JobSetup, String> {
        let file = match &self.setup {
            Some(path) => load_setup(path).map_err(|e| report::render(&e))?,
            None => Setup::default(),
        };
        let table_path = self.tool_table.clone().or(file.tool_table.clone());
        let tool_table = match &table_path {
            Some(path) => Some(load_tool_table(path).map_err(|e| report::render(&e))?),
            None => None,
        };
        let units = self
            .units
            .map(|u| match u {
                UnitArg::Mm => ProgramUnits::Mm,
                UnitArg::Inch => ProgramUnits::Inch,
            })
            .or(file.units);
        Ok(JobSetup {
            work_offset: self.work_offset.or(file.work_offset),
            part_origin: self.part_origin.or(file.part_origin),
            work_offset_at: file.work_offset_at,
            units,
            tool_table,
        })
    }
}
