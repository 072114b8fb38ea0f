//! Rendering of diagnostics for the terminal and logs: miette's graphical report without
//! colours (stable in logs, snapshots and CI), the source attached where the error has a span.

use miette::{Diagnostic, GraphicalReportHandler, GraphicalTheme, NamedSource};

/// The rendered report of a diagnostic that carries its own source (or needs none).
pub(crate) fn render(diagnostic: &dyn Diagnostic) -> String {
    let mut out = String::new();
    let handler = GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor()).with_width(100);
    if handler.render_report(&mut out, diagnostic).is_err() {
        return format!("error: {diagnostic}\n");
    }
    out
}

/// The rendered report of a diagnostic whose spans point into `text` (named `name`).
pub(crate) fn render_with_source<D>(diagnostic: D, name: &str, text: &str) -> String
where
    D: Diagnostic + Send + Sync + 'static,
{
    let report = miette::Report::new(diagnostic).with_source_code(NamedSource::new(name, text.to_string()));
    render(report.as_ref())
}
