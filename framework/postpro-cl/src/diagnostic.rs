//! Diagnostics: warnings and errors with byte spans, rendered by miette with the source line and
//! a caret, or as one `file:line:column: …` line.

use std::fmt;
use std::sync::Arc;

use miette::{GraphicalReportHandler, GraphicalTheme, LabeledSpan, NamedSource, SourceCode};

use crate::span::{Source, Span};

/// How bad a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// The statement still has one clear meaning; reading goes on.
    Warning,
    /// The statement has no clear meaning; the file does not read.
    Error,
}

/// A warning or error about one place in the source.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// Warning or error.
    pub severity: Severity,
    /// A stable code, such as `cl::syntax`.
    pub code: &'static str,
    /// What is wrong.
    pub message: String,
    /// Where.
    pub span: Span,
    /// The label under the caret: what was expected there.
    pub label: String,
    /// How to fix it, or what the reader did about it.
    pub help: Option<String>,
    /// The major word of the statement (canonical), for the summary by word.
    pub word: Option<String>,
}

impl Diagnostic {
    /// A diagnostic without help or word.
    pub(crate) fn new(severity: Severity, code: &'static str, span: Span, message: String, label: String) -> Self {
        Diagnostic { severity, code, message, span, label, help: None, word: None }
    }

    /// With a help text.
    pub(crate) fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    /// With the statement's major word.
    pub(crate) fn with_word(mut self, word: Option<String>) -> Self {
        self.word = word;
        self
    }

    /// True for errors.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// `file:line:column: warning: message (label)`.
    pub fn one_line(&self, source: &Source) -> String {
        let sev = match self.severity {
            Severity::Warning => "warning",
            Severity::Error => "error",
        };
        format!("{}: {sev}[{}]: {}: {}", source.location(self.span.start as usize), self.code, self.message, self.label)
    }

    /// The miette rendering: file:line:column, the source line, a caret and the label.
    /// Without colours, so it can be pinned in snapshots and read in logs.
    pub fn render(&self, source: &Source) -> String {
        let with_source =
            WithSource { diagnostic: self, source: NamedSource::new(source.name(), SharedText(source.shared_text())) };
        let mut out = String::new();
        let handler = GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor()).with_width(100);
        if handler.render_report(&mut out, &with_source).is_err() {
            return self.one_line(source);
        }
        out
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Diagnostic {}

impl miette::Diagnostic for Diagnostic {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.code))
    }

    fn severity(&self) -> Option<miette::Severity> {
        Some(match self.severity {
            Severity::Warning => miette::Severity::Warning,
            Severity::Error => miette::Severity::Error,
        })
    }

    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.help.as_ref().map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        let label = LabeledSpan::new_primary_with_span(Some(self.label.clone()), self.span);
        Some(Box::new(std::iter::once(label)))
    }
}

/// The shared source text, for miette.
#[derive(Debug)]
struct SharedText(Arc<String>);

impl SourceCode for SharedText {
    fn read_span<'a>(
        &'a self,
        span: &miette::SourceSpan,
        before: usize,
        after: usize,
    ) -> Result<Box<dyn miette::SpanContents<'a> + 'a>, miette::MietteError> {
        self.0.as_str().read_span(span, before, after)
    }
}

/// A diagnostic with its source, as miette renders it.
#[derive(Debug)]
struct WithSource<'d> {
    diagnostic: &'d Diagnostic,
    source: NamedSource<SharedText>,
}

impl fmt::Display for WithSource<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self.diagnostic, f)
    }
}

impl std::error::Error for WithSource<'_> {}

impl miette::Diagnostic for WithSource<'_> {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.diagnostic.code()
    }
    fn severity(&self) -> Option<miette::Severity> {
        miette::Diagnostic::severity(self.diagnostic)
    }
    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.diagnostic.help()
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        self.diagnostic.labels()
    }
    fn source_code(&self) -> Option<&dyn SourceCode> {
        Some(&self.source)
    }
}
