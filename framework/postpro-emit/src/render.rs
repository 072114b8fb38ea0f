//! Rendering the program with the dialect's template (minijinja, strict undefined: a template
//! that names a field the context lacks is an error, never an empty string).

use std::collections::HashMap;
use std::io::Write;
use std::rc::Rc;

use minijinja::{Environment, UndefinedBehavior, Value};
use postpro_machine::model::Machine;

use crate::EmitError;
use crate::dialect::Dialect;
use crate::program::{
    Annotation, Block, BlockSink, FIRST_NUMBER, Formatter, Header, NUMBER_STEP, Options, Prediction, Program, Word,
    check_mode, comment_block, header, tools,
};
use postpro_motion::MotionSink;

/// The built-in templates, by dialect name.
pub const TEMPLATES: &[(&str, &str)] = &[
    ("siemens-840d", include_str!("../../../templates/siemens-840d.j2")),
    ("fanuc", include_str!("../../../templates/fanuc.j2")),
    ("haas", include_str!("../../../templates/haas.j2")),
    ("heidenhain", include_str!("../../../templates/heidenhain.j2")),
    ("linuxcnc", include_str!("../../../templates/linuxcnc.j2")),
];

/// The built-in template of a dialect.
pub fn builtin_template(dialect: &str) -> Option<&'static str> {
    TEMPLATES.iter().find(|(d, _)| *d == dialect).map(|(_, t)| *t)
}

/// Renders `program` with the template `source` (named `name` in errors). Where the header lists
/// worst slowdowns, the program is rendered once with their comments marked to find their lines
/// ([`MarkedSlowdown::nc_line`](crate::MarkedSlowdown::nc_line)), then again with them.
pub fn render(program: &Program, name: &str, source: &str) -> Result<String, EmitError> {
    let err = |e: minijinja::Error| EmitError::Template { name: name.to_string(), message: describe(&e) };
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    env.set_keep_trailing_newline(true);
    env.add_template(name, source).map_err(err)?;
    let template = env.get_template(name).map_err(err)?;
    let dialect = &program.header.dialect;
    // A template with the streaming macros leaves the block numbers to the renderer; one without
    // them numbers its own lines.
    let renumber = dialect.numbered_blocks && {
        let empty = minijinja::context! {
            header => Value::from_serialize(&program.header),
            tools => Value::from_serialize(&program.tools),
            blocks => Value::from(Vec::<Value>::new()),
        };
        streamable(&template.render_captured(empty).map_err(err)?)
    };
    let numbered = |text: String| if renumber { numbered(dialect, &text) } else { text };
    if program.header.prediction.as_ref().is_none_or(|p| p.worst.is_empty()) {
        return template.render(program).map_err(err).map(numbered);
    }
    let mut marked = program.clone();
    for block in &mut marked.blocks {
        if let Block::Comment { text, slowdown: Some(number), .. } = block {
            *text = format!("{MARK}{number}{MARK}{text}");
        }
    }
    let first_pass = numbered(template.render(&marked).map_err(err)?);
    let mut lines = HashMap::new();
    for (k, line) in first_pass.lines().enumerate() {
        let number = line.split(MARK).nth(1).and_then(|n| n.parse::<usize>().ok());
        if let Some(number) = number {
            lines.entry(number).or_insert((k + 1, block_number(line)));
        }
    }
    drop(first_pass);
    let mut header = program.header.clone();
    set_nc_lines(&mut header, |number| lines.get(&number).copied());
    let context = minijinja::context! {
        header => Value::from_serialize(&header),
        tools => Value::from_serialize(&program.tools),
        blocks => Value::from_serialize(&program.blocks),
    };
    template.render(context).map_err(err).map(numbered)
}

/// The template rendered with `header`, `tools` and no blocks: the state whose macros write a
/// streamed program.
fn captured<'t>(
    template: &minijinja::Template<'t, 't>,
    header: &Header,
    tools: &[crate::program::Tool],
) -> Result<minijinja::Captured<'t>, minijinja::Error> {
    let context = minijinja::context! {
        header => Value::from_serialize(header),
        tools => Value::from_serialize(tools),
        blocks => Value::from(Vec::<Value>::new()),
    };
    template.render_captured(context)
}

/// True when the template of `captured` defines the macros a streamed program is written with.
fn streamable(captured: &minijinja::Captured<'_>) -> bool {
    ["program_start", "block", "program_end"].iter().all(|m| captured.state().lookup(m).is_some())
}

/// `text` with its blocks numbered where the dialect numbers them ([`Numbering`]).
fn numbered(dialect: &Dialect, text: &str) -> String {
    if !dialect.numbered_blocks {
        return text.to_string();
    }
    let mut out = String::with_capacity(text.len() + text.len() / 8);
    number_lines(dialect, &mut Numbering::default(), text, &mut out);
    out
}

/// The numbers of a dialect whose every block starts with its number, from 0 (Heidenhain): a
/// line that continues the block before it (which ends with `~`) gets none.
#[derive(Debug, Default)]
struct Numbering {
    next: u64,
    continues: bool,
}

impl Numbering {
    /// Writes the number `line` starts with (if any) to `out`; returns it.
    fn prefix(&mut self, line: &str, out: &mut String) -> Option<u64> {
        let number = self.count(line);
        if let Some(n) = number {
            out.push_str(itoa::Buffer::new().format(n));
            out.push(' ');
        }
        number
    }

    /// The number `line` starts with (if any), counted but not written.
    fn count(&mut self, line: &str) -> Option<u64> {
        let number = (!self.continues).then(|| {
            self.next += 1;
            self.next - 1
        });
        self.continues = line.trim_end().ends_with('~');
        number
    }
}

/// Fills in the NC line and block number of each worst slowdown of `header` (none where `line_of`
/// has none).
fn set_nc_lines(header: &mut Header, line_of: impl Fn(usize) -> Option<(usize, Option<u64>)>) {
    if let Some(prediction) = header.prediction.as_mut() {
        for m in &mut prediction.worst {
            (m.nc_line, m.nc_block) = line_of(m.number).map_or((None, None), |(line, block)| (Some(line), block));
        }
    }
}

/// The number of the `N` word `line` starts with (`N120 G1 …`) and its count of digits, if it
/// starts with one.
fn leading_number(line: &[u8]) -> Option<(u64, usize)> {
    let after = line.strip_prefix(b"N")?;
    let digits = after.iter().take_while(|b| b.is_ascii_digit()).count();
    let number = std::str::from_utf8(&after[..digits]).ok()?.parse().ok()?;
    Some((number, digits))
}

/// The block number a line starts with: `N120 …` or Heidenhain's `2031 ; …`.
fn block_number(line: &str) -> Option<u64> {
    let rest = line.trim_start();
    let rest = rest.strip_prefix('N').unwrap_or(rest);
    let digits = rest.find(|c: char| !c.is_ascii_digit()).unwrap_or(rest.len());
    rest[..digits].parse().ok()
}

/// minijinja's error with its template line and the chain of causes.
fn describe(e: &minijinja::Error) -> String {
    let mut s = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(cause) = source {
        s.push_str(&format!(": {cause}"));
        source = cause.source();
    }
    s
}

/// Where the body of a streamed program waits while its header is completed (the lines of its
/// worst slowdowns are known only once the body is written): a temporary file, or memory.
pub trait Scratch: Write {
    /// Copies what was written to `out`.
    fn replay(&mut self, out: &mut dyn Write) -> std::io::Result<()>;
}

impl Scratch for Vec<u8> {
    fn replay(&mut self, out: &mut dyn Write) -> std::io::Result<()> {
        out.write_all(self)
    }
}

impl Scratch for std::fs::File {
    fn replay(&mut self, out: &mut dyn Write) -> std::io::Result<()> {
        use std::io::Seek;
        self.flush()?;
        self.seek(std::io::SeekFrom::Start(0))?;
        std::io::copy(self, out).map(drop)
    }
}

/// Why a streamed program was not written: the emitter's error, or the one of what produced its
/// motion blocks.
#[derive(Debug)]
pub enum WriteError<E> {
    /// The emitter's.
    Emit(EmitError),
    /// The producer's.
    Produce(E),
}

impl<E> From<EmitError> for WriteError<E> {
    fn from(e: EmitError) -> Self {
        WriteError::Emit(e)
    }
}

/// Writes the program of `motion` (see [`write_program_with`]), the body waiting in memory.
#[allow(clippy::too_many_arguments)]
pub fn write_program(
    motion: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
    name: &str,
    source: &str,
    out: &mut dyn Write,
) -> Result<(), EmitError> {
    let mut body = Vec::new();
    let mut produce = |f: &mut Formatter<'_>| -> Result<(), std::convert::Infallible> {
        motion.blocks.iter().for_each(|block| f.block(block));
        Ok(())
    };
    write_with(motion, machine, dialect, options, (name, source), out, &mut body, &mut produce).map_err(|e| match e {
        WriteError::Emit(e) => e,
        WriteError::Produce(never) => match never {},
    })
}

/// Writes a program to `out` block by block, never holding it in memory: `produce` hands the
/// motion blocks over one at a time; the header and the tools come from `facts` (a motion
/// program whose blocks are not read). The template (`name`, `source`) must define the macros
/// `program_start()`, `block(b)` and `program_end()` (the built-in ones do); otherwise the whole
/// program is built and rendered at once, with the same result. The body waits in `scratch`
/// while the header gets the lines of the worst slowdowns' comments; the header's line count
/// must not depend on them.
///
/// Motion blocks are the bulk of a program, so each shape of them (kind, axis letters, feed,
/// note, number) is rendered once with markers in place of the numbers; the markers cut the
/// output into a skeleton that is then filled with each block's numbers. The first two blocks of
/// each shape are also rendered in full and compared: a template that computes on the values
/// (not only the formatted texts) is detected and always rendered in full.
#[allow(clippy::too_many_arguments)]
pub fn write_program_with<E>(
    facts: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
    (name, source): (&str, &str),
    out: &mut dyn Write,
    scratch: &mut dyn Scratch,
    produce: &mut dyn FnMut(&mut dyn MotionSink) -> Result<(), E>,
) -> Result<(), WriteError<E>> {
    let mut feed = |f: &mut Formatter<'_>| produce(f);
    write_with(facts, machine, dialect, options, (name, source), out, scratch, &mut feed)
}

/// [`write_program_with`], the blocks fed to the formatter by `produce` (by reference where
/// they are held).
#[allow(clippy::too_many_arguments)]
fn write_with<E>(
    facts: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
    (name, source): (&str, &str),
    out: &mut dyn Write,
    scratch: &mut dyn Scratch,
    produce: &mut dyn FnMut(&mut Formatter<'_>) -> Result<(), E>,
) -> Result<(), WriteError<E>> {
    check_mode(dialect, facts.mode)?;
    let err = |e: minijinja::Error| EmitError::Template { name: name.to_string(), message: describe(&e) };
    let env = environment(name, source)?;
    let template = env.get_template(name).map_err(err)?;
    let mut header = header(facts, machine, dialect, options)?;
    let tools = tools(facts, dialect, options.units);
    let capture = |header: &Header| captured(&template, header, &tools).map_err(err);
    let captured = capture(&header)?;
    if !streamable(&captured) {
        let mut blocks = Vec::new();
        let mut formatter = Formatter::new(machine, dialect, options, &mut blocks);
        produce(&mut formatter).map_err(WriteError::Produce)?;
        formatter.finish()?;
        let text = render(&Program { header, tools, blocks }, name, source)?;
        for line in text.lines() {
            check_length(line, dialect)?;
        }
        return out.write_all(text.as_bytes()).map_err(|e| io_error(e).into());
    }
    let state = captured.state();
    let mut numbering = Numbering::default();
    let start = state.call_macro("program_start", &[]).map_err(err)?;
    let start_lines = start.matches('\n').count();
    // The body's lines go to the scratch; the scratch is free again once they are all there.
    let (slowdowns, body_numbering) = {
        let numbering = Numbering { next: count_blocks(dialect, &start), ..Numbering::default() };
        let mut body = Streaming::new((state, name, dialect), &mut *scratch, None, (start_lines, numbering));
        let mut formatter = Formatter::new(machine, dialect, options, &mut body);
        produce(&mut formatter).map_err(WriteError::Produce)?;
        formatter.finish()?;
        body.out.flush().map_err(io_error)?;
        let Streaming { slowdowns, numbering, .. } = body;
        (slowdowns, numbering)
    };
    let end = state.call_macro("program_end", &[]).map_err(err)?;
    let start = start_naming_slowdowns(&mut header, start, &slowdowns, (name, &capture))?;
    write_numbered(out, dialect, &mut numbering, &start)?;
    scratch.replay(out).map_err(io_error)?;
    write_numbered(out, dialect, &mut { body_numbering }, &end).map_err(WriteError::from)
}

/// What a program written body first ([`write_program_deferred`]) is completed with once its body
/// is written.
#[derive(Clone, Debug)]
pub struct Annotated {
    /// The motion program's counts (the header has them).
    pub summary: postpro_motion::Summary,
    /// The prediction's summary for the header.
    pub prediction: Option<Prediction>,
    /// The comments on the steps.
    pub annotations: Vec<Annotation>,
}

/// The maker of a body written before what annotates it is known ([`write_program_deferred`]).
pub trait DeferredBody {
    /// Why it failed.
    type Error;
    /// Feeds the motion blocks to `sink`.
    fn produce(&mut self, sink: &mut dyn MotionSink) -> Result<(), Self::Error>;
    /// Once they are all fed, `writing` when the program can be written from this body: the
    /// header's counts and prediction and the annotations, or `None` when the program is not to
    /// be written from it after all (never asked for when not `writing`).
    fn annotate(&mut self, writing: bool) -> Result<Option<Annotated>, Self::Error>;
}

/// [`write_program_with`] for a body produced before what annotates it is known (the main job's
/// prediction pass writes it as it predicts). The body goes to `scratch` as `body` makes it, and
/// where each step's annotations would stand to `places`; `body` then gives the header's counts,
/// the prediction and the annotations, and the header, the body with the annotations' comments in
/// their places and the end go to `out`: the program [`write_program_with`] writes with them in
/// `facts` and `options` (whose own are not used).
///
/// Only where inserting a line changes nothing else the template writes but numbers: the lines of
/// a dialect that numbers every block are numbered as the body is copied, and with
/// `block_numbers` the `N` words after a comment put in are moved up by a step each (not both at
/// once); and a template with the streaming macros. Otherwise nothing is produced or
/// written, and the result is `false`, as it is when `body` gives no annotations or one would
/// have no place; nothing is written to `out` then.
#[allow(clippy::too_many_arguments)]
pub fn write_program_deferred<E>(
    facts: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
    (name, source): (&str, &str),
    out: &mut dyn Write,
    (scratch, places): (&mut dyn Scratch, &mut dyn Scratch),
    body: &mut dyn DeferredBody<Error = E>,
) -> Result<bool, WriteError<E>> {
    check_mode(dialect, facts.mode)?;
    if options.block_numbers && dialect.numbered_blocks {
        return Ok(false);
    }
    let err = |e: minijinja::Error| EmitError::Template { name: name.to_string(), message: describe(&e) };
    let env = environment(name, source)?;
    let template = env.get_template(name).map_err(err)?;
    let tools = tools(facts, dialect, options.units);
    let capture = |header: &Header| captured(&template, header, &tools).map_err(err);
    // The body without the prediction, which it does not depend on.
    let unannotated = Options { prediction: None, annotations: Vec::new(), ..options.clone() };
    let captured = capture(&header(facts, machine, dialect, &unannotated)?)?;
    if !streamable(&captured) {
        return Ok(false);
    }
    let placed = {
        let places: &mut dyn Write = &mut *places;
        let state = captured.state();
        let mut streaming =
            Streaming::new((state, name, dialect), &mut *scratch, Some(places), (0, Numbering::default()));
        streaming.numbers_later = options.block_numbers;
        let mut formatter = Formatter::new(machine, dialect, &unannotated, &mut streaming);
        body.produce(&mut formatter).map_err(WriteError::Produce)?;
        formatter.finish()?;
        streaming.out.flush().map_err(io_error)?;
        if let Some((places, _)) = streaming.places.as_mut() {
            places.flush().map_err(io_error)?;
        }
        !streaming.unplaceable
    };
    let annotated = body.annotate(placed).map_err(WriteError::Produce)?;
    let Some(Annotated { summary, prediction, annotations }) = annotated.filter(|_| placed) else {
        return Ok(false);
    };
    let facts = postpro_motion::Program { summary, ..facts.clone() };
    let options = Options { prediction, annotations, ..unannotated };
    let mut header = header(&facts, machine, dialect, &options)?;
    let captured = capture(&header)?;
    let state = captured.state();
    let start = state.call_macro("program_start", &[]).map_err(err)?;
    let (start_lines, start_blocks) = (start.matches('\n').count(), count_blocks(dialect, &start));
    // The annotations in the order of their steps, each where the formatter would have put it.
    let mut notes: Vec<&Annotation> = options.annotations.iter().collect();
    notes.sort_by_key(|a| a.step);
    let mut finder = PlaceFinder { steps: notes.iter().map(|a| a.step).collect(), ..PlaceFinder::default() };
    places.replay(&mut finder).map_err(io_error)?;
    if finder.found.len() < notes.len() {
        // Every annotation has a place (the formatter notes one at its end): none is dropped, the
        // program is written by the caller's other way.
        return Ok(false);
    }
    let mut insertions = std::collections::VecDeque::with_capacity(notes.len());
    let mut slowdowns = HashMap::new();
    let (mut inserted, mut inserted_blocks) = (0, 0);
    for (k, (note, place)) in notes.iter().zip(&finder.found).enumerate() {
        // With `N` words: the number the formatter gives the comment, after those put in before.
        let n = if options.block_numbers {
            let step = u64::from(NUMBER_STEP);
            match u32::try_from(u64::from(FIRST_NUMBER) + step * (place.blocks + k as u64)) {
                Ok(n) => Some(n),
                Err(_) => return Ok(false),
            }
        } else {
            None
        };
        let block = comment_block(dialect, &note.text, n, note.slowdown);
        let text = state.call_macro("block", &[Value::from_serialize(&block)]).map_err(err)?;
        // Written as the streamed writer writes it: line by line where the lines are numbered (a
        // line ending with `~` would leave the next one unnumbered: not put in afterwards).
        let (written, number) = if dialect.numbered_blocks {
            if text.lines().any(|l| l.trim_end().ends_with('~')) {
                return Ok(false);
            }
            let number = start_blocks + place.blocks + inserted_blocks;
            inserted_blocks += text.lines().count() as u64;
            (text.lines().flat_map(|l| [l, "\n"]).collect::<String>(), Some(number))
        } else {
            text.lines().try_for_each(|l| check_length(l, dialect))?;
            (format!("{text}\n"), block_number(&text))
        };
        if let Some(slowdown) = note.slowdown {
            let line = start_lines + place.lines as usize + inserted + 1;
            slowdowns.entry(slowdown).or_insert((line, number));
        }
        inserted += text.matches('\n').count() + 1;
        insertions.push_back((place.offset, written));
    }
    let end = state.call_macro("program_end", &[]).map_err(err)?;
    let start = start_naming_slowdowns(&mut header, start, &slowdowns, (name, &capture))?;
    // One numbering through the header, the body and the end, where the dialect numbers blocks.
    let mut numbering = Numbering::default();
    write_numbered(out, dialect, &mut numbering, &start)?;
    let mut numbered = NumberedLines::new(&mut *out, &mut numbering, dialect);
    let copied = {
        let into: &mut dyn Write = if dialect.numbered_blocks { &mut numbered } else { &mut *numbered.out };
        let renumber = options.block_numbers.then(|| Renumber::new(dialect));
        let mut body = Inserting { out: into, at: 0, insertions, renumber };
        let copied = scratch.replay(&mut body).and_then(|()| body.finish());
        if let Some(e) = body.renumber.and_then(|r| r.error) {
            return Err(e.into());
        }
        copied
    };
    let copied = copied.and_then(|()| numbered.finish());
    if let Some(e) = numbered.error.take() {
        return Err(e.into());
    }
    copied.map_err(io_error)?;
    write_numbered(out, dialect, &mut numbering, &end)?;
    Ok(true)
}

/// Renders the template with a header (no blocks) for the macros of its state.
type Capture<'c, 't> = dyn Fn(&Header) -> Result<minijinja::Captured<'t>, EmitError> + 'c;

/// The header's start with the lines of the worst slowdowns in it (`start`, rendered before they
/// were known, where it names none), of as many lines as `start`.
fn start_naming_slowdowns<'t>(
    header: &mut Header,
    start: String,
    slowdowns: &HashMap<usize, (usize, Option<u64>)>,
    (name, capture): (&str, &Capture<'_, 't>),
) -> Result<String, EmitError> {
    if header.prediction.as_ref().is_none_or(|p| p.worst.is_empty()) {
        return Ok(start);
    }
    set_nc_lines(header, |number| slowdowns.get(&number).copied());
    let named = capture(header)?
        .state()
        .call_macro("program_start", &[])
        .map_err(|e| EmitError::Template { name: name.to_string(), message: describe(&e) })?;
    if named.matches('\n').count() != start.matches('\n').count() {
        return Err(EmitError::Template { name: name.to_string(), message: LINE_COUNT_DEPENDS.into() });
    }
    Ok(named)
}

/// Why a header that names the lines of the worst slowdowns cannot be written.
const LINE_COUNT_DEPENDS: &str = "the header's line count depends on the lines of the worst slowdowns (nc_line, \
                                  nc_block): keep it the same whatever they are";

/// A template environment holding `source` as `name`: strict about undefined values, keeping the
/// trailing newline.
fn environment<'s>(name: &'s str, source: &'s str) -> Result<Environment<'s>, EmitError> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    env.set_keep_trailing_newline(true);
    env.add_template(name, source)
        .map_err(|e| EmitError::Template { name: name.to_string(), message: describe(&e) })?;
    Ok(env)
}

/// Where the annotations of the steps up to `step` stand in a body written before they are
/// known: before the byte `offset` of the body, after its first `lines` lines and `blocks`
/// numbered blocks (the lines a dialect numbers, or the blocks with an `N` word).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Place {
    step: u64,
    offset: u64,
    lines: u64,
    blocks: u64,
}

impl Place {
    const SIZE: usize = 32;

    fn to_bytes(self) -> [u8; Self::SIZE] {
        let mut bytes = [0; Self::SIZE];
        for (chunk, value) in bytes.chunks_exact_mut(8).zip([self.step, self.offset, self.lines, self.blocks]) {
            chunk.copy_from_slice(&value.to_le_bytes());
        }
        bytes
    }

    fn from_bytes(bytes: &[u8; Self::SIZE]) -> Place {
        let field = |k: usize| {
            let mut value = [0; 8];
            value.copy_from_slice(&bytes[8 * k..8 * k + 8]);
            u64::from_le_bytes(value)
        };
        Place { step: field(0), offset: field(1), lines: field(2), blocks: field(3) }
    }
}

/// Numbers the lines written through it where the dialect numbers blocks, as the streamed writer
/// does ([`Numbering`]), checking each line's length with its number.
struct NumberedLines<'a> {
    out: &'a mut dyn Write,
    numbering: &'a mut Numbering,
    dialect: &'a Dialect,
    /// The line so far.
    line: Vec<u8>,
    /// The line with its number.
    numbered: String,
    /// Why it stopped (a line too long).
    error: Option<EmitError>,
}

impl<'a> NumberedLines<'a> {
    /// Numbers the lines written through it into `out`, with `numbering`.
    fn new(out: &'a mut dyn Write, numbering: &'a mut Numbering, dialect: &'a Dialect) -> Self {
        NumberedLines { out, numbering, dialect, line: Vec::new(), numbered: String::new(), error: None }
    }

    /// Writes the line held, numbered.
    fn line(&mut self) -> std::io::Result<()> {
        let text = String::from_utf8_lossy(&self.line);
        self.numbered.clear();
        self.numbering.prefix(&text, &mut self.numbered);
        self.numbered.push_str(&text);
        if let Err(e) = check_length(&self.numbered, self.dialect) {
            self.error = Some(e);
            return Err(std::io::Error::other("a line too long"));
        }
        self.numbered.push('\n');
        self.line.clear();
        self.out.write_all(self.numbered.as_bytes())
    }

    /// Writes a last line without its line break, if any.
    fn finish(&mut self) -> std::io::Result<()> {
        if self.line.is_empty() { Ok(()) } else { self.line() }
    }
}

impl Write for NumberedLines<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut rest = buf;
        while let Some(end) = rest.iter().position(|&b| b == b'\n') {
            self.line.extend_from_slice(&rest[..end]);
            self.line()?;
            rest = &rest[end + 1..];
        }
        self.line.extend_from_slice(rest);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// Reads the places of a body as they are replayed into it, and finds for each of `steps`
/// (ascending) the place its annotation goes: the first, from where the one before was found,
/// whose step is not below it (the formatter writes the annotations of the steps up to its own).
#[derive(Debug, Default)]
struct PlaceFinder {
    steps: Vec<usize>,
    found: Vec<Place>,
    partial: Vec<u8>,
}

impl Write for PlaceFinder {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut rest = buf;
        while !rest.is_empty() {
            let want = Place::SIZE - self.partial.len();
            let (head, tail) = rest.split_at(want.min(rest.len()));
            self.partial.extend_from_slice(head);
            rest = tail;
            if let Ok(record) = <&[u8; Place::SIZE]>::try_from(self.partial.as_slice()) {
                let place = Place::from_bytes(record);
                self.partial.clear();
                while let Some(&step) = self.steps.get(self.found.len())
                    && place.step >= step as u64
                {
                    self.found.push(place);
                }
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Copies a body to `out` with texts inserted before given byte offsets (ascending), the offsets
/// of line starts.
struct Inserting<'a> {
    out: &'a mut dyn Write,
    /// The offset of the next byte of the body (with `renumber`: of the line it holds).
    at: u64,
    insertions: std::collections::VecDeque<(u64, String)>,
    /// With `N` words: each text put in is a block of its own, numbered, and the body's lines
    /// after it are numbered a step more.
    renumber: Option<Renumber<'a>>,
}

/// The `N` words of a body's lines moved up by `shift`.
struct Renumber<'a> {
    dialect: &'a Dialect,
    shift: u64,
    /// The line so far.
    line: Vec<u8>,
    /// Why it stopped (a line too long).
    error: Option<EmitError>,
}

impl Renumber<'_> {
    /// Before the first comment put in, for the lines of `dialect`.
    fn new(dialect: &Dialect) -> Renumber<'_> {
        Renumber { dialect, shift: 0, line: Vec::new(), error: None }
    }
}

impl Inserting<'_> {
    /// Writes the insertions that stand at or before offset `limit`.
    fn insert_upto(&mut self, limit: u64) -> std::io::Result<()> {
        while let Some((offset, _)) = self.insertions.front()
            && *offset <= limit
        {
            if let Some((_, text)) = self.insertions.pop_front() {
                self.out.write_all(text.as_bytes())?;
                if let Some(r) = self.renumber.as_mut() {
                    r.shift += u64::from(NUMBER_STEP);
                }
            }
        }
        Ok(())
    }

    /// Writes `line` of the body (its line break included), its `N` word moved up, after the
    /// insertions before it.
    fn renumbered_line(&mut self, line: &[u8]) -> std::io::Result<()> {
        self.insert_upto(self.at)?;
        self.at += line.len() as u64;
        let Some(r) = self.renumber.as_mut() else { return self.out.write_all(line) };
        let Some((number, digits)) = leading_number(line).filter(|_| r.shift > 0) else {
            return self.out.write_all(line);
        };
        let mut text = itoa::Buffer::new();
        let moved = text.format(number + r.shift);
        let rest = &line[1 + digits..];
        let content = rest.strip_suffix(b"\n").unwrap_or(rest);
        if 1 + moved.len() + content.len() > r.dialect.max_line {
            let whole = format!("N{moved}{}", String::from_utf8_lossy(content));
            r.error = check_length(&whole, r.dialect).err();
            return Err(std::io::Error::other("a line too long"));
        }
        self.out.write_all(b"N")?;
        self.out.write_all(moved.as_bytes())?;
        self.out.write_all(rest)
    }

    /// Writes the insertions at the body's end (none is ever dropped).
    fn finish(&mut self) -> std::io::Result<()> {
        if let Some(r) = self.renumber.as_mut()
            && !r.line.is_empty()
        {
            let held = std::mem::take(&mut r.line);
            self.renumbered_line(&held)?;
        }
        self.insert_upto(u64::MAX)
    }
}

impl Write for Inserting<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut rest = buf;
        if let Some(r) = self.renumber.as_mut() {
            // Line by line: a line split between two writes is held until its end comes.
            let mut held = std::mem::take(&mut r.line);
            while let Some(end) = rest.iter().position(|&b| b == b'\n') {
                if held.is_empty() {
                    self.renumbered_line(&rest[..=end])?;
                } else {
                    held.extend_from_slice(&rest[..=end]);
                    self.renumbered_line(&held)?;
                    held.clear();
                }
                rest = &rest[end + 1..];
            }
            held.extend_from_slice(rest);
            if let Some(r) = self.renumber.as_mut() {
                r.line = held;
            }
            return Ok(buf.len());
        }
        while !rest.is_empty() {
            self.insert_upto(self.at)?;
            let next = self.insertions.front().map_or(u64::MAX, |(offset, _)| *offset);
            let take = usize::try_from(next - self.at).unwrap_or(usize::MAX).min(rest.len());
            let (head, tail) = rest.split_at(take);
            self.out.write_all(head)?;
            self.at += take as u64;
            rest = tail;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// The blocks `text` holds (each numbered line) in `dialect`.
fn count_blocks(dialect: &Dialect, text: &str) -> u64 {
    let mut numbering = Numbering::default();
    number_lines(dialect, &mut numbering, text, &mut String::new());
    numbering.next
}

/// Writes `text` (the header's start or the end) to `out`, its lines numbered where the dialect
/// numbers blocks and checked for length.
fn write_numbered(
    out: &mut dyn Write,
    dialect: &Dialect,
    numbering: &mut Numbering,
    text: &str,
) -> Result<(), EmitError> {
    let mut numbered = String::with_capacity(text.len() + 64);
    number_lines(dialect, numbering, text, &mut numbered);
    numbered.lines().try_for_each(|l| check_length(l, dialect))?;
    out.write_all(numbered.as_bytes()).map_err(io_error)
}

/// Appends the lines of `text` to `out`, each with its number where the dialect numbers blocks.
fn number_lines(dialect: &Dialect, numbering: &mut Numbering, text: &str, out: &mut String) {
    for line in text.split_inclusive('\n') {
        if dialect.numbered_blocks {
            numbering.prefix(line, out);
        }
        out.push_str(line);
    }
}

fn io_error(e: std::io::Error) -> EmitError {
    EmitError::Io { message: e.to_string() }
}

/// A piece of a motion block's skeleton.
#[derive(Clone, Debug, PartialEq)]
enum Piece {
    Text(String),
    /// The block number.
    Number,
    /// The text of word `k`.
    Word(usize),
    Feed,
    Note,
}

/// What is known about one shape of motion block.
enum Shape {
    /// Verified this many times so far (at most two), with its skeleton.
    Skeleton(Rc<[Piece]>, u8),
    /// Rendered in full every time.
    Full,
}

struct Streaming<'s, 'env, 'o> {
    state: &'s minijinja::State<'s, 'env>,
    name: &'s str,
    dialect: &'s Dialect,
    /// The scratch, a block of lines written at a time.
    out: std::io::BufWriter<&'o mut dyn Scratch>,
    shapes: HashMap<String, Shape>,
    /// Bytes written so far (to the scratch).
    bytes: u64,
    /// Where the annotations of each step would go ([`Place`]), when the body is written before
    /// they are known; the last step noted.
    places: Option<(std::io::BufWriter<&'o mut dyn Write>, Option<usize>)>,
    /// Some annotation would not stand where the places say.
    unplaceable: bool,
    /// The blocks carry `N` words (`block_numbers`) and the annotations' comments come later:
    /// every line that starts with one must be a block's own (see [`Inserting`]).
    numbers_later: bool,
    /// The blocks with an `N` word written so far.
    blocks_numbered: u64,
    /// The shape of the block at hand ([`shape_key`]).
    key: String,
    /// The last shape written through a verified skeleton, and that skeleton: most blocks have
    /// the shape of the one before, found without a look-up.
    last_shape: (String, Option<Rc<[Piece]>>),
    line: String,
    /// The line with its block number.
    numbered: String,
    /// Lines written so far (the header's included).
    lines: usize,
    numbering: Numbering,
    /// The line (1-based) and block number of each slowdown comment written, by slowdown number.
    slowdowns: HashMap<usize, (usize, Option<u64>)>,
}

const MARK: char = '\u{1}';

impl<'s, 'env, 'o> Streaming<'s, 'env, 'o> {
    /// Writes blocks with the macros of `state` into `scratch` (and, with `places`, where each
    /// step's annotations would go), counting from `lines` lines and `numbering`.
    fn new(
        (state, name, dialect): (&'s minijinja::State<'s, 'env>, &'s str, &'s Dialect),
        scratch: &'o mut dyn Scratch,
        places: Option<&'o mut dyn Write>,
        (lines, numbering): (usize, Numbering),
    ) -> Self {
        Streaming {
            state,
            name,
            dialect,
            out: std::io::BufWriter::with_capacity(1 << 16, scratch),
            shapes: HashMap::new(),
            bytes: 0,
            places: places.map(|p| (std::io::BufWriter::with_capacity(1 << 16, p), None)),
            unplaceable: false,
            numbers_later: false,
            blocks_numbered: 0,
            key: String::with_capacity(24),
            last_shape: (String::with_capacity(24), None),
            line: String::with_capacity(128),
            numbered: String::with_capacity(128),
            lines,
            numbering,
            slowdowns: HashMap::new(),
        }
    }
}

impl Streaming<'_, '_, '_> {
    fn full(&self, block: &Block) -> Result<String, EmitError> {
        self.state
            .call_macro("block", &[Value::from_serialize(block)])
            .map_err(|e| EmitError::Template { name: self.name.to_string(), message: describe(&e) })
    }

    /// The block rendered with markers in place of its number, word texts, feed and note.
    fn skeleton(&self, block: &Block) -> Option<Vec<Piece>> {
        let mut marked = block.clone();
        let (n, words, feed, note) = motion_parts(&mut marked)?;
        if n.is_some() {
            *n = Some(MARKED_NUMBER);
        }
        for (k, w) in words.iter_mut().enumerate() {
            w.text = compact_str::format_compact!("{MARK}W{k}{MARK}");
        }
        if let Some(f) = feed {
            *f = format!("{MARK}F{MARK}");
        }
        if let Some(t) = note {
            *t = format!("{MARK}N{MARK}");
        }
        let rendered = self.full(&marked).ok()?;
        let rendered = rendered.replace(&MARKED_NUMBER.to_string(), &format!("{MARK}#{MARK}"));
        let mut pieces = Vec::new();
        let mut parts = rendered.split(MARK);
        pieces.push(Piece::Text(parts.next()?.to_string()));
        while let Some(marker) = parts.next() {
            pieces.push(match marker {
                "#" => Piece::Number,
                "F" => Piece::Feed,
                "N" => Piece::Note,
                w => Piece::Word(w.strip_prefix('W')?.parse().ok()?),
            });
            pieces.push(Piece::Text(parts.next()?.to_string()));
        }
        Some(pieces)
    }

    fn fill(pieces: &[Piece], block: &Block, line: &mut String) -> bool {
        let pl;
        let (n, words, feed, note) = match block {
            Block::Rapid { n, words } => (n, words, &None, &None),
            Block::Linear { n, words, feed, note } => (n, words, feed, note),
            Block::ControlPoint { n, words, pl: p } => {
                pl = Some(p.clone());
                (n, words, &pl, &None)
            }
            _ => return false,
        };
        line.clear();
        for p in pieces {
            match p {
                Piece::Text(t) => line.push_str(t),
                Piece::Number => match n {
                    Some(n) => line.push_str(itoa::Buffer::new().format(*n)),
                    None => return false,
                },
                Piece::Word(k) => match words.get(*k) {
                    Some(w) => line.push_str(&w.text),
                    None => return false,
                },
                Piece::Feed => match feed {
                    Some(f) => line.push_str(f),
                    None => return false,
                },
                Piece::Note => match note {
                    Some(t) => line.push_str(t),
                    None => return false,
                },
            }
        }
        true
    }
}

/// A block number no program reaches, to find where the template writes `n`.
const MARKED_NUMBER: u32 = 3_987_654_321;

/// The parts of a motion block that vary from block to block.
#[allow(clippy::type_complexity)]
fn motion_parts(
    block: &mut Block,
) -> Option<(&mut Option<u32>, &mut Vec<Word>, Option<&mut String>, Option<&mut String>)> {
    match block {
        Block::Rapid { n, words } => Some((n, words, None, None)),
        Block::Linear { n, words, feed, note } => Some((n, words, feed.as_mut(), note.as_mut())),
        Block::ControlPoint { n, words, pl } => Some((n, words, Some(pl), None)),
        _ => None,
    }
}

/// The shape of a motion block, what its skeleton depends on, into `key`; false for a block of
/// another kind.
fn shape_key(block: &Block, key: &mut String) -> bool {
    let (kind, n, words, feed, note) = match block {
        Block::Rapid { n, words } => ('R', n, words, false, false),
        Block::Linear { n, words, feed, note } => ('L', n, words, feed.is_some(), note.is_some()),
        Block::ControlPoint { n, words, .. } => ('C', n, words, true, false),
        _ => return false,
    };
    key.clear();
    key.push(kind);
    key.push(if n.is_some() { 'n' } else { '-' });
    key.push(if feed { 'f' } else { '-' });
    key.push(if note { 't' } else { '-' });
    for w in words {
        key.push_str(&w.letter);
        key.push(',');
    }
    true
}

impl BlockSink for Streaming<'_, '_, '_> {
    fn block(&mut self, block: Block) -> Result<(), EmitError> {
        let mut key = std::mem::take(&mut self.key);
        let result = self.motion_block(block, &mut key);
        self.key = key;
        result
    }

    fn place(&mut self, step: usize) -> Result<(), EmitError> {
        let Some((places, last)) = self.places.as_mut() else { return Ok(()) };
        if *last == Some(step) {
            return Ok(());
        }
        *last = Some(step);
        // After a line that the next continues, a comment would change the numbers after it.
        self.unplaceable |= self.numbering.continues;
        let blocks = if self.numbers_later { self.blocks_numbered } else { self.numbering.next };
        let place = Place { step: step as u64, offset: self.bytes, lines: self.lines as u64, blocks };
        places.write_all(&place.to_bytes()).map_err(io_error)
    }

    fn unplaceable(&mut self) {
        self.unplaceable = true;
    }
}

impl Streaming<'_, '_, '_> {
    /// Writes `block` through the skeleton of its shape (`key` the scratch for it).
    fn motion_block(&mut self, block: Block, key: &mut String) -> Result<(), EmitError> {
        let n = block.number();
        if !shape_key(&block, key) {
            let text = self.full(&block)?;
            let line = self.lines + 1;
            let number = self.write(&text, n)?;
            if let Block::Comment { slowdown: Some(slowdown), .. } = block {
                let number = number.or_else(|| block_number(&text));
                self.slowdowns.entry(slowdown).or_insert((line, number));
            }
            return Ok(());
        };
        let mut line = std::mem::take(&mut self.line);
        // The usual case, a shape verified already: the last block's, else one look-up.
        let filled = match &self.last_shape {
            (last, Some(pieces)) if last == key => Self::fill(pieces, &block, &mut line),
            _ => match self.shapes.get(key.as_str()) {
                Some(Shape::Skeleton(pieces, checked)) if *checked >= 2 => {
                    self.last_shape.0.clone_from(key);
                    self.last_shape.1 = Some(Rc::clone(pieces));
                    Self::fill(pieces, &block, &mut line)
                }
                _ => false,
            },
        };
        if filled {
            let result = self.write(&line, n);
            self.line = line;
            return result.map(drop);
        }
        // The shapes may change below: the last one is looked up again.
        self.last_shape.1 = None;
        if !self.shapes.contains_key(key.as_str()) {
            let shape = self.skeleton(&block).map_or(Shape::Full, |s| Shape::Skeleton(s.into(), 0));
            self.shapes.insert(key.clone(), shape);
        }
        let result = match self.shapes.get(key.as_str()) {
            Some(Shape::Skeleton(pieces, checked)) => {
                // Verify the skeleton against the full rendering; keep it only if they agree.
                let full = self.full(&block)?;
                let agrees = Self::fill(pieces, &block, &mut line) && line == full;
                let next = if agrees { Shape::Skeleton(Rc::clone(pieces), checked + 1) } else { Shape::Full };
                self.shapes.insert(key.clone(), next);
                self.write(&full, n)
            }
            _ => {
                let text = self.full(&block)?;
                self.write(&text, n)
            }
        };
        self.line = line;
        result.map(drop)
    }
}

impl Streaming<'_, '_, '_> {
    /// Writes `text`, a block numbered `n` (`N` words), and a line break (its lines numbered where
    /// the dialect numbers them), counting the lines; returns the number of its first block, if
    /// numbered.
    fn write(&mut self, text: &str, n: Option<u32>) -> Result<Option<u64>, EmitError> {
        let breaks = text.bytes().filter(|&b| b == b'\n').count();
        self.lines += breaks + 1;
        let (out, dialect) = (&mut self.out, self.dialect);
        if !dialect.numbered_blocks {
            let (numbers_later, unplaceable) = (self.numbers_later, &mut self.unplaceable);
            let mut look = |line: &str| {
                check_length(line, dialect)?;
                // A line that starts with an `N` word not of its block (a verbatim insert's) would
                // be numbered anew as the body is copied.
                if numbers_later
                    && let Some((number, _)) = leading_number(line.as_bytes())
                    && n.is_none_or(|n| number < u64::from(n) || number >= u64::from(n) + u64::from(NUMBER_STEP))
                {
                    *unplaceable = true;
                }
                Ok(())
            };
            // Nearly every block is one line: looked at whole.
            if breaks == 0 {
                look(text)?;
            } else {
                text.lines().try_for_each(look)?;
            }
            self.blocks_numbered += u64::from(n.is_some());
            self.bytes += text.len() as u64 + 1;
            return out.write_all(text.as_bytes()).and_then(|()| out.write_all(b"\n")).map(|()| None).map_err(io_error);
        }
        // Written before the header is known, the lines are numbered as they are copied after it.
        let later = self.places.is_some();
        let mut first = None;
        for line in text.lines() {
            if later {
                first = first.or(self.numbering.count(line));
                self.bytes += line.len() as u64 + 1;
                out.write_all(line.as_bytes()).and_then(|()| out.write_all(b"\n")).map_err(io_error)?;
                continue;
            }
            self.numbered.clear();
            let number = self.numbering.prefix(line, &mut self.numbered);
            first = first.or(number);
            self.numbered.push_str(line);
            check_length(&self.numbered, dialect)?;
            self.numbered.push('\n');
            self.bytes += self.numbered.len() as u64;
            out.write_all(self.numbered.as_bytes()).map_err(io_error)?;
        }
        Ok(first)
    }
}

/// A line longer than the controller accepts is an error, never a truncated block.
fn check_length(line: &str, dialect: &Dialect) -> Result<(), EmitError> {
    if line.len() > dialect.max_line {
        let start: String = line.chars().take(60).collect();
        return Err(EmitError::LineTooLong { dialect: dialect.name, max: dialect.max_line, start });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `body` copied in chunks of `chunk` bytes with `insertions` (renumbered in `dialect`'s
    /// lines, if given).
    fn copied(body: &str, insertions: &[(u64, &str)], renumber: Option<&Dialect>, chunk: usize) -> String {
        let mut out = Vec::new();
        let queue = insertions.iter().map(|&(at, t)| (at, t.to_string())).collect();
        let renumber = renumber.map(Renumber::new);
        let mut inserting = Inserting { out: &mut out, at: 0, insertions: queue, renumber };
        for piece in body.as_bytes().chunks(chunk) {
            inserting.write_all(piece).unwrap_or_else(|e| panic!("{e}"));
        }
        inserting.finish().unwrap_or_else(|e| panic!("{e}"));
        String::from_utf8_lossy(&out).into_owned()
    }

    #[test]
    fn texts_go_in_before_their_offsets_whatever_the_chunks_the_body_comes_in() {
        let body = "G1 X1\nG1 X2\nG1 X3\n";
        let insertions = [(0, "(a)\n"), (6, "(b)\n"), (6, "(c)\n"), (18, "(d)\n"), (u64::MAX, "(e)\n")];
        for chunk in [1, 5, 6, 7, 64] {
            let out = copied(body, &insertions, None, chunk);
            assert_eq!(out, "(a)\nG1 X1\n(b)\n(c)\nG1 X2\nG1 X3\n(d)\n(e)\n", "chunks of {chunk}");
        }
    }

    #[test]
    fn with_n_words_each_comment_put_in_moves_the_numbers_after_it_up_a_step() {
        // The body as the formatter numbered it without the comments; a tool change of two lines
        // (`N30`, `N31`), a line without a number, and comments numbered where they go.
        let dialect = crate::dialect::dialect("fanuc").unwrap_or_else(|| panic!("fanuc"));
        let body = "N10 G1 X1\nN20 G1 X2\nN30 T2 M6\nN31 G43 H2\n%\nN40 G1 X3";
        let insertions = [(10, "N20 (a)\n"), (20, "N40 (b)\n"), (20, "N50 (c)\n"), (u64::MAX, "N90 (d)\n")];
        for chunk in [1, 4, 10, 100] {
            assert_eq!(
                copied(body, &insertions, Some(dialect), chunk),
                "N10 G1 X1\nN20 (a)\nN30 G1 X2\nN40 (b)\nN50 (c)\nN60 T2 M6\nN61 G43 H2\n%\nN70 G1 X3N90 (d)\n",
                "chunks of {chunk}"
            );
        }
    }

    #[test]
    fn a_number_moved_past_the_dialects_line_length_is_an_error() {
        let mut dialect = crate::dialect::dialect("fanuc").unwrap_or_else(|| panic!("fanuc")).clone();
        dialect.max_line = 10;
        let mut out = Vec::new();
        let queue = [(0, "N10 (a)\n".to_string())].into();
        let renumber = Some(Renumber::new(&dialect));
        let mut inserting = Inserting { out: &mut out, at: 0, insertions: queue, renumber };
        assert!(inserting.write_all(b"N90 G1 X12\n").is_err());
        let error = inserting.renumber.and_then(|r| r.error).map(|e| e.to_string()).unwrap_or_default();
        assert!(error.contains("N100 G1 X12"), "{error}");
    }

    #[test]
    fn numbered_lines_are_numbered_as_the_streamed_writer_numbers_them_whatever_the_chunks() {
        let dialect = crate::dialect::dialect("heidenhain").unwrap_or_else(|| panic!("heidenhain"));
        let body = "L X1 FMAX\nCYCL DEF 200 ~\n  Q200=2 ~\n  Q201=-5\nL X2\n";
        let mut expected = String::new();
        number_lines(dialect, &mut Numbering { next: 7, continues: false }, body, &mut expected);
        assert!(expected.starts_with("7 L X1 FMAX\n8 CYCL DEF 200 ~\n  Q200=2 ~\n  Q201=-5\n9 L X2\n"), "{expected}");
        for chunk in [1, 3, 11, 100] {
            let (mut out, mut numbering) = (Vec::new(), Numbering { next: 7, continues: false });
            let mut numbered = NumberedLines::new(&mut out, &mut numbering, dialect);
            for piece in body.as_bytes().chunks(chunk) {
                numbered.write_all(piece).unwrap_or_else(|e| panic!("{e}"));
            }
            numbered.finish().unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(String::from_utf8_lossy(&out), expected, "chunks of {chunk}");
        }
    }

    #[test]
    fn each_step_finds_the_first_place_from_the_last_one_found_whose_step_reaches_it() {
        let places = [(3, 10, 1), (5, 20, 2), (9, 30, 3), (usize::MAX, 40, 4)].map(|(step, offset, lines)| Place {
            step: step as u64,
            offset,
            lines,
            blocks: lines + 100,
        });
        let bytes: Vec<u8> = places.iter().flat_map(|p| p.to_bytes()).collect();
        for chunk in [1, 7, 32, 100] {
            let mut finder = PlaceFinder { steps: vec![0, 3, 4, 5, 6, 12], ..PlaceFinder::default() };
            for piece in bytes.chunks(chunk) {
                finder.write_all(piece).unwrap_or_else(|e| panic!("{e}"));
            }
            let offsets: Vec<u64> = finder.found.iter().map(|p| p.offset).collect();
            assert_eq!(offsets, [10, 10, 20, 20, 30, 40], "chunks of {chunk}");
            assert!(finder.found.iter().all(|p| p.blocks == p.lines + 100), "chunks of {chunk}");
        }
    }
}
