//! `postpro`: the command line. `postpro --machine NAME FILE.cl` writes the NC program (the
//! main job, `emit`); subcommands check CL files, list machines, solve the kinematics, predict the feed and
//! orient 3+2 set-ups.
//!
//! Exit codes: 0 when the input reads, 1 for input errors (a CL file or machine definition that
//! does not read, a missing file), 2 for usage errors (clap's own code).

mod check;
mod emit;
mod html;
mod job;
mod machines;
mod memory;
mod orient;
mod plot;
mod predict;
mod progress;
mod report;
mod scratch;
mod setup;
mod solve;
mod stream;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Post-processor for multi-axis CNC milling: APT/CL in, NC programs out.
#[derive(Debug, Parser)]
#[command(
    name = "postpro",
    version,
    about,
    propagate_version = true,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    job: emit::EmitArgs,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Read a CL file and print a summary: CAM system, units, moves, axes, tools, feeds,
    /// bounding box, path length, arcs, and warnings by word.
    Check(check::CheckArgs),
    /// List the known machines (built in, and the files of `--dir` and POSTPRO_MACHINE_PATH), or
    /// validate one machine definition with `--check FILE`.
    Machines(machines::MachinesArgs),
    /// Solve the inverse kinematics of a CL file on one machine: the axis values of every
    /// position, the decisions (branch switches, singularities, retracts) and the points added
    /// by linearization.
    Solve(solve::SolveArgs),
    /// Predict the feed the machine will really reach: per block the lowest and mean feed, what
    /// holds it back and the time; the cycle time and the time lost to slowdowns; samples as
    /// CSV/JSON and an SVG report.
    Predict(predict::PredictArgs),
    /// Find the 3+2 set-up that makes the machine fastest (paper 004): per path and for the
    /// whole part, the rotary angles that point the feed at a jerk-polytope vertex, the reach
    /// there, and the predicted cycle time against the original; `--apply OUT` writes it.
    Orient(orient::OrientArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let Some(command) = cli.command else {
        if !cli.job.given() {
            use clap::CommandFactory;
            let _ = Cli::command().print_help();
            return ExitCode::from(2);
        }
        return emit::run(&cli.job);
    };
    match command {
        Command::Check(args) => check::run(&args),
        Command::Machines(args) => machines::run(&args),
        Command::Solve(args) => solve::run(&args),
        Command::Predict(args) => predict::main(&args),
        Command::Orient(args) => orient::run(&args),
    }
}
