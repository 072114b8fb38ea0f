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

/// The rendered report of a diagnostic whose spans point into `source`'s text (shared with the
/// report, not copied).
pub(crate) fn render_with_source<D>(diagnostic: D, source: &postpro_cl::Source) -> String
where
    D: Diagnostic + Send + Sync + 'static,
{
    render_with_code(diagnostic, source.name(), postpro_cl::Excerpt::whole(source))
}

/// The rendered report of a diagnostic whose spans point into `code` (the text, or lines of it
/// that hold them: a [`postpro_cl::Excerpt`]), named `name`.
pub(crate) fn render_with_code<D, S>(diagnostic: D, name: &str, code: S) -> String
where
    D: Diagnostic + Send + Sync + 'static,
    S: miette::SourceCode + Send + Sync + 'static,
{
    let report = miette::Report::new(diagnostic).with_source_code(NamedSource::new(name, code));
    render(report.as_ref())
}

/// Prints to standard output; a closed pipe (`postpro … | head`) ends quietly, other write
/// errors are input/output errors (exit 1).
pub(crate) fn print_stdout(text: &str) -> std::process::ExitCode {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: cannot write to standard output: {e}");
            std::process::ExitCode::from(1)
        }
    }
}
