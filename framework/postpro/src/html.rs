//! The prediction as one self-contained HTML page (`postpro predict … --report FILE.html`) for
//! people who would rather look than read: the totals, the plot (the SVG of `--plot`, inline),
//! the time lost by cause, a row per operation and every slowdown marked with its number and CL
//! line. No script, no external resource: the page opens anywhere, offline, and prints.
//!
//! The page is written as well-formed XML-style HTML (every element closed, every attribute
//! quoted, text escaped), each part a `<section id="…">`, so that a test can read it back.

use std::fmt::Write as _;

/// What the page shows.
pub(crate) struct Report {
    /// The page's title: file and machine.
    pub(crate) title: String,
    /// The line under it: planner, mode, blocks, what is marked.
    pub(crate) setup: String,
    /// The totals: (label, value with its unit).
    pub(crate) totals: Vec<(String, String)>,
    /// The time lost by cause: (cause, seconds, blocks); a total row adds them up.
    pub(crate) causes: Vec<(String, f64, usize)>,
    /// One row per operation, in program order.
    pub(crate) operations: Vec<OperationRow>,
    /// Every slowdown marked, the worst first.
    pub(crate) marks: Vec<MarkRow>,
    /// The assumptions the prediction made.
    pub(crate) notes: Vec<String>,
    /// The plot, as SVG text.
    pub(crate) svg: String,
}

/// An operation's figures.
pub(crate) struct OperationRow {
    pub(crate) name: String,
    pub(crate) cycle_time: f64,
    pub(crate) programmed_time: f64,
    pub(crate) time_lost: f64,
    pub(crate) cause: String,
}

/// A slowdown marked in the program.
pub(crate) struct MarkRow {
    /// Its number (the program's comment `slowdown #N: …`).
    pub(crate) number: usize,
    /// The CL line of its first block.
    pub(crate) line: usize,
    pub(crate) operation: String,
    /// What the comment says after `slowdown #N: `.
    pub(crate) text: String,
    pub(crate) time_lost: f64,
}

const STYLE: &str = "body{font-family:sans-serif;margin:24px;color:#222;max-width:1440px}\
h1{font-size:22px;margin:0 0 4px}h2{font-size:17px;margin:28px 0 8px}p.setup{color:#555;margin:0 0 16px}\
table{border-collapse:collapse;font-size:14px}th,td{padding:4px 10px;border-bottom:1px solid #ddd;text-align:left}\
td.n,th.n{text-align:right;font-variant-numeric:tabular-nums}th{background:#f4f4f4}\
dl.totals{display:grid;grid-template-columns:max-content max-content;gap:4px 16px;margin:0}\
dl.totals dt{color:#555}dl.totals dd{margin:0;font-variant-numeric:tabular-nums}\
figure{margin:0}figure svg{width:100%;height:auto;border:1px solid #eee}";

/// Escapes text for HTML content and attribute values.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// The SVG without its XML declaration, to stand inside the page.
fn inline_svg(svg: &str) -> &str {
    match svg.trim_start().strip_prefix("<?xml") {
        Some(rest) => rest.split_once("?>").map_or(svg, |(_, body)| body.trim_start()),
        None => svg.trim_start(),
    }
}

/// The page.
pub(crate) fn report(r: &Report) -> String {
    let mut out = String::with_capacity(r.svg.len() + 16 * 1024);
    let title = escape(&r.title);
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>{title}: predicted feed</title>\n\
         <style>{STYLE}</style>\n</head>\n<body>\n<h1>{title}</h1>\n<p class=\"setup\">{}</p>\n",
        escape(&r.setup)
    );
    out.push_str("<section id=\"totals\">\n<h2>Totals</h2>\n<dl class=\"totals\">\n");
    for (label, value) in &r.totals {
        let _ = writeln!(out, "<dt>{}</dt><dd>{}</dd>", escape(label), escape(value));
    }
    out.push_str("</dl>\n");
    for note in &r.notes {
        let _ = writeln!(out, "<p class=\"note\">note: {}</p>", escape(note));
    }
    out.push_str("</section>\n");

    let _ = write!(
        out,
        "<section id=\"plot\">\n<h2>Feed along the path</h2>\n<figure>\n{}\n</figure>\n</section>\n",
        inline_svg(&r.svg)
    );

    out.push_str(
        "<section id=\"operations\">\n<h2>Operations</h2>\n<table>\n<thead><tr><th>operation</th>\
         <th class=\"n\">predicted s</th><th class=\"n\">at the programmed feed s</th><th class=\"n\">lost s</th>\
         <th>mostly</th></tr></thead>\n<tbody>\n",
    );
    for o in &r.operations {
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td class=\"n\">{:.2}</td><td class=\"n\">{:.2}</td><td class=\"n\">{:.2}</td><td>{}</td></tr>",
            escape(&o.name),
            o.cycle_time,
            o.programmed_time,
            o.time_lost,
            escape(&o.cause)
        );
    }
    out.push_str("</tbody>\n</table>\n</section>\n");

    out.push_str(
        "<section id=\"causes\">\n<h2>Time lost by cause</h2>\n<table>\n<thead><tr><th>cause</th>\
         <th class=\"n\">lost s</th><th class=\"n\">blocks</th></tr></thead>\n<tbody>\n",
    );
    for (cause, seconds, blocks) in &r.causes {
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td class=\"n\">{seconds:.2}</td><td class=\"n\">{blocks}</td></tr>",
            escape(cause)
        );
    }
    let total: f64 = r.causes.iter().map(|c| c.1).sum();
    let _ = writeln!(out, "</tbody>\n<tfoot><tr><th>total</th><th class=\"n\">{total:.2}</th><th></th></tr></tfoot>");
    out.push_str("</table>\n</section>\n");

    out.push_str(
        "<section id=\"marks\">\n<h2>Slowdowns marked, the worst first</h2>\n<p>Each is a comment \
         <code>slowdown #N: …</code> before its first block in the NC program.</p>\n<table>\n<thead><tr>\
         <th class=\"n\">mark</th><th class=\"n\">CL line</th><th>operation</th><th class=\"n\">lost s</th>\
         <th>slowdown</th></tr></thead>\n<tbody>\n",
    );
    for m in &r.marks {
        let _ = writeln!(
            out,
            "<tr><td class=\"n\">#{}</td><td class=\"n\">{}</td><td>{}</td><td class=\"n\">{:.2}</td><td>{}</td></tr>",
            m.number,
            m.line,
            escape(&m.operation),
            m.time_lost,
            escape(&m.text)
        );
    }
    out.push_str("</tbody>\n</table>\n</section>\n</body>\n</html>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_and_the_xml_declaration_dropped() {
        assert_eq!(escape("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
        assert_eq!(inline_svg("<?xml version=\"1.0\"?>\n<svg></svg>"), "<svg></svg>");
        assert_eq!(inline_svg("<svg></svg>"), "<svg></svg>");
    }
}
