//! A CL file read in windows ([`ClFile`], what the main job reads) reads exactly as the whole
//! text ([`Source`]) does: the same items with the same spans, the same diagnostics and summary,
//! and the same line and column for every offset (also those of offsets asked for in order,
//! [`ClFile::lines`]); every diagnostic shown from an excerpt of the file ([`ClFile::excerpt`])
//! as from the whole text. Windows are made small (a few hundred bytes
//! to a few KiB) so that records, `$` continuations, comments, CRLF pairs and multi-byte
//! characters fall across their boundaries, and records longer than a window make it grow.
//!
//! Files: the real CL corpus, the peers' CL inputs, the bundled examples, and variants written
//! here (CR and CRLF line ends, Latin-1, no final line end, a record longer than any window).
//! With the full-size window, files over 64 KiB also test the line look-ups between
//! checkpoints inside a window.

use std::path::{Path, PathBuf};

use postpro_cl::{ClFile, Item, ReadOptions, Source, read_into_with, summarize_file, summarize_with};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Every CL file of the corpus, the peers' inputs and the examples.
fn cl_files() -> Vec<PathBuf> {
    let mut files = Vec::new();
    let shared = repo().join("../shared/data");
    collect(&shared.join("cl"), &mut files, &|p| p.extension().is_none_or(|e| e != "md"));
    collect(&shared.join("peers"), &mut files, &|p| {
        let inside_input = p.components().any(|c| c.as_os_str() == "input" || c.as_os_str() == "holdout");
        let cl_like = p.extension().is_none_or(|e| !["md", "LOG", "pptable"].contains(&e.to_string_lossy().as_ref()));
        inside_input && cl_like
    });
    collect(&repo().join("examples/cl"), &mut files, &|p| p.extension().is_some_and(|e| e == "cl"));
    files.sort();
    assert!(files.len() >= 30, "expected the CL corpus, the peers' inputs and the examples, found {}", files.len());
    files
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>, keep: &dyn Fn(&Path) -> bool) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()));
    for entry in entries {
        let path = entry.unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display())).path();
        if path.is_dir() {
            collect(&path, out, keep);
        } else if keep(&path) {
            out.push(path);
        }
    }
}

/// What a reading gives, as comparable text (numbers through their round-trip `Debug`).
fn reading_of_source(source: &Source, options: &ReadOptions) -> String {
    let mut items: Vec<Item> = Vec::new();
    let (info, diagnostics) = read_into_with(source, options, &mut items);
    format!("{items:#?}\n{info:#?}\n{diagnostics:#?}")
}

fn reading_of_file(file: &ClFile, options: &ReadOptions) -> String {
    let mut items: Vec<Item> = Vec::new();
    let (info, diagnostics) =
        file.read_into_with(options, &mut items).unwrap_or_else(|e| panic!("{}: {e}", file.name()));
    format!("{items:#?}\n{info:#?}\n{diagnostics:#?}")
}

/// Reads `path` whole and in windows of each size; asserts the readings and the line and column
/// of a sample of offsets are equal.
fn assert_windows_read_as_whole(path: &Path, windows: &[usize]) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let source = Source::from_bytes(path.display().to_string(), bytes);
    let options = ReadOptions::default();
    let whole = reading_of_source(&source, &options);
    let len = source.text().len();
    for &window in windows {
        let file = ClFile::open_in_windows(path, window).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(file.len(), len, "{}: the text's length", path.display());
        let windowed = reading_of_file(&file, &options);
        if windowed != whole {
            let at = whole.lines().zip(windowed.lines()).position(|(a, b)| a != b).unwrap_or(0);
            let around = |s: &str| s.lines().skip(at.saturating_sub(5)).take(12).collect::<Vec<_>>().join("\n");
            panic!(
                "{} read in windows of {window} bytes differs from the whole text at line {at} of the dump:\n\
                 whole:\n{}\nwindowed:\n{}",
                path.display(),
                around(&whole),
                around(&windowed)
            );
        }
        // `check`'s summary, read in windows, is the whole text's.
        let (summary, diagnostics) = summarize_file(&file, &options).unwrap_or_else(|e| panic!("{}: {e}", file.name()));
        let (whole_summary, whole_diagnostics) = summarize_with(&source, &options);
        assert_eq!(
            format!("{summary:#?}\n{diagnostics:#?}"),
            format!("{whole_summary:#?}\n{whole_diagnostics:#?}"),
            "{}: the summary read in windows of {window} bytes",
            path.display()
        );
        // Each diagnostic shown with lines read around it, as with the whole text.
        for d in &whole_diagnostics {
            let excerpt = file.excerpt(d.span).unwrap_or_else(|e| panic!("{}: {e}", file.name()));
            assert_eq!(d.render_excerpt(&excerpt), d.render(&source), "{}: windows of {window}", path.display());
            assert_eq!(d.one_line(&file), d.one_line(&source), "{}: windows of {window}", path.display());
        }
        let step = (len / 97).max(1);
        for offset in (0..=len).step_by(step).chain([len]) {
            assert_eq!(
                file.line_col(offset),
                source.line_col(offset),
                "{}: line and column of offset {offset} (windows of {window})",
                path.display()
            );
        }
    }
    // The lines and columns of offsets in increasing order, read on from the last: every
    // character of the first 4 KiB (line ends of every kind), then a sample, then past the end.
    let file = ClFile::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = file.lines().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = source.text();
    let first = (0..=len.min(4096)).filter(|&o| text.is_char_boundary(o));
    let sample = (4097..=len).step_by((len / 97).max(1)).filter(|&o| text.is_char_boundary(o));
    for offset in first.chain(sample).chain([len, len + 10]) {
        let found = lines.line_col(offset).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(found, source.line_col(offset), "{}: line and column of offset {offset}, in order", path.display());
    }
}

#[test]
fn every_real_file_reads_in_windows_as_whole() {
    for path in cl_files() {
        assert_windows_read_as_whole(&path, &[193, 4096, 4 << 20]);
    }
}

#[test]
fn line_ends_encodings_and_long_records_cross_window_boundaries() {
    let dir = std::env::temp_dir().join(format!("postpro-cl-windows-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let base = std::fs::read_to_string(repo().join("examples/cl/hypar-5axis.cl")).expect("the example");
    let long_record = format!("PPRINT/{}\nINSERT/{}$\n{}\n", "X".repeat(3000), "Y".repeat(900), "Z".repeat(900));
    let mut cases: Vec<(&str, Vec<u8>)> = vec![
        ("crlf.cl", base.replace('\n', "\r\n").into_bytes()),
        ("cr.cl", base.replace('\n', "\r").into_bytes()),
        ("no-final-line-end.cl", base.trim_end().as_bytes().to_vec()),
        ("long-record.cl", format!("{long_record}{base}{long_record}").into_bytes()),
        ("utf8.cl", format!("PPRINT/Maße für Ölwanne €\n{base}PPRINT/Schlußprüfung\n").into_bytes()),
        // Errors all through a file of several checkpoints (64 KiB apart), right after them
        // too: each one's excerpt must hold the lines around it.
        ("errors.cl", {
            let mut text = String::new();
            for (k, line) in base.lines().cycle().take(12_000).enumerate() {
                text.push_str(if k % 997 == 0 || k % 1499 == 1 { "GOTO/1,2,zz" } else { line });
                text.push('\n');
            }
            text.into_bytes()
        }),
    ];
    // Latin-1: a byte from 0x80 up in the file, two bytes in the text.
    let mut latin1 = b"PPRINT/Ma\xdfe f\xfcr \xd6lwanne\r\n".to_vec();
    latin1.extend_from_slice(base.replace('\n', "\r\n").as_bytes());
    latin1.extend_from_slice(b"PPRINT/Schlu\xdfpr\xfcfung\r\n");
    cases.push(("latin1.cl", latin1));
    // Latin-1 found late, after lines that read as UTF-8 (`Ã©` there, two characters): the
    // pre-scan cannot go on from those lines as read at first.
    let mut late = "PPRINT/caf\u{e9}\n".as_bytes().to_vec();
    late.extend_from_slice(base.as_bytes());
    late.extend_from_slice(b"PPRINT/Ma\xdfe\n");
    late.extend_from_slice(base.as_bytes());
    cases.push(("latin1-late.cl", late));
    // Latin-1 found late, after ASCII lines only: the pre-scan goes on, decoding.
    let mut ascii_first = base.as_bytes().to_vec();
    ascii_first.extend_from_slice(b"PPRINT/Ma\xdfe\n");
    ascii_first.extend_from_slice(base.as_bytes());
    cases.push(("latin1-after-ascii.cl", ascii_first));
    for (name, bytes) in cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).expect("a scratch file");
        assert_windows_read_as_whole(&path, &[1, 7, 64, 193, 1000, 4 << 20]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_that_changes_between_readings_is_refused() {
    let dir = std::env::temp_dir().join(format!("postpro-cl-changed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let path = dir.join("part.cl");
    std::fs::write(&path, "GOTO/1,2,3\nGOTO/4,5,6\n").expect("a scratch file");
    let file = ClFile::open(&path).expect("opens");
    let mut items: Vec<Item> = Vec::new();
    file.read_into_with(&ReadOptions::default(), &mut items).expect("reads while unchanged");
    std::fs::write(&path, "GOTO/1,2,3\nGOTO/4,5,6\nGOTO/7,8,9\n").expect("the file rewritten");
    let e = file.read_into_with(&ReadOptions::default(), &mut items).expect_err("the text changed");
    assert!(matches!(e, postpro_cl::Error::Changed { .. }), "{e:?}");
    assert!(e.to_string().ends_with("changed while it was being read; run again once it is written"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
