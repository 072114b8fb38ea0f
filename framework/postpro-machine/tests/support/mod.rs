//! What the data-driven tests share: the rendering of a diagnostic as the command line prints
//! it, without colours.

/// The miette rendering (no colours, 100 columns).
pub(crate) fn render(diagnostic: &dyn miette::Diagnostic) -> String {
    let mut out = String::new();
    miette::GraphicalReportHandler::new_themed(miette::GraphicalTheme::unicode_nocolor())
        .with_width(100)
        .render_report(&mut out, diagnostic)
        .expect("renders");
    out
}
