//! `postpro check FILE`: read a CL file and summarise it, with every diagnostic. The file is read
//! in windows (memory does not grow with it), and so are the lines the diagnostics are shown
//! with.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use postpro_cl::{ClFile, Diagnostic, Summary, summarize_file};

/// How many diagnostics are rendered in full; the rest are listed one per line.
const RENDERED: usize = 20;

/// Arguments of `postpro check`.
#[derive(Debug, clap::Args)]
pub(crate) struct CheckArgs {
    /// The CL file.
    file: PathBuf,
    #[command(flatten)]
    read: crate::setup::ReadArgs,
    /// Print the summary as JSON (stable keys) instead of a table.
    #[arg(long)]
    json: bool,
    /// Print every diagnostic as one `file:line:column` line instead of rendering the first
    /// ones with the source line.
    #[arg(long)]
    brief: bool,
    /// Print the reading throughput (MB/s, the file opened, read and summarised) and the peak
    /// memory (where the system says it) to stderr.
    #[arg(long)]
    timing: bool,
}

pub(crate) fn run(args: &CheckArgs) -> ExitCode {
    let started = Instant::now();
    let read = ClFile::open(&args.file).and_then(|file| {
        let (summary, diagnostics) = summarize_file(&file, &args.read.options())?;
        Ok((file, summary, diagnostics))
    });
    let (file, summary, diagnostics) = match read {
        Ok(read) => read,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    if args.timing {
        let (mb, seconds) = (file.len() as f64 / 1e6, started.elapsed().as_secs_f64());
        eprintln!(
            "read {mb:.1} MB in {seconds:.3} s: {:.0} MB/s{}",
            mb / seconds.max(1e-9),
            crate::memory::peak_note()
        );
    }
    if let Err(e) = print_diagnostics(&file, &diagnostics, args.brief) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    let mut out = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut out, &summary).map_err(std::io::Error::from).and_then(|()| writeln!(out))
    } else {
        write!(out, "{}", table(&summary))
    };
    if let Err(e) = written {
        eprintln!("error: cannot write the summary: {e}");
        return ExitCode::from(1);
    }
    if summary.errors > 0 { ExitCode::from(1) } else { ExitCode::SUCCESS }
}

fn print_diagnostics(file: &ClFile, diagnostics: &[Diagnostic], brief: bool) -> Result<(), postpro_cl::Error> {
    let mut err = std::io::stderr().lock();
    let full = if brief { 0 } else { RENDERED };
    // Errors first: they are what stops the file from reading.
    let mut ordered: Vec<&Diagnostic> = diagnostics.iter().filter(|d| d.is_error()).collect();
    ordered.extend(diagnostics.iter().filter(|d| !d.is_error()));
    for (k, d) in ordered.iter().enumerate() {
        let text = if k < full { d.render_excerpt(&file.excerpt(d.span)?) } else { d.one_line(file) + "\n" };
        let _ = err.write_all(text.as_bytes());
    }
    if !brief && ordered.len() > full && std::io::stderr().is_terminal() {
        let _ = writeln!(err, "({} diagnostics, the first {full} shown in full)", ordered.len());
    }
    Ok(())
}

fn table(s: &Summary) -> String {
    use std::fmt::Write as _;
    let mut t = String::new();
    let opt = |v: Option<String>| v.unwrap_or_else(|| "-".into());
    let _ = writeln!(t, "file            {}", s.file);
    let _ = writeln!(t, "CAM system      {}", s.cam_system.unwrap_or("not recognised"));
    if let Some(p) = &s.part_name {
        let _ = writeln!(t, "part            {p}");
    }
    let at = s.units.at.as_ref().map(|a| format!(" at {a}")).unwrap_or_default();
    let _ = writeln!(t, "units           {} ({}{at}); figures below in mm", s.units.file.name(), s.units.origin);
    let _ = writeln!(t, "axes            {}", s.axes);
    let m = &s.moves;
    let _ = writeln!(
        t,
        "moves           {} ({} feed, {} rapid, {} holes), {} arcs, {} NURBS",
        m.total, m.feed, m.rapid, m.holes, s.arcs, s.nurbs
    );
    if s.start_points > 0 {
        let _ = writeln!(t, "start point     FROM ×{} before any tool change or move: not a move", s.start_points);
    }
    let _ = writeln!(t, "statements      {}, {} operations, {} frame changes", s.statements, s.operations, s.frames);
    let tools: Vec<String> = s
        .tools
        .iter()
        .map(|tl| {
            let d = tl.diameter.map(|d| format!(" D{d}")).unwrap_or_default();
            let r = tl.corner_radius.filter(|r| *r > 0.0).map(|r| format!(" R{r}")).unwrap_or_default();
            let n = tl.name.as_ref().map(|n| format!(" {n}")).unwrap_or_default();
            format!("T{}{n}{d}{r}", tl.number)
        })
        .collect();
    let _ = writeln!(t, "tools           {}", if tools.is_empty() { "-".into() } else { tools.join(", ") });
    let range = |r: Option<postpro_cl::Range>, unit: &str| r.map(|r| format!("{}–{} {unit}", r.min, r.max));
    let feeds: Vec<String> =
        [range(s.feeds.per_minute, "mm/min"), range(s.feeds.per_revolution, "mm/rev")].into_iter().flatten().collect();
    let _ = writeln!(
        t,
        "feeds           {} ({} distinct)",
        if feeds.is_empty() { "-".into() } else { feeds.join(", ") },
        s.feeds.distinct
    );
    let _ = writeln!(t, "spindle         {}", opt(range(s.spindle, "")));
    let bb = s.bounding_box.map(|b| {
        format!("x {} … {}, y {} … {}, z {} … {}", b.min[0], b.max[0], b.min[1], b.max[1], b.min[2], b.max[2])
    });
    let _ = writeln!(t, "bounding box    {}", opt(bb));
    let _ = writeln!(t, "path length     {} mm at feed, {} mm rapid", s.path_length.feed, s.path_length.rapid);
    let _ = writeln!(t, "tool axis       {} changes", s.axis_changes);
    let words = |m: &std::collections::BTreeMap<String, usize>| {
        if m.is_empty() {
            "-".to_string()
        } else {
            m.iter().map(|(w, n)| format!("{w} ×{n}")).collect::<Vec<_>>().join(", ")
        }
    };
    let _ = writeln!(t, "unknown words   {}", words(&s.unknown_words));
    let known: std::collections::BTreeMap<String, usize> = s
        .uninterpreted_words
        .iter()
        .filter(|(w, _)| !s.unknown_words.contains_key(*w))
        .map(|(w, n)| (w.clone(), *n))
        .collect();
    let _ = writeln!(t, "passed through  {} (known words without effect on the path)", words(&known));
    let _ = writeln!(t, "warnings        {} ({})", s.warnings.total, words(&s.warnings.by_word));
    let _ = writeln!(t, "errors          {}", s.errors);
    t
}
