//! Rendering the program with the dialect's template (minijinja, strict undefined: a template
//! that names a field the context lacks is an error, never an empty string).

use std::collections::HashMap;
use std::io::Write;

use minijinja::{Environment, UndefinedBehavior, Value};
use postpro_machine::model::Machine;

use crate::EmitError;
use crate::dialect::Dialect;
use crate::program::{
    Block, BlockSink, Header, Options, Program, Word, build, build_blocks, check_mode, header, tools,
};

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
    if program.header.prediction.as_ref().is_none_or(|p| p.worst.is_empty()) {
        return template.render(program).map_err(err);
    }
    let mut marked = program.clone();
    for block in &mut marked.blocks {
        if let Block::Comment { text, slowdown: Some(number), .. } = block {
            *text = format!("{MARK}{number}{MARK}{text}");
        }
    }
    let first_pass = template.render(&marked).map_err(err)?;
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
    template.render(context).map_err(err)
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

/// Writes the program to `out` block by block, never holding it in memory. The template must
/// define the macros `program_start()`, `block(b)` and `program_end()` (the built-in ones do, except
/// Heidenhain's, whose line numbers run across blocks); otherwise the whole program is built and
/// rendered at once, with the same result.
///
/// Motion blocks are the bulk of a program, so each shape of them (kind, axis letters, feed,
/// note, number) is rendered once with markers in place of the numbers; the markers cut the
/// output into a skeleton that is then filled with each block's numbers. The first two blocks of
/// each shape are also rendered in full and compared: a template that computes on the values
/// (not only the formatted texts) is detected and always rendered in full.
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
    check_mode(dialect, motion.mode)?;
    let err = |e: minijinja::Error| EmitError::Template { name: name.to_string(), message: describe(&e) };
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    env.set_keep_trailing_newline(true);
    env.add_template(name, source).map_err(err)?;
    let template = env.get_template(name).map_err(err)?;
    let mut header = header(motion, machine, dialect, options)?;
    let tools = tools(motion, dialect, options.units);
    // Rendering with no blocks yields the state whose macros are called below.
    let captured = template
        .render_captured(minijinja::context! { header => Value::from_serialize(&header), tools, blocks => Value::from(Vec::<Value>::new()) })
        .map_err(err)?;
    let streamable = ["program_start", "block", "program_end"].iter().all(|m| captured.state().lookup(m).is_some());
    if !streamable {
        let program = build(motion, machine, dialect, options)?;
        let text = render(&program, name, source)?;
        for line in text.lines() {
            check_length(line, dialect)?;
        }
        return out.write_all(text.as_bytes()).map_err(io_error);
    }
    let worst = header.prediction.as_ref().is_some_and(|p| !p.worst.is_empty());
    if worst {
        // A first pass, written nowhere, finds the lines of the worst slowdowns' comments.
        let counted = stream(&captured, name, motion, machine, dialect, options, &mut std::io::sink())?;
        set_nc_lines(&mut header, |number| counted.get(&number).copied());
    }
    let captured = if worst {
        template
            .render_captured(minijinja::context! { header => Value::from_serialize(&header), tools, blocks => Value::from(Vec::<Value>::new()) })
            .map_err(err)?
    } else {
        captured
    };
    stream(&captured, name, motion, machine, dialect, options, out).map(drop)
}

/// Writes the program with the template's streaming macros; returns the line (1-based) and block
/// number of each slowdown's comment, by slowdown number.
fn stream(
    captured: &minijinja::Captured<'_>,
    name: &str,
    motion: &postpro_motion::Program,
    machine: &Machine,
    dialect: &Dialect,
    options: &Options,
    out: &mut dyn Write,
) -> Result<HashMap<usize, (usize, Option<u64>)>, EmitError> {
    let err = |e: minijinja::Error| EmitError::Template { name: name.to_string(), message: describe(&e) };
    let state = captured.state();
    let start = state.call_macro("program_start", &[]).map_err(err)?;
    start.lines().try_for_each(|l| check_length(l, dialect))?;
    out.write_all(start.as_bytes()).map_err(io_error)?;
    let mut sink = Streaming {
        state,
        name,
        dialect,
        out,
        shapes: HashMap::new(),
        line: String::with_capacity(128),
        lines: start.matches('\n').count(),
        slowdowns: HashMap::new(),
    };
    build_blocks(motion, machine, dialect, options, &mut sink)?;
    let slowdowns = std::mem::take(&mut sink.slowdowns);
    let end = state.call_macro("program_end", &[]).map_err(err)?;
    end.lines().try_for_each(|l| check_length(l, dialect))?;
    out.write_all(end.as_bytes()).map_err(io_error)?;
    Ok(slowdowns)
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
    Skeleton(Vec<Piece>, u8),
    /// Rendered in full every time.
    Full,
}

struct Streaming<'s, 'env, 'o> {
    state: &'s minijinja::State<'s, 'env>,
    name: &'s str,
    dialect: &'s Dialect,
    out: &'o mut dyn Write,
    shapes: HashMap<String, Shape>,
    line: String,
    /// Lines written so far.
    lines: usize,
    /// The line (1-based) and block number of each slowdown comment written, by slowdown number.
    slowdowns: HashMap<usize, (usize, Option<u64>)>,
}

const MARK: char = '\u{1}';

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
            w.text = format!("{MARK}W{k}{MARK}");
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
                    Some(n) => line.push_str(&n.to_string()),
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

/// The shape of a motion block: what its skeleton depends on.
fn shape_key(block: &Block) -> Option<String> {
    let (kind, n, words, feed, note) = match block {
        Block::Rapid { n, words } => ('R', n, words, false, false),
        Block::Linear { n, words, feed, note } => ('L', n, words, feed.is_some(), note.is_some()),
        Block::ControlPoint { n, words, .. } => ('C', n, words, true, false),
        _ => return None,
    };
    let mut key = String::with_capacity(24);
    key.push(kind);
    key.push(if n.is_some() { 'n' } else { '-' });
    key.push(if feed { 'f' } else { '-' });
    key.push(if note { 't' } else { '-' });
    for w in words {
        key.push_str(&w.letter);
        key.push(',');
    }
    Some(key)
}

impl BlockSink for Streaming<'_, '_, '_> {
    fn block(&mut self, block: Block) -> Result<(), EmitError> {
        let Some(key) = shape_key(&block) else {
            let text = self.full(&block)?;
            if let Block::Comment { slowdown: Some(number), .. } = block {
                self.slowdowns.entry(number).or_insert((self.lines + 1, block_number(&text)));
            }
            return write_line(self.out, &mut self.lines, &text, self.dialect);
        };
        if !self.shapes.contains_key(&key) {
            let shape = self.skeleton(&block).map_or(Shape::Full, |s| Shape::Skeleton(s, 0));
            self.shapes.insert(key.clone(), shape);
        }
        let mut line = std::mem::take(&mut self.line);
        let result = match self.shapes.get(&key) {
            Some(Shape::Skeleton(pieces, checked)) if *checked >= 2 && Self::fill(pieces, &block, &mut line) => {
                write_line(self.out, &mut self.lines, &line, self.dialect)
            }
            Some(Shape::Skeleton(pieces, checked)) => {
                // Verify the skeleton against the full rendering; keep it only if they agree.
                let full = self.full(&block)?;
                let agrees = Self::fill(pieces, &block, &mut line) && line == full;
                let next = if agrees { Shape::Skeleton(pieces.clone(), checked + 1) } else { Shape::Full };
                self.shapes.insert(key, next);
                write_line(self.out, &mut self.lines, &full, self.dialect)
            }
            _ => {
                let text = self.full(&block)?;
                write_line(self.out, &mut self.lines, &text, self.dialect)
            }
        };
        self.line = line;
        result
    }
}

/// Writes `text` and a line break, counting the lines in `lines`.
fn write_line(out: &mut dyn Write, lines: &mut usize, text: &str, dialect: &Dialect) -> Result<(), EmitError> {
    *lines += text.matches('\n').count() + 1;
    for line in text.lines() {
        check_length(line, dialect)?;
    }
    out.write_all(text.as_bytes()).and_then(|()| out.write_all(b"\n")).map_err(io_error)
}

/// A line longer than the controller accepts is an error, never a truncated block.
fn check_length(line: &str, dialect: &Dialect) -> Result<(), EmitError> {
    if line.len() > dialect.max_line {
        let start: String = line.chars().take(60).collect();
        return Err(EmitError::LineTooLong { dialect: dialect.name, max: dialect.max_line, start });
    }
    Ok(())
}
