//! The crate's one error type, [`MachineError`]: thiserror for the message, miette for the
//! rendering (the file name, line and column, the source line, a caret on the offending value
//! and a label saying what was expected). The same [`DefinitionError`] serves the three file
//! formats of the crate ([`FileKind`]: machine definitions, set-ups and tool tables); a
//! [`Skipped`] file is a warning that wraps the error that made the registry pass it over.

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

use miette::{Diagnostic, LabeledSpan, NamedSource, Severity, SourceCode, SourceSpan};

use crate::locate::{Seg, Span, collection_span, locate, offset_of, second_key, span_at};
use crate::registry::Origin;

/// Everything that can go wrong with machine definitions.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum MachineError {
    /// A definition that does not read or does not validate.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Definition(Box<DefinitionError>),

    /// A file or folder that cannot be read.
    #[error("cannot read `{}`", path.display())]
    #[diagnostic(code(machine::io))]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },

    /// No machine has this name or alias.
    #[error("unknown machine `{name}`{}", did_you_mean(suggestions))]
    #[diagnostic(code(machine::unknown), help("`postpro machines` lists the known machines"))]
    UnknownMachine {
        /// The name asked for.
        name: String,
        /// The nearest names and aliases, best first (may be empty).
        suggestions: Vec<String>,
    },

    /// Two definitions use the same name or alias.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Clash(Box<ClashError>),

    /// A name or alias that two or more definitions claim: it finds none of them.
    #[error("the machine name `{name}` is ambiguous: {}", claimants(claims))]
    #[diagnostic(
        code(machine::ambiguous),
        help(
            "rename one of the machines or drop the alias (or remove the file you do not want); `postpro machines` lists every machine with its origin"
        )
    )]
    Ambiguous {
        /// The name asked for.
        name: String,
        /// Each definition that claims it: its machine name and where it comes from, first
        /// loaded first.
        claims: Vec<(String, Origin)>,
    },

    /// A tool table whose file name ends in neither `.yaml`, `.yml` nor `.csv`.
    #[error("cannot tell the format of the tool table `{}`", path.display())]
    #[diagnostic(
        code(machine::tool_table_format),
        help("a tool table is YAML (`.yaml`, `.yml`) or CSV (`.csv`), by its file name's extension")
    )]
    ToolTableFormat {
        /// The file.
        path: PathBuf,
    },
}

/// ``machine `a` (built in) and machine `b` (dir/b.yaml) both claim it``
fn claimants(claims: &[(String, Origin)]) -> String {
    let each: Vec<String> = claims.iter().map(|(m, o)| format!("machine `{m}` ({o})")).collect();
    match each.as_slice() {
        [a, b] => format!("{a} and {b} both claim it"),
        [init @ .., last] if init.len() > 1 => format!("{} and {last} all claim it", init.join(", ")),
        _ => format!("{} claims it", each.concat()),
    }
}

/// ``; did you mean `a` or `b`?``
fn did_you_mean(suggestions: &[String]) -> String {
    match suggestions {
        [] => String::new(),
        [one] => format!("; did you mean `{one}`?"),
        [init @ .., last] => {
            let init: Vec<String> = init.iter().map(|s| format!("`{s}`")).collect();
            format!("; did you mean {} or `{last}`?", init.join(", "))
        }
    }
}

/// The file formats whose errors a [`DefinitionError`] reports; each has its diagnostic code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// A machine definition (`machine::definition`).
    Machine,
    /// A set-up file (`machine::setup`).
    Setup,
    /// A tool table, YAML or CSV (`machine::tool_table`).
    ToolTable,
}

impl FileKind {
    /// The diagnostic code.
    pub fn code(self) -> &'static str {
        match self {
            FileKind::Machine => "machine::definition",
            FileKind::Setup => "machine::setup",
            FileKind::ToolTable => "machine::tool_table",
        }
    }
}

/// A file of one of the crate's formats that does not read or does not validate: where, what is
/// wrong, what was expected.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct DefinitionError {
    /// Which format the file is in (it gives the diagnostic code).
    pub kind: FileKind,
    /// The file name as shown (`machine-defs/maho600e.yaml`).
    pub file: String,
    /// What is wrong (`axes[3].vmax: unknown unit `m/sec``).
    pub message: String,
    /// What was expected: the label under the caret.
    pub expected: String,
    /// How to fix it, where there is more to say.
    pub help: Option<String>,
    /// The file's text, named after the file.
    pub source_code: NamedSource<Arc<str>>,
    /// The offending value.
    pub span: SourceSpan,
    /// A second place that explains the first (where an unclosed collection starts, where a
    /// duplicated tool was first defined).
    pub context_span: Option<SourceSpan>,
    /// What is at `context_span`.
    pub context_label: String,
    /// 1-based line of the offending value.
    pub line: usize,
    /// 1-based column (in characters) of the offending value.
    pub column: usize,
}

impl DefinitionError {
    /// `file:line:column: message (expected)` on one line.
    pub fn one_line(&self) -> String {
        format!("{}:{}:{}: {} ({})", self.file, self.line, self.column, self.message, self.expected)
    }
}

// By hand rather than derived: the code depends on the file's kind.
impl Diagnostic for DefinitionError {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.kind.code()))
    }

    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.help.as_ref().map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        Some(&self.source_code)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        let main = LabeledSpan::new_with_span(Some(self.expected.clone()), self.span);
        let context = self.context_span.map(|s| LabeledSpan::new_with_span(Some(self.context_label.clone()), s));
        Some(Box::new(std::iter::once(main).chain(context)))
    }
}

/// A file the registry passed over, and why: a warning, so that the other machines still load.
#[derive(Debug, thiserror::Error)]
#[error("skipped `{}`: {error}", path.display())]
pub struct Skipped {
    /// The file (or folder) passed over.
    pub path: PathBuf,
    /// Why.
    pub error: MachineError,
}

// The error's diagnostic (code, source, labels, help) with the severity of a warning.
impl Diagnostic for Skipped {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.error.code()
    }

    fn severity(&self) -> Option<Severity> {
        Some(Severity::Warning)
    }

    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.error.help()
    }

    fn url<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.error.url()
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        self.error.source_code()
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        self.error.labels()
    }

    fn related<'a>(&'a self) -> Option<Box<dyn Iterator<Item = &'a dyn Diagnostic> + 'a>> {
        self.error.related()
    }
}

/// A name or alias that an earlier definition already uses.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error(
    "the name `{name}` of machine `{machine}` ({origin}) is already used by machine `{first_machine}` ({first_origin})"
)]
#[diagnostic(
    code(machine::clash),
    help("rename the machine or drop the alias: names and aliases must be unique, whatever the case")
)]
pub struct ClashError {
    /// The name or alias used twice.
    pub name: String,
    /// The later machine.
    pub machine: String,
    /// Where the later machine comes from.
    pub origin: Origin,
    /// The earlier machine.
    pub first_machine: String,
    /// Where the earlier machine comes from.
    pub first_origin: Origin,
    /// The later definition's text, when it is a YAML file.
    #[source_code]
    pub source_code: Option<NamedSource<Arc<str>>>,
    /// The name or alias in the later definition.
    #[label("already used by `{first_machine}`")]
    pub span: Option<SourceSpan>,
}

/// The text of one definition and its shown name, to build errors that point into it.
#[derive(Clone, Debug)]
pub(crate) struct Doc {
    pub(crate) kind: FileKind,
    pub(crate) file: String,
    pub(crate) text: Arc<str>,
}

impl Doc {
    /// A machine definition.
    pub(crate) fn new(file: &str, text: &str) -> Doc {
        Doc::of(FileKind::Machine, file, text)
    }

    /// A file of any kind.
    pub(crate) fn of(kind: FileKind, file: &str, text: &str) -> Doc {
        Doc { kind, file: file.to_string(), text: Arc::from(text) }
    }

    /// An error at `span`.
    pub(crate) fn error_at(&self, span: Span, message: String, expected: String, help: Option<String>) -> MachineError {
        let (line, column) = line_column(&self.text, span.offset);
        MachineError::Definition(Box::new(DefinitionError {
            kind: self.kind,
            file: self.file.clone(),
            message,
            expected,
            help,
            source_code: NamedSource::new(self.file.clone(), Arc::clone(&self.text)),
            span: SourceSpan::new(span.offset.into(), span.len),
            context_span: None,
            context_label: String::new(),
            line,
            column,
        }))
    }

    /// An error at `span` with a second labelled place that explains it.
    pub(crate) fn error_with_context(
        &self,
        span: Span,
        message: String,
        expected: String,
        (context, label): (Span, String),
    ) -> MachineError {
        let mut error = self.error_at(span, message, expected, None);
        if let MachineError::Definition(e) = &mut error {
            e.context_span = Some(SourceSpan::new(context.offset.into(), context.len));
            e.context_label = label;
        }
        error
    }

    /// An error at the value at `path` (or its nearest existing ancestor).
    pub(crate) fn error(&self, path: &[Seg<'_>], message: String, expected: String) -> MachineError {
        self.error_at(locate(&self.text, path), message, expected, None)
    }

    /// An error at the value at `path`, with a help text.
    pub(crate) fn error_help(&self, path: &[Seg<'_>], message: String, expected: String, help: String) -> MachineError {
        self.error_at(locate(&self.text, path), message, expected, Some(help))
    }

    /// The error of the YAML library (syntax, unknown key, bad unit…), at its location.
    pub(crate) fn yaml_error(&self, err: &serde_yaml::Error) -> MachineError {
        let text = &*self.text;
        let full = err.to_string();
        let (message, expected) = split_expected(&strip_locations(&full));
        let offset = err.location().map(|l| l.index());
        let span = match offset {
            None => Span { offset: 0, len: 0 },
            // A missing key: the mapping that lacks it.
            Some(o) if message.contains("missing key `") => collection_span(text, o),
            // A key given twice: serde notices it in the mapping; point at the second one.
            Some(o) if message.contains("duplicate key `") => {
                let key = message.split('`').nth(1).unwrap_or_default();
                second_key(text, o, key).unwrap_or_else(|| collection_span(text, o))
            }
            Some(o) => span_at(text, o),
        };
        let mut error = self.error_at(span, message, expected, None);
        // A syntax error inside a collection: show where the collection starts.
        if let (MachineError::Definition(e), Some((what, at))) = (&mut error, syntax_context(&full, text))
            && at != span.offset
        {
            e.context_span = Some(SourceSpan::new(at.into(), 1));
            e.context_label = format!("{what} that starts here");
        }
        error
    }
}

/// `…, while parsing a flow sequence at line 26 column 11`: (`the flow sequence`, its offset).
fn syntax_context(full: &str, text: &str) -> Option<(String, usize)> {
    let rest = &full[full.find(", while parsing ")? + ", while parsing ".len()..];
    let (what, at) = rest.split_once(" at line ")?;
    let mut numbers = at.split(|c: char| !c.is_ascii_digit()).filter(|s| !s.is_empty());
    let line: usize = numbers.next()?.parse().ok()?;
    let column: usize = numbers.next()?.parse().ok()?;
    let what = what.strip_prefix("a ").or_else(|| what.strip_prefix("an ")).unwrap_or(what);
    Some((format!("the {what}"), offset_of(text, line, column)?))
}

/// 1-based line and column (in characters) of a byte offset.
pub(crate) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (before.matches('\n').count() + 1, before[line_start..].chars().count() + 1)
}

/// Removes the ` at line L column C` and ` at position N` the YAML library appends.
fn strip_locations(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(i) = rest.find(" at line ").or_else(|| rest.find(" at position ")) {
        out.push_str(&rest[..i]);
        let after = &rest[i + 4..];
        // Skip `line L column C` or `position N`.
        let mut words = 0;
        let want = if after.starts_with("line") { 4 } else { 2 };
        let mut end = after.len();
        for (j, c) in after.char_indices() {
            if c == ' ' {
                words += 1;
                if words == want {
                    end = j;
                    break;
                }
            } else if c == ',' && words == want - 1 {
                end = j;
                break;
            }
        }
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// Splits a serde message into what is wrong and what was expected; uses the YAML words
/// (`key`) instead of serde's (`field`).
fn split_expected(message: &str) -> (String, String) {
    let mut message = message
        .replace("unknown field `", "unknown key `")
        .replace("missing field `", "missing key `")
        .replace("duplicate field `", "duplicate key `")
        .replace("unknown variant `", "unknown value `");
    // `invalid value: string "nearest"` → `invalid value `nearest``.
    if let Some(i) = message.find("invalid value: string \"") {
        let start = i + "invalid value: string \"".len();
        if let Some(len) = message[start..].find('"') {
            let value = message[start..start + len].to_string();
            message.replace_range(i..start + len + 1, &format!("invalid value `{value}`"));
        }
    }
    if let Some(i) = message.find(", expected ") {
        let what = message[..i].to_string();
        let mut expected = message[i + 2..].to_string();
        // serde names the Rust type of a mapping (`expected struct ToolFile`).
        if expected.starts_with("expected struct ") {
            expected = "expected a mapping of `key: value` lines".to_string();
        }
        return (what, expected);
    }
    if let Some(i) = message.find("missing key `") {
        let key = message[i + "missing key `".len()..].split('`').next().unwrap_or_default();
        return (message.clone(), format!("expected `{key}` in this mapping"));
    }
    if message.contains("duplicate key `") {
        return (message.clone(), "expected each key once in a mapping".to_string());
    }
    if message.contains("there are no fields") {
        return (message.clone(), "expected no keys here".to_string());
    }
    if let Some(i) = message.find("did not find expected ") {
        let what = message[i + "did not find ".len()..].split(", while").next().unwrap_or_default();
        return (message.clone(), what.to_string());
    }
    if message.contains("while parsing") || message.contains("while scanning") {
        return (message.clone(), "not valid YAML here".to_string());
    }
    (message.clone(), "here".to_string())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    #[test]
    fn locations_are_stripped() {
        assert_eq!(strip_locations("a: bad at line 3 column 7"), "a: bad");
        assert_eq!(
            strip_locations("did not find expected ',' at line 2 column 3, while parsing at line 1 column 1"),
            "did not find expected ',', while parsing"
        );
        assert_eq!(strip_locations("x at position 12"), "x");
    }

    #[test]
    fn expected_is_split_off() {
        assert_eq!(
            split_expected("axes[0]: unknown field `vmaxx`, expected one of `a`, `b`"),
            ("axes[0]: unknown key `vmaxx`".to_string(), "expected one of `a`, `b`".to_string())
        );
        assert_eq!(
            split_expected("axes[0]: missing field `vmax`"),
            ("axes[0]: missing key `vmax`".to_string(), "expected `vmax` in this mapping".to_string())
        );
    }

    #[test]
    fn serde_words_become_yaml_words() {
        assert_eq!(
            split_expected("invalid type: sequence, expected struct SetupFile"),
            ("invalid type: sequence".to_string(), "expected a mapping of `key: value` lines".to_string())
        );
        assert_eq!(
            split_expected("policy.branch: invalid value: string \"nearest\", expected `closest`"),
            ("policy.branch: invalid value `nearest`".to_string(), "expected `closest`".to_string())
        );
        assert_eq!(
            split_expected("kind: unknown variant `rotational`, expected `linear` or `rotary`"),
            ("kind: unknown value `rotational`".to_string(), "expected `linear` or `rotary`".to_string())
        );
    }

    #[test]
    fn line_and_column_count_characters() {
        assert_eq!(line_column("a°\nbc°d", 8), (2, 4));
        assert_eq!(line_column("abc", 0), (1, 1));
    }

    #[test]
    fn suggestions_read_well() {
        assert_eq!(did_you_mean(&[]), "");
        assert_eq!(did_you_mean(&["a".into()]), "; did you mean `a`?");
        assert_eq!(did_you_mean(&["a".into(), "b".into(), "c".into()]), "; did you mean `a`, `b` or `c`?");
    }
}
