//! The main job streamed: the CL file is read two to four times, a window at a time
//! ([`ClFile`]), and nothing proportional to its length is held but a few bits per CL point.
//!
//! 1. **Survey**: the reader's items, their targets and the policy's first pass (the branch
//!    graph), the tools and their changes, whether the tool turns while cutting (the mode `auto`
//!    picks), what the reader passed over, the 3+2 set-ups guessed from the tool axes (where the
//!    rotary brakes lock and the working planes stand, for the prediction pass to write in; kept
//!    only where the steps agree).
//! 2. **Prediction**: the items again, the policy's second pass, the linearization and the motion
//!    program, each a stage handing on to the next; the prediction reads the blocks as they come
//!    and keeps its look-ahead; the steps are surveyed for the 3+2 set-ups.
//! 3. **Writing**: the same stages again, the motion program in its final frame, formatted and
//!    rendered block by block into a scratch file beside the output, the travels checked; the
//!    header (which names the lines of the worst slowdowns) is written last, before the body.
//!
//! Where the program does not depend on what the prediction pass finds ([`Writer::speculates`]),
//! the prediction pass writes the body as it goes and the slowdowns' comments are put in
//! afterwards ([`Speculation`], `postpro_emit::write_program_deferred`): the same program, without
//! the third pass. Where the rotary brakes lock and whether the 3+2 set-ups stand in working
//! planes are guessed from the survey's tool axes, and kept only where the steps prove them
//! right.
//!
//! Where the 3+2 set-ups stand in working planes the prediction pass was not in, whose frame
//! changes their blocks, a pass of its own predicts again on the blocks in the planes before the
//! writing: the header and comments are those of the program written. `postpro predict` runs
//! the passes but the writing ([`predict`]); `postpro solve` the survey and the stages up to the
//! linearization ([`solve`]).
//!
//! Every pass runs the same stages on the same items, so the step and block numbers the
//! prediction's marks name are those of the program written. An error in any pass leaves
//! nothing written (the output is renamed into place at the very end).

use std::collections::BTreeSet;
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use postpro_cl::{ClFile, Item, ItemKind, ItemSink, Motion, ProgramInfo, Span, TextKind, ToolAxis};
use postpro_emit::{Dialect, EmitError, Options, WriteError};
use postpro_kin::{
    BranchGraph, Collected, Kinematics, Linearizer, Placer, Shape, SolveError, Stretches, Target, ToolPlacer,
};
use postpro_machine::model::Machine;
use postpro_motion::travel::TravelCheck;
use postpro_motion::{AxisStretches, MotionSink, SetUps, Stage, Survey, Surveyor, ToolingReader};
use postpro_predict::moves::Reader;
use postpro_predict::{Blocks, MarkFinder, Predictor};

use crate::emit::ModeArg;
use crate::job::{Shapes, WRITTEN, warn_all};
use crate::predict::{MarkArgs, PredictionArgs};
use crate::progress::Progress;
use crate::report;
use crate::setup::SetupArgs;
use crate::solve::{Chosen, IktArgs};

/// What the passes are for.
pub(crate) enum Purpose<'a> {
    /// The main job: the program, written as `Program` says.
    Program(Program<'a>),
    /// `postpro predict`: the prediction alone, with `every_block` each block's row
    /// ([`crate::predict::BlockRows`]), with `csv` the samples' and blocks' CSV files there
    /// ([`crate::predict::CsvRows`]).
    Prediction { every_block: bool, csv: Option<&'a Path> },
    /// `postpro solve`: the axis values alone.
    Solution,
}

/// What the main job (or `postpro predict` or `postpro solve`, streamed) is asked for.
pub(crate) struct Request<'a> {
    /// The program, the prediction or the axis values.
    pub(crate) purpose: Purpose<'a>,
    /// The CL file.
    pub(crate) file: &'a Path,
    /// The machine.
    pub(crate) chosen: &'a Chosen,
    /// The policy's options.
    pub(crate) ikt: &'a IktArgs,
    /// The set-up's options.
    pub(crate) setup: &'a SetupArgs,
    /// The output mode asked for.
    pub(crate) mode: ModeArg,
    /// Controller dialect.
    pub(crate) dialect: &'a Dialect,
    /// How arcs, cycles and 3+2 set-ups are written.
    pub(crate) shapes: Shapes,
    /// Predict the feed and mark the slowdowns, with these options (`None`: `--no-predict`).
    pub(crate) prediction: Option<(&'a PredictionArgs, &'a MarkArgs)>,
}

/// How the main job writes the program.
pub(crate) struct Program<'a> {
    /// The template's name and text.
    pub(crate) template: &'a (String, String),
    /// Where (`-` for standard output).
    pub(crate) output: &'a Path,
    /// The program's name.
    pub(crate) name: String,
    /// Number the blocks.
    pub(crate) block_numbers: bool,
    /// How TCP mode gives the tool's orientation.
    pub(crate) tcp_orientation: postpro_emit::TcpOrientation,
    /// CL `INSERT` text as blocks (else as comments).
    pub(crate) insert_verbatim: bool,
    /// Say how long each pass took (`--timing`).
    pub(crate) timing: bool,
    /// Write the program in a pass of its own even where the prediction pass could (to compare).
    pub(crate) three_passes: bool,
}

impl Request<'_> {
    /// True for the main job, which writes a program.
    fn writes(&self) -> bool {
        matches!(self.purpose, Purpose::Program(_))
    }

    /// What an error says was not done.
    fn nothing(&self) -> &'static str {
        match self.purpose {
            Purpose::Program(_) => WRITTEN,
            Purpose::Prediction { .. } => crate::predict::PREDICTED,
            Purpose::Solution => crate::solve::SOLVED,
        }
    }
}

/// What the first pass found.
struct Surveyed {
    info: ProgramInfo,
    diagnostics: Vec<postpro_cl::Diagnostic>,
    choice: postpro_kin::Choice,
    /// Where the branch graph found a pose it cannot reach (reported once the reading is said).
    graph_error: Option<SolveError>,
    tooling: postpro_motion::Tooling,
    tool_warnings: Vec<postpro_motion::Warning>,
    turns_tool: bool,
    moves: bool,
    inserts: (usize, Option<Span>),
    /// The 3+2 set-ups guessed from the tool axes, for a pass that writes where the rotary brakes
    /// lock or the working planes stand before its steps say.
    stretches: AxisStretches,
}

/// The first pass's sink.
struct SurveySink<'a> {
    graph: BranchGraph<'a>,
    tolerance: f64,
    targets: Vec<Target>,
    tooling: ToolingReader<'a>,
    axis: Option<ToolAxis>,
    turns_tool: bool,
    moves: bool,
    inserts: (usize, Option<Span>),
    stretches: AxisStretches,
    error: Option<SolveError>,
}

impl ItemSink for SurveySink<'_> {
    fn push(&mut self, item: Item) {
        self.tooling.item(&item);
        match &item.kind {
            ItemKind::Move(m) => {
                let turned = self.axis.is_some_and(|a| (a.into_inner() - m.axis.into_inner()).norm() > 1e-6);
                self.turns_tool |= turned && matches!(m.motion, Motion::Feed(_));
                self.axis = Some(m.axis);
            }
            ItemKind::Text(TextKind::Insert, _) => {
                self.inserts.0 += 1;
                self.inserts.1.get_or_insert(item.span);
            }
            _ => {}
        }
        if !matches!(item.kind, ItemKind::Move(_) | ItemKind::Arc(_) | ItemKind::Nurbs(_)) {
            return;
        }
        self.moves = true;
        if self.error.is_some() {
            return;
        }
        self.targets.clear();
        postpro_kin::targets_of(&item, self.tolerance, &mut self.targets);
        for t in &self.targets {
            self.stretches.target(t.span.start, &t.pose.axis, t.rapid);
        }
        for t in &self.targets {
            if let Err(e) = self.graph.push(t) {
                self.error = Some(e);
                return;
            }
        }
    }
}

/// A sink that tells the progress bar how far the reading has come.
struct Counting<'a, S> {
    sink: &'a mut S,
    progress: &'a Progress,
}

impl<S: ItemSink> ItemSink for Counting<'_, S> {
    fn push(&mut self, item: Item) {
        self.progress.item(item.span.end() as u64);
        self.sink.push(item);
    }
}

/// Why a pass stopped.
enum PassError {
    Read(postpro_cl::Error),
    Solve(SolveError),
    Motion(postpro_motion::MotionError),
}

impl PassError {
    fn render(self, file: &ClFile) -> String {
        match self {
            PassError::Read(e) => format!("error: {e}\n"),
            PassError::Solve(e) => render_in(e, file),
            PassError::Motion(e) => render_in(e, file),
        }
    }
}

/// The stages from the reader's items to motion blocks: targets, the policy's second pass, the
/// linearization (each tool with its own length) and the motion program.
struct Motions<'a> {
    placing: Placing<'a>,
    stage: Stage<'a>,
    surveyor: Option<Surveyor<'a>>,
    index: usize,
    error: Option<PassError>,
}

impl ItemSink for Motions<'_> {
    fn push(&mut self, item: Item) {
        if self.error.is_some() {
            return;
        }
        let i = self.index;
        self.index += 1;
        match self.placing.item(&item) {
            Ok(true) => {
                if let Some(s) = self.surveyor.as_mut() {
                    self.placing.steps.steps.iter().for_each(|step| s.step(step));
                }
            }
            Ok(false) => {}
            Err(e) => {
                self.error = Some(PassError::Solve(e));
                return;
            }
        }
        let steps = &self.placing.steps;
        if let Err(e) = self.stage.item(i, &item, &steps.steps, &steps.decisions) {
            self.error = Some(PassError::Motion(e));
        }
    }
}

/// What a pass found: the motion program's counts and warnings, the survey of the steps (when
/// asked for) and the linearization's subdivisions.
struct Passed {
    summary: postpro_motion::Summary,
    survey: Option<Survey>,
    shape: Shape,
    /// The answers the motion program took from guessed 3+2 set-ups, `(step, answer)`.
    guessed: Vec<(usize, bool)>,
}

impl Passed {
    /// True when the program the pass built is the one the set-ups it surveyed give: it took no
    /// guessed answer they contradict.
    fn as_surveyed(&self) -> bool {
        self.guessed.is_empty() || self.survey.as_ref().is_some_and(|s| s.set_ups.agrees(&self.guessed))
    }
}

impl Motions<'_> {
    /// The end of the pass.
    fn finish(self) -> Result<Passed, PassError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let placing = self.placing.placing;
        let guessed = self.stage.guessed_answers().to_vec();
        let summary = self.stage.finish(placing.inserted(), &placing.unsettled()).map_err(PassError::Motion)?;
        Ok(Passed { summary, survey: self.surveyor.map(Surveyor::finish), shape: placing.shape(), guessed })
    }
}

/// The prediction as motion blocks come.
struct Predicting<'a> {
    machine: &'a Machine,
    reader: Reader,
    blocks: Blocks,
    predictor: Predictor<'a>,
    marks: MarkFinder,
    /// The number of the prediction's blocks at which what it no longer needs is next forgotten.
    forget_at: usize,
    /// Each block's row, as it is final (`postpro predict --blocks`).
    rows: Option<crate::predict::BlockRows<'a>>,
    /// The CSV rows of the samples and blocks (`postpro predict --csv`).
    csv: Option<crate::predict::CsvRows<'a>>,
}

/// The prediction's blocks between two forgettings of what it no longer needs (a few hundred
/// kilobytes held at most). Counted as the prediction counts them, not as motion blocks: a
/// B-spline run, one motion block, brings one per data point (a whole pass of a finishing
/// program, where 256 runs held 60 MB).
const FORGET_EVERY: usize = 256;

impl Predicting<'_> {
    fn take(&mut self, range: std::ops::Range<usize>) {
        for i in range {
            let op = self.blocks.operation[i] as usize;
            let result = self.predictor.result(i);
            self.marks.block(i, result, op);
            if let Some(rows) = &mut self.rows {
                rows.push(result, self.machine);
            }
            if let Some(csv) = &mut self.csv {
                csv.block(result, self.machine);
            }
        }
        if let Some(csv) = &mut self.csv {
            self.predictor.drain_samples(|samples| csv.samples(samples, self.machine));
        }
    }
}

impl MotionSink for Predicting<'_> {
    fn block(&mut self, block: postpro_motion::Block) {
        self.see(&block);
    }
}

impl Predicting<'_> {
    /// Predicts as far as the blocks so far, and `block`, let it.
    fn see(&mut self, block: &postpro_motion::Block) {
        self.reader.block(&mut self.blocks, self.machine, block);
        let done = self.predictor.advance(&self.blocks);
        self.take(done);
        // What the prediction no longer needs is forgotten every so many blocks, not at each:
        // its many windows are looked at once for all of them.
        if self.blocks.len() >= self.forget_at {
            self.forget_at = self.blocks.len() + FORGET_EVERY;
            let from = self.predictor.needs_from(&self.blocks);
            self.blocks.forget_before(from);
        }
    }
}

/// Drops the motion blocks (a pass that only surveys).
struct Dropped;

impl MotionSink for Dropped {
    fn block(&mut self, _: postpro_motion::Block) {}
}

/// The blocks of the writing pass to the travel check, then to the emitter.
struct Checked<'a> {
    travel: TravelCheck<'a>,
    error: Option<postpro_motion::MotionError>,
    next: &'a mut dyn MotionSink,
}

impl Checked<'_> {
    /// The end of the pass: the travel check's warnings, or the error it stopped at.
    fn finish(self) -> Result<Vec<postpro_motion::Warning>, PassError> {
        match self.error {
            Some(e) => Err(PassError::Motion(e)),
            None => Ok(self.travel.finish()),
        }
    }
}

impl MotionSink for Checked<'_> {
    fn block(&mut self, block: postpro_motion::Block) {
        if self.error.is_none()
            && let Err(e) = self.travel.block(&block)
        {
            self.error = Some(e);
        }
        self.next.block(block);
    }
}

/// The blocks of the prediction pass to the prediction, then on to `next` (the program written
/// as the prediction goes).
struct PredictAndWrite<'s, 'a> {
    predicting: &'s mut Predicting<'a>,
    next: &'s mut dyn MotionSink,
}

impl MotionSink for PredictAndWrite<'_, '_> {
    fn block(&mut self, block: postpro_motion::Block) {
        self.predicting.see(&block);
        self.next.block(block);
    }
}

/// What the passes after the survey share.
struct Passes<'a> {
    how: &'a Request<'a>,
    file: &'a ClFile,
    machine: &'a Machine,
    setup: &'a crate::setup::JobSetup,
    mode: postpro_motion::Mode,
    surveyed: &'a Surveyed,
    /// The stages from the items to motion blocks, with the job of the prediction pass.
    pass: Pass<'a>,
    motion_options: &'a postpro_motion::Options,
    /// When the survey started, when it ended and when the prediction pass ended (since then).
    started: std::time::Instant,
    surveyed_at: std::time::Duration,
    predicted_at: std::cell::Cell<Option<std::time::Duration>>,
    /// A pass's error, reported.
    render: &'a dyn Fn(PassError) -> ExitCode,
    /// Whose kinematics solve (a plugin's, or the definition's).
    solver: &'a postpro_plugins::Solver,
}

/// What the prediction pass found, for the program.
struct Concluded {
    summary: postpro_motion::Summary,
    survey: Survey,
    shape: Shape,
    /// The working planes the program's 3+2 set-ups are written in.
    planes: Option<postpro_motion::PlaneKind>,
    /// The header's prediction and the slowdowns' comments.
    prediction: Option<postpro_emit::Prediction>,
    annotations: Vec<postpro_emit::Annotation>,
    /// The prediction was made again in a pass of its own, on the blocks in working planes.
    repredicted: bool,
}

/// What the main job reports once the program is written.
struct Outcome {
    summary: postpro_motion::Summary,
    /// Predicted cycle time, time lost (s), slowdowns marked.
    predicted_time: Option<(f64, f64, usize)>,
    /// The passes over the CL file: 2 where the prediction pass wrote the program, else 3.
    passes: u8,
}

impl Passes<'_> {
    /// The prediction pass alone (the solving pass, without a prediction).
    fn predict(&self, mut predicting: Option<Predicting<'_>>) -> Result<Concluded, Failure> {
        let mut dropped = Dropped;
        let sink: &mut dyn MotionSink = match predicting.as_mut() {
            Some(p) => p,
            None => &mut dropped,
        };
        let passed = self.prediction_pass(None, sink)?;
        self.conclude(passed, predicting, None)
    }

    /// The stages of the prediction pass, their blocks to `sink`: the policy's choice, the
    /// linearization recorded, every step standing in a set-up, the steps surveyed; the 3+2
    /// set-ups in working planes of `planes`, when guessed so. On a machine whose rotary axes
    /// have brakes, which lock where a set-up stands, or in working planes, which stand where
    /// one does, the set-ups are guessed from the tool axes (the steps that say are yet to
    /// come): the pass's program is the one to write where its answers prove right
    /// ([`Passed::as_surveyed`]).
    fn prediction_pass(
        &self,
        planes: Option<postpro_motion::PlaneKind>,
        sink: &mut dyn MotionSink,
    ) -> Result<Passed, Failure> {
        let choice = (&self.surveyed.choice, None);
        let set_ups = if planes.is_some() || self.machine.axes.iter().any(|a| a.clamp.is_some()) {
            SetUps::guessed(self.surveyed.stretches.clone())
        } else {
            SetUps::default()
        };
        let (job, motion_options) = self.in_planes(planes);
        let pass = Pass { job: &job, ..self.pass };
        pass.run(&motion_options, set_ups, choice, true, sink).map_err(Failure::Pass)
    }

    /// The travel check before `next`.
    fn checked<'s>(&'s self, next: &'s mut dyn MotionSink) -> Checked<'s> {
        let units = self.surveyed.info.units;
        Checked { travel: TravelCheck::new(self.machine, self.setup.work_offset_at.as_ref(), units), error: None, next }
    }

    /// The end of the prediction pass (which ran in the working planes `ran_in`): its warnings,
    /// the working planes, the prediction's header and comments.
    fn conclude(
        &self,
        passed: Passed,
        predicting: Option<Predicting<'_>>,
        ran_in: Option<postpro_motion::PlaneKind>,
    ) -> Result<Concluded, Failure> {
        let (how, file, progress) = (self.how, self.file, self.pass.progress);
        let strict = how.setup.strict;
        let Passed { summary, survey, shape, .. } = passed;
        let survey = survey.unwrap_or_default();
        let warnings = progress.suspend(|| warn_all(file, &summary.warnings, strict));
        if strict && warnings > 0 {
            return Err(Failure::Refused(format!(
                "error: {warnings} warning(s), and --strict makes them errors; {WRITTEN}\n"
            )));
        }
        let planes = self.planes_of(&survey);
        // In working planes the set-ups' blocks differ: the prediction is made again on them, as
        // the program is written.
        let (predicting, repredicted) = match (planes, predicting) {
            (Some(kind), Some(_)) if ran_in != Some(kind) => {
                let mut again = self.predicting();
                if let Some(p) = again.as_mut() {
                    self.planes_pass(kind, &survey, shape.clone(), p).map_err(Failure::Pass)?;
                }
                (again, true)
            }
            (_, predicting) => (predicting, false),
        };
        let (prediction, annotations) = match (predicting, how.prediction) {
            (Some(mut p), Some((args, _))) => {
                let done = p.predictor.finish(&p.blocks);
                p.take(done);
                let (totals, operations) = (p.predictor.totals(), p.predictor.operations());
                progress.suspend(|| {
                    for note in &p.blocks.notes {
                        eprintln!("note: {}: prediction: {}", file.location(note.span.start as usize), note.text);
                    }
                    crate::predict::warn_if_abandoned(&totals);
                });
                let marks = p.marks.finish();
                let header =
                    crate::predict::header((&totals, &operations), args, self.mode, &marks, (self.machine, file));
                (Some(header), crate::predict::annotations(&marks, self.machine))
            }
            _ => (None, Vec::new()),
        };
        Ok(Concluded { summary, survey, shape, planes, prediction, annotations, repredicted })
    }

    /// The working planes the 3+2 set-ups are guessed to stand in before the steps are surveyed:
    /// the request's, where the dialect has them and no feed move turns the tool (else the
    /// motion is simultaneous, and there is no set-up to speak of).
    fn planes_guess(&self) -> Option<postpro_motion::PlaneKind> {
        let how = self.how;
        match crate::job::plane_kind(self.machine, self.mode, how.dialect) {
            Some(Ok(kind)) if how.shapes.planes && !self.surveyed.turns_tool => Some(kind),
            _ => None,
        }
    }

    /// True when the steps `passed` surveyed stand in the working planes `planes` the pass ran in
    /// and give every answer it took from the guessed set-ups: its blocks are those to predict.
    fn in_planes_as_guessed(&self, passed: &Passed, planes: Option<postpro_motion::PlaneKind>) -> bool {
        passed.as_surveyed() && passed.survey.as_ref().and_then(|s| self.planes_of(s)) == planes
    }

    /// The working planes the 3+2 set-ups the prediction pass surveyed (`survey`) are written in,
    /// if the request asks for planes and they stand in any.
    fn planes_of(&self, survey: &Survey) -> Option<postpro_motion::PlaneKind> {
        let how = self.how;
        how.shapes.planes.then(|| crate::job::planes_for(self.machine, self.mode, how.dialect, survey)).flatten()
    }

    /// A pass of its own after the prediction pass (the bar makes room for it) with the 3+2
    /// set-ups in working planes of `kind` (their frame), the set-ups and linearization the
    /// prediction pass found (`survey`, `shape`), its blocks to `sink`.
    fn planes_pass(
        &self,
        kind: postpro_motion::PlaneKind,
        survey: &Survey,
        shape: Shape,
        sink: &mut dyn MotionSink,
    ) -> Result<Passed, PassError> {
        self.pass.progress.repeat_pass(1);
        self.pass.progress.pass(2, "predicting in the planes");
        let (job, motion_options) = self.in_planes(Some(kind));
        let pass = Pass { job: &job, ..self.pass };
        pass.run(&motion_options, survey.set_ups.clone(), (&self.surveyed.choice, Some(shape)), false, sink)
    }

    /// The job and the motion program's options with the 3+2 set-ups in working planes of
    /// `planes` (in the part zero's frame), or as the prediction pass has them.
    fn in_planes(&self, planes: Option<postpro_motion::PlaneKind>) -> (postpro_motion::Job, postpro_motion::Options) {
        let mut job = self.pass.job.clone();
        if planes.is_some() {
            job.frame = postpro_motion::part_zero_frame(self.pass.kin);
        }
        let mut motion_options = self.motion_options.clone();
        motion_options.planes = planes;
        (job, motion_options)
    }

    /// The motion program's facts for the header, with `job` and `summary`.
    fn facts(&self, job: &postpro_motion::Job, summary: postpro_motion::Summary) -> postpro_motion::Program {
        postpro_motion::Program {
            mode: self.mode,
            part: self.surveyed.info.part_name.clone(),
            work_offset: job.work_offset,
            origin: job.frame.describe(),
            tools: job.tooling.tools.clone(),
            blocks: Vec::new(),
            summary,
        }
    }

    /// Reports the travel check's warnings (refused with `--strict`).
    fn travel_warnings(&self, travel: &[postpro_motion::Warning]) -> Result<(), Failure> {
        let strict = self.how.setup.strict;
        let count = self.pass.progress.suspend(|| warn_all(self.file, travel, strict));
        if strict && count > 0 {
            return Err(Failure::Refused(format!(
                "error: {count} warning(s), and --strict makes them errors; {WRITTEN}\n"
            )));
        }
        Ok(())
    }

    /// The time since the survey started.
    fn elapsed(&self) -> std::time::Duration {
        self.started.elapsed()
    }
}

/// The main job's writing: the passes after the survey with the program asked for and the
/// emitter's options (the prediction and its comments aside, which the prediction pass finds).
struct Writer<'p, 'a> {
    passes: &'p Passes<'a>,
    program: &'p Program<'a>,
    options: Options,
}

impl Writer<'_, '_> {
    /// The prediction pass, then the program into `out`: written by the prediction pass as it
    /// goes where the program does not depend on what the pass finds ([`Self::speculates`]),
    /// else (or where the 3+2 set-ups it finds are written in working planes) by a pass of its own.
    fn predict_and_write(&self, out: &mut dyn Write, predicting: Option<Predicting<'_>>) -> Result<Outcome, Failure> {
        let mut wasted = 0;
        let concluded = match self.speculates() {
            Some(planes) => {
                let mut body = Speculation {
                    passes: self.passes,
                    planes,
                    predicting,
                    wasted: false,
                    travel: Vec::new(),
                    passed: None,
                    concluded: None,
                };
                let output = self.program.output;
                let (mut scratch, mut places) =
                    (ScratchFile::beside(output, "body")?, ScratchFile::beside(output, "places")?);
                let (job, _) = self.passes.in_planes(planes);
                let facts = self.passes.facts(&job, postpro_motion::Summary::default());
                let template = (self.program.template.0.as_str(), self.program.template.1.as_str());
                let written = postpro_emit::write_program_deferred(
                    &facts,
                    self.passes.machine,
                    self.passes.how.dialect,
                    &self.options,
                    template,
                    out,
                    (&mut scratch.file, &mut places.file),
                    &mut body,
                )
                .map_err(|e| match e {
                    WriteError::Emit(e) => Failure::Emit(e),
                    WriteError::Produce(e) => e,
                })?;
                match (written, body.concluded) {
                    (true, Some(c)) => {
                        return Ok(Outcome { predicted_time: predicted_time(&c), summary: c.summary, passes: 2 });
                    }
                    // Working planes, or comments the body has no place for: the program is
                    // written by a pass of its own, which the bar makes room for.
                    (false, Some(c)) => {
                        self.passes.pass.progress.set_weights(if c.repredicted { &[1, 10, 8, 5] } else { &[1, 10, 5] });
                        c
                    }
                    // Nothing was produced (the options or the template do not allow it), or the
                    // working planes guessed proved wrong: predicted (again) as without a guess.
                    _ => {
                        if body.wasted {
                            wasted = 1;
                            self.passes.pass.progress.repeat_pass(1);
                        }
                        self.passes.predict(body.predicting)?
                    }
                }
            }
            None => self.passes.predict(predicting)?,
        };
        let outcome = self.write_pass(out, concluded)?;
        Ok(Outcome { passes: outcome.passes + wasted, ..outcome })
    }

    /// The working planes the prediction pass is to write the program in as it goes (`Some(None)`:
    /// none), when the program the writing pass would write can be the one it makes, but for the
    /// slowdowns' comments, which can be put in their places afterwards (with `--no-predict`, the
    /// pass surveys the steps only, and writes): the dialect's own template, not both `N` words
    /// and a dialect that numbers its lines (either is numbered anew as the body is copied, not
    /// both at once). The planes are guessed where the dialect has them and no feed move turns
    /// the tool (the frame of a 3+2 set-up's blocks in one depends on them); where the rotary
    /// brakes lock, from the tool axes. Both are known only at the end of the pass: a wrong guess
    /// of brakes leaves the program to a pass of its own, a wrong guess of planes the prediction
    /// too.
    fn speculates(&self) -> Option<Option<postpro_motion::PlaneKind>> {
        let (passes, how, program) = (self.passes, self.passes.how, self.program);
        let builtin = postpro_emit::builtin_template(how.dialect.name) == Some(program.template.1.as_str());
        let planes = passes.planes_guess();
        (!program.three_passes && builtin && !(program.block_numbers && how.dialect.numbered_blocks)).then_some(planes)
    }

    /// The writing pass: the stages again, the motion program in its final frame, formatted and
    /// rendered block by block into a scratch file; the header, which names the lines of the
    /// worst slowdowns, then the body into `out`.
    fn write_pass(&self, out: &mut dyn Write, c: Concluded) -> Result<Outcome, Failure> {
        let (passes, program) = (self.passes, self.program);
        let progress = passes.pass.progress;
        passes.predicted_at.set(passes.predicted_at.get().or(Some(passes.elapsed())));
        progress.pass(2 + usize::from(c.repredicted), "writing the program");
        let (job, motion_options) = passes.in_planes(c.planes);
        let predicted_time = predicted_time(&c);
        let Concluded { summary, survey, shape, prediction, annotations, .. } = c;
        let options = Options { prediction, annotations, ..self.options.clone() };
        let facts = passes.facts(&job, summary.clone());
        let pass = Pass { job: &job, ..passes.pass };
        let mut scratch = ScratchFile::beside(program.output, "body")?;
        let mut travel = Vec::new();
        let mut produce = |sink: &mut dyn MotionSink| -> Result<(), PassError> {
            let mut checked = passes.checked(sink);
            let shape = Some(shape.clone());
            pass.run(&motion_options, survey.set_ups.clone(), (&passes.surveyed.choice, shape), false, &mut checked)?;
            travel = checked.finish()?;
            Ok(())
        };
        let template = (program.template.0.as_str(), program.template.1.as_str());
        postpro_emit::write_program_with(
            &facts,
            passes.machine,
            passes.how.dialect,
            &options,
            template,
            out,
            &mut scratch.file,
            &mut produce,
        )
        .map_err(|e| match e {
            WriteError::Emit(e) => Failure::Emit(e),
            WriteError::Produce(e) => Failure::Pass(e),
        })?;
        passes.travel_warnings(&travel)?;
        Ok(Outcome { summary, predicted_time, passes: 3 + u8::from(c.repredicted) })
    }
}

/// The predicted cycle time, the time lost and the slowdowns marked, with a prediction.
fn predicted_time(c: &Concluded) -> Option<(f64, f64, usize)> {
    c.prediction.as_ref().map(|p| (p.cycle_time, p.time_lost, p.slowdowns))
}

/// The prediction pass writing the program as it goes (see [`Writer::speculates`]).
struct Speculation<'p, 'a> {
    passes: &'p Passes<'a>,
    /// The working planes guessed for the 3+2 set-ups (see [`Writer::speculates`]).
    planes: Option<postpro_motion::PlaneKind>,
    /// Until the pass ends; then a fresh one where the guess of working planes proved wrong.
    predicting: Option<Predicting<'a>>,
    /// The guess of working planes proved wrong: the pass is to be made again without it.
    wasted: bool,
    /// The travel check's warnings.
    travel: Vec<postpro_motion::Warning>,
    passed: Option<Passed>,
    /// Once the pass ended.
    concluded: Option<Concluded>,
}

impl postpro_emit::DeferredBody for Speculation<'_, '_> {
    type Error = Failure;

    fn produce(&mut self, sink: &mut dyn MotionSink) -> Result<(), Failure> {
        let passes = self.passes;
        let mut checked = passes.checked(sink);
        let passed = match self.predicting.as_mut() {
            Some(predicting) => {
                passes.prediction_pass(self.planes, &mut PredictAndWrite { predicting, next: &mut checked })?
            }
            None => passes.prediction_pass(self.planes, &mut checked)?,
        };
        self.travel = checked.finish().map_err(Failure::Pass)?;
        self.passed = Some(passed);
        Ok(())
    }

    fn annotate(&mut self, writing: bool) -> Result<Option<postpro_emit::Annotated>, Failure> {
        let Some(passed) = self.passed.take() else { return Ok(None) };
        let passes = self.passes;
        passes.predicted_at.set(Some(passes.elapsed()));
        let as_surveyed = passed.as_surveyed();
        if self.planes.is_some() && !passes.in_planes_as_guessed(&passed, self.planes) {
            // Predicted in working planes the steps do not stand in as guessed: made again.
            self.predicting = passes.predicting();
            self.wasted = true;
            return Ok(None);
        }
        let concluded = passes.conclude(passed, self.predicting.take(), self.planes)?;
        if !writing || concluded.planes != self.planes || !as_surveyed {
            self.concluded = Some(concluded);
            return Ok(None);
        }
        passes.travel_warnings(&self.travel)?;
        let annotated = postpro_emit::Annotated {
            summary: concluded.summary.clone(),
            prediction: concluded.prediction.clone(),
            annotations: concluded.annotations.clone(),
        };
        self.concluded = Some(concluded);
        Ok(Some(annotated))
    }
}

/// A prediction made as the file streams by ([`predict`]): what `postpro predict` prints of it.
pub(crate) struct Streamed {
    /// The machine, as solved.
    pub(crate) machine: Machine,
    /// The output mode predicted for.
    pub(crate) mode: postpro_motion::Mode,
    /// The blocks predicted.
    pub(crate) blocks: usize,
    /// The totals, the operations and the prediction's notes (no block is held).
    pub(crate) prediction: postpro_predict::Prediction,
    /// The slowdowns marked.
    pub(crate) marks: Vec<postpro_predict::Mark>,
    /// The CL file's name.
    pub(crate) name: String,
    /// The CL line of each mark, and of each of the prediction's notes.
    pub(crate) mark_lines: Vec<usize>,
    pub(crate) note_lines: Vec<usize>,
    /// How long the prediction pass took (s).
    pub(crate) seconds: f64,
    /// Each block's row, asked for (`--blocks`): in a scratch file.
    pub(crate) rows: Option<crate::scratch::Scratch>,
    /// The CSV files, asked for (`--csv`): written, to be put in place.
    pub(crate) csv: Option<crate::predict::CsvFiles>,
}

/// `postpro predict` without the exports that need every block or sample: the survey, then the
/// prediction pass with the travels checked, a window at a time as the main job reads the file;
/// nothing proportional to the file is held, and nothing is written.
pub(crate) fn predict(request: &Request<'_>) -> Result<Streamed, ExitCode> {
    let progress = Progress::on_stderr(&[1, 8]);
    let streamed = surveyed(request, &progress, |passes, predicting| passes.predicted(predicting));
    progress.finish();
    streamed
}

impl<'a> Passes<'a> {
    /// The prediction to make, as the request asks (none with `--no-predict`).
    fn predicting(&self) -> Option<Predicting<'a>> {
        let (kin, mode) = (self.pass.kin, self.mode);
        let timing =
            if mode.feeds_the_tip() { postpro_predict::Timing::TipFeed } else { postpro_predict::Timing::AxisFeed };
        let (every_block, csv) = match self.how.purpose {
            Purpose::Prediction { every_block, csv } => (every_block, csv),
            _ => (false, None),
        };
        self.how.prediction.map(|(prediction, marks)| Predicting {
            machine: kin.machine(),
            reader: Reader::new(timing),
            blocks: Blocks::new(kin.machine()),
            predictor: Predictor::new(
                kin,
                &postpro_predict::Options { samples: csv.is_some(), ..crate::predict::options_for(mode, prediction) },
                kin.machine().axes.len(),
                true,
            ),
            marks: MarkFinder::new(marks.rules(prediction)),
            forget_at: FORGET_EVERY,
            rows: every_block.then(|| crate::predict::BlockRows::table(self.file)),
            csv: csv.map(|path| crate::predict::CsvRows::new(self.file, path, kin.machine())),
        })
    }

    /// The prediction pass alone, and what it found; where the 3+2 set-ups it finds stand in
    /// working planes, a pass of their own predicts the program in them (as the main job writes
    /// it).
    fn predicted(&self, predicting: Option<Predicting<'_>>) -> Result<Streamed, ExitCode> {
        let (progress, file) = (self.pass.progress, self.file);
        let fail = |message: &str| progress.suspend(|| crate::job::fail(message, 1));
        let Some(mut p) = predicting else { return Err(fail("error: no prediction asked for\n")) };
        progress.pass(1, "predicting the feed");
        let started = std::time::Instant::now();
        let failed = |e: Failure| match e {
            Failure::Pass(e) => (self.render)(e),
            Failure::Emit(e) => fail(&report::render(&e)),
            Failure::Refused(message) => fail(&message),
        };
        // In the working planes guessed, where the steps prove the guess; else again without it.
        let mut ran_in = self.planes_guess();
        let (mut passed, mut travel) = loop {
            let mut checked = self.checked(&mut p);
            let passed = self.prediction_pass(ran_in, &mut checked).map_err(failed)?;
            let travel = checked.finish().map_err(|e| (self.render)(e))?;
            if ran_in.is_none() || self.in_planes_as_guessed(&passed, ran_in) {
                break (passed, travel);
            }
            ran_in = None;
            progress.repeat_pass(1);
            p = self.predicting().ok_or_else(|| fail("error: no prediction asked for\n"))?;
        };
        let survey = passed.survey.take().unwrap_or_default();
        let passed = match self.planes_of(&survey) {
            Some(kind) if ran_in != Some(kind) => {
                // The blocks in the working planes' frame: the prediction again, on them.
                p = self.predicting().ok_or_else(|| fail("error: no prediction asked for\n"))?;
                let mut checked = self.checked(&mut p);
                let again = self.planes_pass(kind, &survey, passed.shape, &mut checked);
                let checked = checked.finish();
                let again = again.map_err(|e| (self.render)(e))?;
                travel = checked.map_err(|e| (self.render)(e))?;
                again
            }
            _ => passed,
        };
        let done = p.predictor.finish(&p.blocks);
        p.take(done);
        let rows = p.rows.take().map(crate::predict::BlockRows::finish).transpose().map_err(|e| fail(&e))?;
        let csv = p.csv.take().map(crate::predict::CsvRows::finish).transpose().map_err(|e| fail(&e))?;
        let seconds = started.elapsed().as_secs_f64();
        progress.finish();
        crate::predict::warn_if_abandoned(&p.predictor.totals());
        let strict = self.how.setup.strict;
        let warnings = warn_all(file, passed.summary.warnings.iter().chain(&travel), strict);
        if strict && warnings > 0 {
            return Err(fail(&format!("error: {warnings} warning(s), and --strict makes them errors\n")));
        }
        let prediction = postpro_predict::Prediction {
            blocks: Vec::new(),
            samples: None,
            totals: Some(p.predictor.totals()),
            notes: std::mem::take(&mut p.blocks.notes),
            operations: p.predictor.operations(),
        };
        let marks = p.marks.finish();
        // The marks and the notes each in program order: their lines by reading on.
        let lines_of = |spans: &mut dyn Iterator<Item = Span>| -> Result<Vec<usize>, ExitCode> {
            let cannot = |e: &dyn std::fmt::Display| fail(&format!("error: cannot read {} again: {e}\n", file.name()));
            let mut lines = file.lines().map_err(|e| cannot(&e))?;
            spans.map(|span| lines.line_col(span.start as usize).map(|at| at.line).map_err(|e| cannot(&e))).collect()
        };
        Ok(Streamed {
            machine: self.machine.clone(),
            mode: self.mode,
            blocks: p.blocks.len(),
            mark_lines: lines_of(&mut marks.iter().map(|m| m.span))?,
            note_lines: lines_of(&mut prediction.notes.iter().map(|n| n.span))?,
            prediction,
            marks,
            name: file.name().to_string(),
            seconds,
            rows,
            csv,
        })
    }
}

/// What `postpro solve` says besides each position's axis values ([`solve`]).
pub(crate) struct Solution {
    /// The machine, as defined (with the policy's options).
    pub(crate) machine: Machine,
    /// A plugin's library, where its kinematics solve.
    pub(crate) plugin: Option<std::path::PathBuf>,
    /// The frame the axis values are in.
    pub(crate) frame: postpro_motion::WorkFrame,
    /// The CL file's name.
    pub(crate) name: String,
    /// The points linearization added.
    pub(crate) inserted: usize,
    /// The feed moves it left out of tolerance, and where the first is (`file:line:column`).
    pub(crate) unsettled: (postpro_kin::Unsettled, Option<String>),
}

/// `postpro solve`: the survey, then the policy's second pass and the linearization (no motion
/// program), a window at a time; each CL item's steps and decisions go to `each` as they come,
/// with the file (for their lines) and the frame the program's axis values are in. Nothing
/// proportional to the file is held.
pub(crate) fn solve(
    request: &Request<'_>,
    each: &mut dyn FnMut(&Collected, &ClFile, &postpro_motion::WorkFrame),
) -> Result<Solution, ExitCode> {
    let progress = Progress::on_stderr(&[1, 2]);
    let solution = surveyed(request, &progress, |passes, _| {
        progress.pass(1, "solving the kinematics");
        let frame = postpro_motion::work_frame(passes.pass.kin, passes.mode);
        let linearized = passes.pass.steps(&passes.surveyed.choice, &mut |c| each(c, passes.file, &frame));
        progress.finish();
        let (inserted, unsettled) = linearized.map_err(|e| (passes.render)(e))?;
        let first = unsettled.first.map(|span| passes.file.location(span.start as usize));
        Ok(Solution {
            machine: passes.machine.clone(),
            plugin: match passes.solver {
                postpro_plugins::Solver::Plugin(a) => Some(a.library().to_path_buf()),
                postpro_plugins::Solver::Built(_) => None,
            },
            frame,
            name: passes.file.name().to_string(),
            inserted,
            unsettled: (unsettled, first),
        })
    });
    progress.finish();
    solution
}

/// The steps of a pass without the motion program ([`Pass::steps`]).
struct Steps<'a> {
    placing: Placing<'a>,
    each: &'a mut dyn FnMut(&Collected),
    error: Option<PassError>,
}

impl ItemSink for Steps<'_> {
    fn push(&mut self, item: Item) {
        if self.error.is_some() {
            return;
        }
        match self.placing.item(&item) {
            Ok(true) => (self.each)(&self.placing.steps),
            Ok(false) => {}
            Err(e) => self.error = Some(PassError::Solve(e)),
        }
    }
}

/// The policy's placing of a pass: each CL item's targets, their steps and decisions.
struct Placing<'a> {
    tolerance: f64,
    placing: ToolPlacer<'a>,
    targets: Vec<Target>,
    /// The last item's.
    steps: Collected,
}

impl<'a> Placing<'a> {
    /// With the policy's `choice` (its first pass over the whole path) and `linearizer`.
    fn new(pass: &Pass<'a>, choice: &postpro_kin::Choice, linearizer: Linearizer) -> Placing<'a> {
        let (kin, policy) = (pass.kin, pass.policy);
        Placing {
            tolerance: policy.linearization_tolerance,
            placing: ToolPlacer::new(
                Placer::new(kin, policy, None, choice.clone()),
                linearizer,
                Stretches::starting(kin, pass.job.stretch_starts()),
            ),
            targets: Vec::new(),
            steps: Collected::default(),
        }
    }

    /// Places `item`'s targets: true, its steps and decisions in [`Self::steps`], where it moves
    /// the tool (else they are empty).
    fn item(&mut self, item: &Item) -> Result<bool, SolveError> {
        self.steps.steps.clear();
        self.steps.decisions.clear();
        if !matches!(item.kind, ItemKind::Move(_) | ItemKind::Arc(_) | ItemKind::Nurbs(_)) {
            return Ok(false);
        }
        self.targets.clear();
        postpro_kin::targets_of(item, self.tolerance, &mut self.targets);
        for t in &self.targets {
            self.placing.push(t, &mut self.steps)?;
        }
        Ok(true)
    }
}

/// The main job, streamed (see the module's documentation), with a progress bar on a terminal.
pub(crate) fn run(request: &Request<'_>) -> ExitCode {
    // The passes' shares of the time, as measured on a million CL points (survey 0.5 s,
    // prediction 4.3 s, writing 1.8 s; prediction and writing in one pass 5.4 s).
    let progress = Progress::on_stderr(&[1, 8, 4]);
    let code = main_job(request, &progress).unwrap_or_else(|code| code);
    progress.finish();
    code
}

fn main_job(how: &Request<'_>, progress: &Progress) -> Result<ExitCode, ExitCode> {
    surveyed(how, progress, write_program)
}

/// The survey (see the module's documentation) and what the passes after it share, handed to
/// `then` with the prediction to make (none with `--no-predict`).
fn surveyed<R>(
    how: &Request<'_>,
    progress: &Progress,
    then: impl FnOnce(&Passes<'_>, Option<Predicting<'_>>) -> Result<R, ExitCode>,
) -> Result<R, ExitCode> {
    // What is printed while the bar may be on the screen is printed with the bar put away.
    let fail = |message: &str, code: u8| progress.suspend(|| crate::job::fail(message, code));
    let (dialect, nothing) = (how.dialect, how.nothing());
    // Before the file is read: no bar on the screen yet.
    let (machine, setup) = crate::job::machine_and_setup(how.chosen, how.ikt, how.setup, nothing)?;
    let file = ClFile::open(how.file).map_err(|e| fail(&format!("error: {e}\n"), 1))?;
    progress.set_len(file.len() as u64);
    let read_options = how.setup.read.options();
    let solve_machine = crate::job::solving_machine(&machine);
    let solver = how.chosen.solver(&solve_machine)?;
    let kin = solver.kinematics();
    let policy = &solve_machine.policy;
    let render = |e: PassError| match solver.take_error() {
        // A plugin's failure is why the solve went wrong.
        Some(e) => fail(&report::render(&e), 1),
        None => fail(&e.render(&file), 1),
    };

    // 1. The survey.
    progress.pass(0, "reading");
    let started = std::time::Instant::now();
    let surveyed = survey(&file, &read_options, kin, policy, setup.tool_table.as_ref(), progress);
    let surveyed = surveyed.map_err(|e| render(PassError::Read(e)))?;
    if surveyed.diagnostics.iter().any(postpro_cl::Diagnostic::is_error) {
        // Each error with the lines around it, read from the file.
        progress.suspend(|| {
            for d in surveyed.diagnostics.iter().filter(|d| d.is_error()) {
                match file.excerpt(d.span) {
                    Ok(excerpt) => eprint!("{}", d.render_excerpt(&excerpt)),
                    Err(e) => {
                        eprintln!("error: {e}");
                        break;
                    }
                }
            }
        });
        return Err(fail(&format!("error: {} does not read; {nothing}\n", file.name()), 1));
    }
    let strict = how.setup.strict;
    // What the reader passed over is the main job's to say.
    let passed_over = how.writes();
    let mut warnings = progress
        .suspend(|| crate::job::report_reading(&file, (&surveyed.info, &surveyed.diagnostics), strict, passed_over));
    if !surveyed.moves {
        return Err(fail(&crate::job::no_motion(file.name(), surveyed.info.apt_source, nothing), 1));
    }
    let mode = how.mode.resolve_turning(surveyed.turns_tool, &machine, dialect);
    let job =
        postpro_motion::Job::with_tooling(kin, surveyed.tooling.clone(), mode, setup.work_offset.unwrap_or_default());
    let mut job = job.map_err(|e| {
        let rendered = render_in(e, &file);
        fail(&format!("{rendered}error: {nothing}\n"), 1)
    })?;
    warnings += progress.suspend(|| warn_all(&file, &surveyed.tool_warnings, strict));
    if strict && warnings > 0 {
        return Err(fail(&format!("error: {warnings} warning(s), and --strict makes them errors; {nothing}\n"), 1));
    }
    if let Some(e) = surveyed.graph_error.clone() {
        return Err(render(PassError::Solve(e)));
    }
    if let Purpose::Program(program) = &how.purpose {
        progress.suspend(|| crate::emit::check_writing(dialect, mode, program.tcp_orientation))?;
    }

    // 2. The prediction and the survey of the steps; 3. the program. Where nothing in the program
    // waits for the prediction's end, the prediction pass writes it as it goes ([`Speculation`]).
    let surveyed_at = started.elapsed();
    let unknown: BTreeSet<String> =
        surveyed.info.uninterpreted.iter().filter(|(_, u)| u.unknown).map(|(w, _)| w.clone()).collect();
    let mut motion_options = postpro_emit::motion_options(dialect, mode, !how.shapes.linear_arcs);
    motion_options.cycles = !how.shapes.expand_cycles;
    job.work_offset = setup.work_offset.unwrap_or_else(|| dialect.default_work_offset());
    let passes = Passes {
        how,
        file: &file,
        machine: &machine,
        setup: &setup,
        mode,
        surveyed: &surveyed,
        pass: Pass { file: &file, read_options: &read_options, kin, policy, job: &job, unknown: &unknown, progress },
        motion_options: &motion_options,
        started,
        surveyed_at,
        predicted_at: std::cell::Cell::new(None),
        render: &render,
        solver: &solver,
    };
    then(&passes, passes.predicting())
}

/// The main job's passes after the survey: the program written, and what it says on standard
/// error.
fn write_program(passes: &Passes<'_>, predicting: Option<Predicting<'_>>) -> Result<ExitCode, ExitCode> {
    let (how, progress, file, machine) = (passes.how, passes.pass.progress, passes.file, passes.machine);
    let started = passes.started;
    let fail = |message: &str, code: u8| progress.suspend(|| crate::job::fail(message, code));
    let Purpose::Program(program) = &how.purpose else {
        return Err(fail(&format!("error: no program asked for; {WRITTEN}\n"), 1));
    };
    let options = Options {
        units: passes.setup.units(machine),
        program_name: program.name.clone(),
        source_name: file.name().to_string(),
        block_numbers: program.block_numbers,
        tcp_orientation: program.tcp_orientation,
        insert_verbatim: program.insert_verbatim,
        prediction: None,
        annotations: Vec::new(),
    };
    let writer = Writer { passes, program, options };
    let output = program.output;
    if writer.speculates().is_some() {
        progress.set_weights(&[1, 10]);
    }
    progress.pass(1, if how.prediction.is_some() { "predicting the feed" } else { "solving the kinematics" });
    let mut outcome = None;
    let write = |out: &mut dyn Write| -> Result<(), Failure> {
        outcome = Some(writer.predict_and_write(out, predicting)?);
        Ok(())
    };
    let io = |e: std::io::Error| Failure::Emit(EmitError::Io { message: e.to_string() });
    let written = if output == Path::new("-") {
        let stdout = std::io::stdout();
        let mut out = std::io::BufWriter::new(stdout.lock());
        write(&mut out).and_then(|()| out.flush().map_err(io))
    } else {
        crate::emit::write_atomically_with(output, write, io)
    };
    let outcome = match (written, outcome) {
        (Ok(()), Some(outcome)) => outcome,
        (Err(e), _) => {
            let message = match e {
                Failure::Emit(EmitError::Io { message }) => {
                    format!("error: cannot write {}: {message}\n", output.display())
                }
                Failure::Emit(e) => report::render(&e),
                Failure::Pass(e) => return Err((passes.render)(e)),
                Failure::Refused(message) => message,
            };
            return Err(fail(&message, 1));
        }
        (Ok(()), None) => return Err(fail(&format!("error: the program was not made; {WRITTEN}\n"), 1)),
    };
    let surveyed_at = passes.surveyed_at;
    let predicted_at = passes.predicted_at.get().unwrap_or(surveyed_at);
    let inserts = passes.surveyed.inserts;
    let tcp = passes.mode == postpro_motion::Mode::Tcp;
    let Outcome { summary, predicted_time, passes } = outcome;
    progress.finish();
    if program.timing {
        let total = started.elapsed();
        let seconds = total.as_secs_f64();
        eprintln!(
            "timing: {} CL points ({:.1} MB) in {seconds:.3} s: {:.0} k CL points/s, {:.1} MB/s; {passes} passes (survey {:.3} \
             s, {} {:.3} s, writing {:.3} s){}",
            summary.cl_points,
            file.len() as f64 / 1e6,
            summary.cl_points as f64 / seconds / 1e3,
            file.len() as f64 / seconds / 1e6,
            surveyed_at.as_secs_f64(),
            match (how.prediction.is_some(), passes) {
                (true, 2) => "prediction and program",
                (true, _) => "prediction",
                (false, _) => "solving",
            },
            (predicted_at - surveyed_at).as_secs_f64(),
            (total - predicted_at).as_secs_f64(),
            crate::memory::peak_note(),
        );
    }
    let (inserts, first_insert) = inserts;
    let first_insert = first_insert.filter(|_| !program.insert_verbatim).map(|f| file.location(f.start as usize));
    let counts = (summary.cl_points, summary.linearized_points, summary.decisions);
    crate::job::said_written(
        output,
        &machine.name,
        (inserts, first_insert.map(|l| l.to_string())),
        counts,
        tcp,
        predicted_time,
    );
    Ok(ExitCode::SUCCESS)
}

/// Why the program was not written.
enum Failure {
    Emit(EmitError),
    Pass(PassError),
    /// A check after writing refused it (`--strict`): the message.
    Refused(String),
}

/// The scratch file the body of the program waits in, beside the output (or in the temporary
/// folder for standard output and devices), removed when dropped.
struct ScratchFile {
    path: std::path::PathBuf,
    file: std::fs::File,
}

impl ScratchFile {
    /// A scratch file named with `suffix`.
    fn beside(output: &Path, suffix: &str) -> Result<ScratchFile, Failure> {
        let folder = output == Path::new("-") || crate::emit::is_special_file(output);
        let path = if folder {
            std::env::temp_dir().join(format!("postpro-{}.{suffix}", std::process::id()))
        } else {
            crate::emit::beside(output, suffix)
        };
        let file =
            crate::emit::create_scratch(&path).map_err(|e| Failure::Emit(EmitError::Io { message: e.to_string() }))?;
        Ok(ScratchFile { path, file })
    }
}

impl std::ops::Drop for ScratchFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The first pass (see the module's documentation).
fn survey(
    file: &ClFile,
    read_options: &postpro_cl::ReadOptions,
    kin: &dyn Kinematics,
    policy: &postpro_kin::Policy,
    table: Option<&postpro_machine::tools::ToolTable>,
    progress: &Progress,
) -> Result<Surveyed, postpro_cl::Error> {
    let mut sink = SurveySink {
        graph: BranchGraph::new(kin, policy, None),
        tolerance: policy.linearization_tolerance,
        targets: Vec::new(),
        tooling: ToolingReader::new(table),
        axis: None,
        turns_tool: false,
        moves: false,
        inserts: (0, None),
        stretches: AxisStretches::default(),
        error: None,
    };
    let (info, diagnostics) = file.read_into_with(read_options, &mut Counting { sink: &mut sink, progress })?;
    let SurveySink { graph, tooling, turns_tool, moves, inserts, stretches, error, .. } = sink;
    let (tooling, tool_warnings) = tooling.finish();
    Ok(Surveyed {
        info,
        diagnostics,
        choice: graph.finish(),
        graph_error: error,
        tooling,
        tool_warnings,
        turns_tool,
        moves,
        inserts,
        stretches: stretches.finish(),
    })
}

/// What a pass of the stages from the items to motion blocks reads (see [`Motions`]).
#[derive(Clone, Copy)]
struct Pass<'a> {
    file: &'a ClFile,
    read_options: &'a postpro_cl::ReadOptions,
    kin: &'a dyn Kinematics,
    policy: &'a postpro_kin::Policy,
    job: &'a postpro_motion::Job,
    unknown: &'a BTreeSet<String>,
    progress: &'a Progress,
}

impl Pass<'_> {
    /// Reads the CL file through the stages, the blocks to `sink`, with `options` and the 3+2
    /// set-ups `set_ups`; with `surveying`, the steps are surveyed.
    /// With `shape`, the linearization replays it (recorded by an earlier pass); without, it
    /// records its own.
    fn run(
        &self,
        options: &postpro_motion::Options,
        set_ups: SetUps,
        (choice, shape): (&postpro_kin::Choice, Option<Shape>),
        surveying: bool,
        sink: &mut dyn MotionSink,
    ) -> Result<Passed, PassError> {
        let (kin, policy) = (self.kin, self.policy);
        let linearizer = match shape {
            Some(shape) => Linearizer::replaying(policy, shape),
            None => Linearizer::recording(policy),
        };
        let mut motions = Motions {
            placing: Placing::new(self, choice, linearizer),
            stage: Stage::new(kin, options, self.job, self.unknown.clone(), set_ups, sink),
            surveyor: surveying.then(|| Surveyor::new(kin)),
            index: 0,
            error: None,
        };
        let mut counting = Counting { sink: &mut motions, progress: self.progress };
        self.file.read_into_with(self.read_options, &mut counting).map_err(PassError::Read)?;
        motions.finish()
    }

    /// Reads the CL file through the policy's second pass (`choice`) and the linearization,
    /// each item's steps to `each`; returns the points linearization added and the feed moves it
    /// left out of tolerance.
    fn steps(
        &self,
        choice: &postpro_kin::Choice,
        each: &mut dyn FnMut(&Collected),
    ) -> Result<(usize, postpro_kin::Unsettled), PassError> {
        let linearizer = Linearizer::recording(self.policy);
        let mut steps = Steps { placing: Placing::new(self, choice, linearizer), each, error: None };
        let mut counting = Counting { sink: &mut steps, progress: self.progress };
        self.file.read_into_with(self.read_options, &mut counting).map_err(PassError::Read)?;
        match steps.error {
            Some(e) => Err(e),
            None => Ok((steps.placing.placing.inserted(), steps.placing.placing.unsettled())),
        }
    }
}

/// The rendered report of an error whose spans point into the CL text: with the lines around
/// them read from the file when they lie within a few MB of each other, else with the text read
/// whole (the job stops there).
fn render_in<D>(e: D, file: &ClFile) -> String
where
    D: miette::Diagnostic + Send + Sync + 'static,
{
    /// Spans further apart are shown from the whole text.
    const EXCERPT_SPAN: usize = 4 << 20;
    // Where the labels start and end, together.
    let range = e.labels().and_then(|labels| {
        labels.map(|l| (l.offset(), l.offset() + l.len())).reduce(|(s, e), (s2, e2)| (s.min(s2), e.max(e2)))
    });
    if let Some((start, end)) = range
        && end - start <= EXCERPT_SPAN
        && let Ok(excerpt) = file.excerpt(postpro_cl::Span::new(start, end))
    {
        return report::render_with_code(e, file.name(), excerpt);
    }
    match file.source() {
        Ok(source) => report::render_with_source(e, &source),
        Err(_) => report::render(&e),
    }
}
