//! Diagnostics: warnings and errors with byte spans, rendered by miette with the source line and
//! a caret, or as one `file:line:column: …` line.

use std::fmt;
use std::sync::Arc;

use miette::{GraphicalReportHandler, GraphicalTheme, LabeledSpan, MietteSpanContents, NamedSource, SourceCode};

use crate::span::{Locate, Source, Span};

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

    /// `file:line:column: warning: message (label)`, `source` locating the offset (a [`Source`],
    /// a [`crate::ClFile`], an [`Excerpt`]).
    pub fn one_line(&self, source: &impl Locate) -> String {
        let sev = match self.severity {
            Severity::Warning => "warning",
            Severity::Error => "error",
        };
        format!("{}: {sev}[{}]: {}: {}", source.location(self.span.start as usize), self.code, self.message, self.label)
    }

    /// The miette rendering: file:line:column, the source line, a caret and the label.
    /// Without colours, so it can be pinned in snapshots and read in logs.
    pub fn render(&self, source: &Source) -> String {
        self.miette(&Excerpt::whole(source)).unwrap_or_else(|| self.one_line(source))
    }

    /// What [`Self::render`] shows, from lines of the text around the diagnostic
    /// ([`crate::ClFile::excerpt`]) rather than the whole text.
    pub fn render_excerpt(&self, excerpt: &Excerpt) -> String {
        self.miette(excerpt).unwrap_or_else(|| self.one_line(excerpt))
    }

    /// The miette rendering, unless it fails.
    fn miette(&self, excerpt: &Excerpt) -> Option<String> {
        let with_source = WithSource { diagnostic: self, source: NamedSource::new(&excerpt.name, excerpt.clone()) };
        let mut out = String::new();
        let handler = GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor()).with_width(100);
        handler.render_report(&mut out, &with_source).ok().map(|()| out)
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

/// Whole lines of a source's text (or all of it) and where they sit in it: what a diagnostic is
/// shown with ([`Diagnostic::render_excerpt`]).
#[derive(Clone, Debug)]
pub struct Excerpt {
    /// The source's name (the path).
    pub(crate) name: String,
    /// The lines.
    pub(crate) text: Arc<String>,
    /// The offset of their first byte in the source's text.
    pub(crate) offset: usize,
    /// The line breaks before them (0-based line of the first).
    pub(crate) line: usize,
}

impl Excerpt {
    /// All of `source`'s text (shared, not copied).
    pub fn whole(source: &Source) -> Excerpt {
        Excerpt { name: source.name().to_string(), text: source.shared_text(), offset: 0, line: 0 }
    }
}

impl Locate for Excerpt {
    fn name(&self) -> &str {
        &self.name
    }

    /// Line and column of an offset of the whole text within the excerpt (the excerpt's first
    /// line for one before it, its end for one past it).
    fn line_col(&self, offset: usize) -> crate::span::LineCol {
        let within = offset.saturating_sub(self.offset);
        let lc = Source::new("", self.text.as_str()).line_col_scan(within);
        crate::span::LineCol { line: lc.line + self.line, column: lc.column }
    }
}

impl SourceCode for Excerpt {
    /// The lines around `span` (offsets of the whole text), as miette reads them from the whole
    /// text: read in the excerpt, their offset and line numbers moved back to the whole text's.
    fn read_span<'a>(
        &'a self,
        span: &miette::SourceSpan,
        before: usize,
        after: usize,
    ) -> Result<Box<dyn miette::SpanContents<'a> + 'a>, miette::MietteError> {
        let start = span.offset().checked_sub(self.offset).ok_or(miette::MietteError::OutOfBounds)?;
        let local = miette::SourceSpan::new(start.into(), span.len());
        let contents = self.text.as_str().read_span(&local, before, after)?;
        let whole = miette::SourceSpan::new((contents.span().offset() + self.offset).into(), contents.span().len());
        Ok(Box::new(MietteSpanContents::new(
            contents.data(),
            whole,
            contents.line() + self.line,
            contents.column(),
            contents.line_count(),
        )))
    }
}

/// A diagnostic with its source, as miette renders it.
#[derive(Debug)]
struct WithSource<'d> {
    diagnostic: &'d Diagnostic,
    source: NamedSource<Excerpt>,
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
