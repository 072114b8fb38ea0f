//! A CL file read in windows, never held whole: what the main job reads with memory that does not
//! grow with the file. Opening it reads it once (its encoding and length, and for a UTF-8 file the
//! reader's pre-scan); each pass of a reading (the pre-scan of a Latin-1 file, the reading) asks
//! for its windows in order; a window ends at a line end, and what a pass has not finished of it (a
//! record that runs past its end) starts the next. The text is that of [`Source::from_bytes`]:
//! UTF-8 if the whole file is, else Latin-1, so spans, lines and columns are the same as a
//! [`Source`]'s of the same file.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::SystemTime;

use crate::diagnostic::Excerpt;
use crate::read::prescan::{Prescan, Prescanner};
use crate::read::{ItemSink, ReadOptions, Window, prescan_windows, read_windows};
use crate::span::{LineCol, Locate, Source, Span};
use crate::{Diagnostic, Error, ProgramInfo};

/// The size of a window (a record longer than that makes it grow).
const WINDOW: usize = 4 << 20;
/// The size of a read.
const BLOCK: usize = 1 << 20;
/// The least read that ends a window (what runs past the window's size to the end of a line).
const LINE_READ: usize = 4 << 10;
/// The text between two line-and-column checkpoints (about; each is at a line start).
const STRIDE: usize = 64 << 10;

/// A CL file on disk, read in windows.
#[derive(Debug)]
pub struct ClFile {
    path: PathBuf,
    name: String,
    latin1: bool,
    len: usize,
    /// The file's length and modification time when opened: every reading checks them.
    stamp: (u64, Option<SystemTime>),
    /// The size of a window (and the most read at once).
    window: usize,
    /// Line starts about [`STRIDE`] apart, for line and column look-ups (found on the first).
    checkpoints: OnceLock<Vec<Checkpoint>>,
    /// The reader's pre-scan, done while the file was opened (a UTF-8 file: its text is known
    /// then), or else by the first reading (a Latin-1 file).
    prescan: OnceLock<Prescan>,
}

/// A line start: its offset in the text and in the file, and the line breaks before it.
#[derive(Clone, Copy, Debug, Default)]
struct Checkpoint {
    text: usize,
    file: u64,
    lines_before: usize,
}

impl ClFile {
    /// Opens `path` and finds its encoding and length (one pass over it, which also does the
    /// reader's pre-scan of a UTF-8 file).
    pub fn open(path: &Path) -> Result<ClFile, Error> {
        ClFile::open_reading(path, BLOCK, WINDOW)
    }

    /// The same file opened with reads of `bytes` and read in windows of about `bytes` (for tests
    /// of the window boundaries).
    #[doc(hidden)]
    pub fn open_in_windows(path: &Path, bytes: usize) -> Result<ClFile, Error> {
        ClFile::open_reading(path, bytes.max(1), bytes.max(1))
    }

    /// Opens `path` reading `read` bytes at a time, to be read in windows of `window` bytes.
    fn open_reading(path: &Path, read: usize, window: usize) -> Result<ClFile, Error> {
        let name = path.display().to_string();
        let io = |source| Error::Io { path: name.clone(), source };
        let mut file = std::fs::File::open(path).map_err(io)?;
        let stamp = stamp_of(&file).map_err(io)?;
        let (mut bytes, mut high) = (0u64, 0u64);
        let mut latin1 = false;
        // While the text is known: the pre-scan, the text not scanned yet (a record running past
        // the lines read so far comes again) and its offset. Lines end at ASCII bytes, so whole
        // lines never cut a UTF-8 sequence: checking them in turn checks the file.
        let mut scan = Some((Prescanner::default(), Vec::<u8>::new(), 0usize));
        // The bytes read, where they are not read into the text itself (a Latin-1 file).
        let mut block = Vec::new();
        loop {
            let (n, last) = match scan.as_mut() {
                Some((_, text, _)) if !latin1 => {
                    // Read into the text itself, not copied through a block.
                    let start = text.len();
                    text.reserve(read);
                    let n = Read::take(&mut file, read as u64).read_to_end(text).map_err(io)?;
                    high += high_bytes(&text[start..]);
                    (n, n < read)
                }
                _ => {
                    block.resize(read, 0);
                    let n = file.read(&mut block).map_err(io)?;
                    high += high_bytes(&block[..n]);
                    if let Some((_, text, _)) = scan.as_mut() {
                        push_latin1(text, &block[..n]);
                    }
                    (n, n == 0)
                }
            };
            bytes += n as u64;
            if let Some((scanner, text, base)) = scan.as_mut()
                && !scan_lines(scanner, text, base, last)
            {
                latin1 = true;
                // Not UTF-8: Latin-1. While the lines scanned so far were ASCII, which reads the
                // same in both, the pre-scan goes on with the text decoded; else the first
                // reading does it.
                let raw = std::mem::take(text);
                if high_bytes(&raw) == high {
                    push_latin1(text, &raw);
                    // Decoded Latin-1 is UTF-8.
                    let _ = scan_lines(scanner, text, base, last);
                } else {
                    scan = None;
                }
            }
            if last {
                break;
            }
        }
        if bytes != stamp.0 {
            return Err(Error::Changed { path: name });
        }
        let len = if latin1 { bytes + high } else { bytes };
        if len > Source::MAX_LEN as u64 {
            return Err(Error::TooLarge { path: name, size: len });
        }
        Ok(ClFile {
            path: path.to_path_buf(),
            name,
            latin1,
            len: len as usize,
            stamp,
            window,
            checkpoints: OnceLock::new(),
            prescan: scan.map_or_else(OnceLock::new, |(scanner, ..)| OnceLock::from(scanner.finish())),
        })
    }

    /// The name shown in diagnostics (the path).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The length of the text (bytes of UTF-8).
    pub fn len(&self) -> usize {
        self.len
    }

    /// True for an empty file.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The whole text, for showing a diagnostic with its lines (read again).
    pub fn source(&self) -> Result<Source, Error> {
        let source = Source::from_path(&self.path)?;
        if source.text().len() != self.len {
            return Err(Error::Changed { path: self.name.clone() });
        }
        Ok(source)
    }

    /// Reads the file with options, handing each item to `sink` as soon as it is complete, as
    /// [`crate::read_into_with`] reads a [`Source`], with the same items and diagnostics.
    pub fn read_into_with(
        &self,
        options: &ReadOptions,
        sink: &mut impl ItemSink,
    ) -> Result<(ProgramInfo, Vec<Diagnostic>), Error> {
        let mut windows =
            |each: &mut dyn FnMut(&Window, bool) -> usize| self.windows_from(Checkpoint::default(), self.window, each);
        let prescan = match self.prescan.get() {
            Some(&prescan) => prescan,
            None => {
                let prescan = prescan_windows(&mut windows)?;
                *self.prescan.get_or_init(|| prescan)
            }
        };
        read_windows(windows, self.len, Some(prescan), options, sink)
    }

    /// Line and column of an offset of the text (1-based); reads about [`STRIDE`] bytes of the
    /// file (the first look-up also reads the whole file once, for the checkpoints). An offset
    /// past the end is taken as the end; line 0 if the file cannot be read.
    pub fn line_col(&self, offset: usize) -> LineCol {
        let offset = offset.min(self.len);
        let Ok(from) = self.checkpoint_before(offset, 0) else { return LineCol { line: 0, column: 0 } };
        let mut found = LineCol { line: 0, column: 0 };
        let mut look = |w: &Window, last: bool| {
            if offset >= w.base + w.text.len() && !last {
                return w.text.len();
            }
            let lc = Source::new("", w.text.as_str()).line_col(offset - w.base);
            found = LineCol { line: w.lines_before + lc.line, column: lc.column };
            w.text.len() + 1 // found: stop
        };
        let _ = self.windows_from(from, STRIDE, &mut look);
        found
    }

    /// Whole lines of the text around `span`: from a stretch of lines before it (the checkpoint
    /// before the one at or before it) to a few lines after it, what a diagnostic is shown with
    /// ([`Diagnostic::render_excerpt`]) without reading the whole text. Reads about two
    /// [`STRIDE`]s (the first excerpt or look-up also reads the whole file once, for the
    /// checkpoints).
    pub fn excerpt(&self, span: Span) -> Result<Excerpt, Error> {
        // More lines after the span than miette shows around it.
        const AFTER: usize = 4;
        let start = (span.start as usize).min(self.len);
        let end = (span.start as usize + span.len as usize).clamp(start, self.len);
        let from = self.checkpoint_before(start, 1)?;
        let mut text = String::new();
        let mut collect = |w: &Window, last: bool| {
            text.push_str(&w.text);
            let read_to = from.text + text.len();
            let enough = read_to > end && line_breaks(&text.as_bytes()[end - from.text..]) > AFTER;
            if enough || last { w.text.len() + 1 } else { w.text.len() }
        };
        self.windows_from(from, STRIDE, &mut collect)?;
        Ok(Excerpt { name: self.name.clone(), text: Arc::new(text), offset: from.text, line: from.lines_before })
    }

    /// `name:line:column` of an offset of the text.
    pub fn location(&self, offset: usize) -> String {
        Locate::location(self, offset)
    }

    /// The lines and columns of offsets asked for in increasing order (each step and decision of
    /// a solution), by one more reading of the file from its start: each look-up reads on from
    /// the last, where [`ClFile::line_col`] reads a stretch of the file every time.
    pub fn lines(&self) -> Result<Lines, Error> {
        let file = self.reopen()?;
        let reader = std::io::BufReader::with_capacity(BLOCK, file);
        let at = Walk { text: 0, line: 1, column: 0, after_cr: false };
        Ok(Lines { reader, latin1: self.latin1, len: self.len, at })
    }

    /// The file opened again for a reading, unless it changed since it was first read.
    fn reopen(&self) -> Result<std::fs::File, Error> {
        let io = |source| Error::Io { path: self.name.clone(), source };
        let file = std::fs::File::open(&self.path).map_err(io)?;
        if stamp_of(&file).map_err(io)? != self.stamp {
            return Err(Error::Changed { path: self.name.clone() });
        }
        Ok(file)
    }

    /// The checkpoint at or before `offset`, or `back` checkpoints before that one (the first if
    /// there are not so many); an error if the file cannot be read again or changed.
    fn checkpoint_before(&self, offset: usize, back: usize) -> Result<Checkpoint, Error> {
        let points = self.checkpoints()?;
        let at = points.partition_point(|p| p.text <= offset).saturating_sub(1 + back);
        Ok(points.get(at).copied().unwrap_or_default())
    }

    /// The checkpoints, found by reading the file once.
    fn checkpoints(&self) -> Result<&[Checkpoint], Error> {
        if let Some(points) = self.checkpoints.get() {
            return Ok(points);
        }
        let mut points: Vec<Checkpoint> = Vec::new();
        let mut record = |w: &Window, _: bool| {
            let text = w.text.as_str();
            let (mut at, mut lines_before) = (0, w.lines_before);
            loop {
                points.push(Checkpoint { text: w.base + at, file: 0, lines_before });
                let Some(next) = line_start_after(text, at + STRIDE) else { break };
                lines_before += line_breaks(&text.as_bytes()[at..next]);
                at = next;
            }
            text.len()
        };
        self.windows_from(Checkpoint::default(), self.window, &mut record)?;
        self.with_file_offsets(&mut points)?;
        Ok(self.checkpoints.get_or_init(|| points))
    }

    /// Sets the file offset of each checkpoint.
    fn with_file_offsets(&self, points: &mut [Checkpoint]) -> Result<(), Error> {
        if !self.latin1 {
            points.iter_mut().for_each(|p| p.file = p.text as u64);
            return Ok(());
        }
        // Latin-1: a byte from 0x80 up is two bytes of text.
        let io = |source| Error::Io { path: self.name.clone(), source };
        let mut file = std::fs::File::open(&self.path).map_err(io)?;
        let mut block = vec![0u8; BLOCK];
        let (mut text, mut file_offset) = (0usize, 0u64);
        let mut wanted = points.iter_mut().peekable();
        loop {
            let n = file.read(&mut block).map_err(io)?;
            for &b in &block[..n] {
                while let Some(p) = wanted.next_if(|p| p.text <= text) {
                    p.file = file_offset;
                }
                text += if b >= 0x80 { 2 } else { 1 };
                file_offset += 1;
            }
            if n == 0 {
                wanted.for_each(|p| p.file = file_offset);
                return Ok(());
            }
        }
    }

    /// The windows of the text from checkpoint `from`, in order, each of about `size` bytes
    /// (see the module's documentation); `each` says how much of a window it is done with, or
    /// stops the walk by returning more than the window's length.
    fn windows_from(
        &self,
        from: Checkpoint,
        size: usize,
        each: &mut dyn FnMut(&Window, bool) -> usize,
    ) -> Result<(), Error> {
        let io = |source| Error::Io { path: self.name.clone(), source };
        let changed = || Error::Changed { path: self.name.clone() };
        let mut file = self.reopen()?;
        if from.file > 0 {
            std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(from.file)).map_err(io)?;
        }
        let (mut base, mut lines_before) = (from.text, from.lines_before);
        // The text from `base` on: what the last window left, then what was read after it (in
        // a Latin-1 file, decoded); whole lines up to `whole`. One buffer, handed to each window
        // and taken back: the file's bytes are read into it, not copied through another.
        let mut text: Vec<u8> = Vec::new();
        let mut whole = 0;
        let read = BLOCK.min(size);
        let mut block = if self.latin1 { vec![0u8; read] } else { Vec::new() };
        let mut eof = false;
        let mut want = size;
        // Windows the pass kept (the reader holds the one before its current one, for messages):
        // each one's buffer is taken back for the text once the pass lets go of it, rather than
        // a new buffer grown (and its pages faulted in) for every window.
        let mut kept: std::collections::VecDeque<Arc<String>> = std::collections::VecDeque::new();
        loop {
            // Whole lines up to the window's size (or to the end of the file): reads up to the
            // size, then small ones to the end of the line it cuts, into a buffer reserved
            // exactly for the window and a line or two past it (grown by doubling, it would end
            // up to twice the window: it is handed from window to window).
            while whole < want && !eof {
                let chunk = want.saturating_sub(text.len()).max(LINE_READ).min(read);
                let room = if self.latin1 { 2 * chunk } else { chunk };
                let capacity = (want + 2 * LINE_READ).max(text.len() + room);
                text.reserve_exact(capacity - text.len());
                if self.latin1 {
                    let n = file.read(&mut block[..chunk]).map_err(io)?;
                    push_latin1(&mut text, &block[..n]);
                    eof = n == 0;
                } else {
                    let n = Read::take(&mut file, chunk as u64).read_to_end(&mut text).map_err(io)?;
                    eof = n < chunk;
                }
                // The lines before the new bytes were whole already.
                whole = if eof { text.len() } else { whole + last_line_end(&text[whole..]) };
            }
            let rest = text.split_off(whole);
            let last = eof && rest.is_empty();
            if last && base + text.len() != self.len {
                return Err(changed());
            }
            // Whole lines of a file that was UTF-8 when opened are: else it changed since.
            let window_text = String::from_utf8(std::mem::take(&mut text)).map_err(|_| changed())?;
            let window = Window { text: Arc::new(window_text), base, lines_before };
            let done = each(&window, last);
            if last || done > window.text.len() {
                return Ok(());
            }
            if done == 0 {
                // A record longer than the window: a larger one.
                want = want.saturating_mul(2);
            } else {
                lines_before += line_breaks(&window.text.as_bytes()[..done]);
                base += done;
            }
            // What the window left, in its buffer unless the window was kept.
            text = match Arc::try_unwrap(window.text) {
                Ok(left) => {
                    let mut left = left.into_bytes();
                    left.drain(..done);
                    left
                }
                Err(window) => {
                    let mut buffer = match kept.pop_front().map(Arc::try_unwrap) {
                        Some(Ok(released)) => released.into_bytes(),
                        Some(Err(still_held)) => {
                            kept.push_front(still_held);
                            Vec::new()
                        }
                        None => Vec::new(),
                    };
                    buffer.clear();
                    buffer.extend_from_slice(&window.as_bytes()[done..]);
                    kept.push_back(window);
                    buffer
                }
            };
            if done > 0 {
                want = size.max(text.len() * 2);
            }
            whole = text.len();
            text.extend_from_slice(&rest);
        }
    }
}

/// The line and column of each offset of a [`ClFile`]'s text, asked for in increasing order
/// ([`ClFile::lines`]): what [`ClFile::line_col`] gives (a line ends at `\n`, `\r\n` or a lone
/// `\r`; a column counts characters).
#[derive(Debug)]
pub struct Lines {
    reader: std::io::BufReader<std::fs::File>,
    latin1: bool,
    len: usize,
    /// Where the reading is.
    at: Walk,
}

/// Where [`Lines`] has read up to in the text.
#[derive(Debug)]
struct Walk {
    /// The offset of the text read up to, its line, and the characters of that line before it.
    text: usize,
    line: usize,
    column: usize,
    /// The last byte read was a `\r`: a line starts after it unless a `\n` follows.
    after_cr: bool,
}

impl Lines {
    /// The line and column (1-based) of `offset`, which is not below the last one asked for (an
    /// offset below it gets the place of the last one); the end of the text for an offset beyond
    /// it.
    pub fn line_col(&mut self, offset: usize) -> std::io::Result<LineCol> {
        use std::io::BufRead;
        let offset = offset.min(self.len);
        let at = &mut self.at;
        while at.text < offset {
            let buffer = self.reader.fill_buf()?;
            if buffer.is_empty() {
                break;
            }
            let used = if self.latin1 { at.latin1(buffer, offset) } else { at.utf8(buffer, offset) };
            self.reader.consume(used);
        }
        // At a `\r`'s end: a line starts here unless a `\n` comes next.
        if at.after_cr {
            let next = self.reader.fill_buf()?.first().copied();
            if next != Some(b'\n') {
                return Ok(LineCol { line: at.line + 1, column: 1 });
            }
        }
        Ok(LineCol { line: at.line, column: at.column + 1 })
    }
}

impl Walk {
    /// Takes in the bytes of `buffer` up to `offset` (a UTF-8 file: a byte is a byte of text)
    /// by their line ends, counting the characters of the last line only; returns how many.
    fn utf8(&mut self, buffer: &[u8], offset: usize) -> usize {
        let chunk = &buffer[..buffer.len().min(offset - self.text)];
        // A lone `\r` ended a line: the byte after it starts one.
        if self.after_cr && chunk.first().is_some_and(|&b| b != b'\n') {
            (self.line, self.column) = (self.line + 1, 0);
        }
        // Where the characters of the line the chunk ends in start.
        let mut start = 0;
        for i in memchr::memchr2_iter(b'\n', b'\r', chunk) {
            // A `\r` at the chunk's end waits for the next byte (`after_cr`).
            let ends_line = chunk[i] == b'\n' || chunk.get(i + 1).is_some_and(|&b| b != b'\n');
            if ends_line {
                (self.line, self.column, start) = (self.line + 1, 0, i + 1);
            }
        }
        // Each byte that is not a UTF-8 continuation byte starts a character.
        self.column += chunk[start..].iter().filter(|&&b| b & 0xC0 != 0x80).count();
        if let Some(&last) = chunk.last() {
            self.after_cr = last == b'\r';
        }
        self.text += chunk.len();
        chunk.len()
    }

    /// Takes in the bytes of `buffer` up to `offset` one by one (a Latin-1 file: a byte from
    /// 0x80 up is two bytes of text); returns how many.
    fn latin1(&mut self, buffer: &[u8], offset: usize) -> usize {
        let mut used = 0;
        for &b in buffer {
            if self.text >= offset {
                break;
            }
            used += 1;
            if self.after_cr && b != b'\n' {
                (self.line, self.column) = (self.line + 1, 0);
            }
            self.after_cr = b == b'\r';
            if b == b'\n' {
                (self.line, self.column) = (self.line + 1, 0);
            } else {
                self.column += 1;
            }
            self.text += if b >= 0x80 { 2 } else { 1 };
        }
        used
    }
}

impl Locate for ClFile {
    fn name(&self) -> &str {
        &self.name
    }

    fn line_col(&self, offset: usize) -> LineCol {
        ClFile::line_col(self, offset)
    }
}

/// The length and modification time of an open file.
fn stamp_of(file: &std::fs::File) -> std::io::Result<(u64, Option<SystemTime>)> {
    let meta = file.metadata()?;
    Ok((meta.len(), meta.modified().ok()))
}

/// The first line start of `text` after `from` (a line start at `from` itself is passed over),
/// or `None` at or past the end.
fn line_start_after(text: &str, from: usize) -> Option<usize> {
    let bytes = text.as_bytes();
    let i = from + memchr::memchr2(b'\n', b'\r', bytes.get(from..)?)?;
    let next = if bytes[i] == b'\r' && bytes.get(i + 1) == Some(&b'\n') { i + 2 } else { i + 1 };
    (next < bytes.len()).then_some(next)
}

/// Where the last whole line of `raw` ends (after its `\n`, `\r\n` or lone `\r`; a `\r` at the
/// very end may be the first half of a `\r\n`), or 0.
fn last_line_end(raw: &[u8]) -> usize {
    let mut end = raw.len();
    while let Some(i) = memchr::memrchr2(b'\n', b'\r', &raw[..end]) {
        if raw[i] == b'\n' || i + 1 < raw.len() {
            return i + 1;
        }
        end = i;
    }
    0
}

/// The bytes from 0x80 up in `data` (each is two bytes of text if the file is Latin-1): summed
/// in byte counters over runs of 255, which the compiler makes vector code of.
fn high_bytes(data: &[u8]) -> u64 {
    data.chunks(255).map(|run| u64::from(run.iter().fold(0u8, |n, &b| n + (b >> 7)))).sum()
}

/// Pre-scans the whole lines of `text` (all of it when `last`), at offset `base` of the text,
/// and drops them from it; false, scanning nothing, if they are not UTF-8.
fn scan_lines(scanner: &mut Prescanner, text: &mut Vec<u8>, base: &mut usize, last: bool) -> bool {
    let whole = if last { text.len() } else { last_line_end(text) };
    let Ok(lines) = std::str::from_utf8(&text[..whole]) else { return false };
    let done = scanner.window(lines, *base, last);
    *base += done;
    text.drain(..done);
    true
}

/// Appends Latin-1 `bytes` to `text` as UTF-8: a byte from 0x80 up is the two bytes of its
/// character (U+0080 to U+00FF), the runs of ASCII are copied as they are.
fn push_latin1(text: &mut Vec<u8>, bytes: &[u8]) {
    text.reserve(bytes.len() + high_bytes(bytes) as usize);
    for run in bytes.chunks(64) {
        if run.is_ascii() {
            text.extend_from_slice(run);
            continue;
        }
        for &b in run {
            if b < 0x80 {
                text.push(b);
            } else {
                text.extend_from_slice(&[0xC0 | (b >> 6), 0x80 | (b & 0x3F)]);
            }
        }
    }
}

/// The line breaks in `text` (`\n`, `\r\n` and a lone `\r` each one).
fn line_breaks(bytes: &[u8]) -> usize {
    let lone_cr = memchr::memchr_iter(b'\r', bytes).filter(|&k| bytes.get(k + 1) != Some(&b'\n')).count();
    memchr::memchr_iter(b'\n', bytes).count() + lone_cr
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn high_bytes_are_counted_across_runs() {
        let data: Vec<u8> = (0..2000u32).map(|k| (k * 37 % 256) as u8).collect();
        for end in [0, 1, 254, 255, 256, 511, 2000] {
            let slice = &data[..end];
            let expected = slice.iter().filter(|&&b| b >= 0x80).count() as u64;
            assert_eq!(high_bytes(slice), expected, "{end} bytes");
        }
        assert_eq!(high_bytes(&[0xFF; 1000]), 1000);
    }

    #[test]
    fn latin1_is_decoded_as_its_characters() {
        let bytes: Vec<u8> = (0..=255u8).cycle().take(700).collect();
        let mut text = b"x".to_vec();
        push_latin1(&mut text, &bytes);
        let expected: String = std::iter::once('x').chain(bytes.iter().map(|&b| char::from(b))).collect();
        assert_eq!(text, expected.into_bytes());
    }

    #[test]
    fn a_line_end_is_never_cut_in_two() {
        assert_eq!(last_line_end(b"ab\ncd"), 3);
        assert_eq!(last_line_end(b"ab\r\ncd\r"), 4);
        assert_eq!(last_line_end(b"ab\rcd"), 3);
        assert_eq!(last_line_end(b"abcd"), 0);
        assert_eq!(line_breaks(b"a\r\nb\rc\nd"), 3);
    }

    /// A file read again for a diagnostic's lines may have gone or changed since the job opened
    /// it: the error says which, not one for the other.
    #[test]
    fn an_excerpt_of_a_file_gone_or_changed_says_which() -> Result<(), Box<dyn std::error::Error>> {
        let dir = std::env::temp_dir().join(format!("postpro-cl-excerpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let text = "GOTO/1,2,3\nGOTO/4,5,6\n";
        let span = Span { start: 11, len: 10 };
        let path = dir.join("gone.cl");
        std::fs::write(&path, text)?;
        let file = ClFile::open(&path)?;
        std::fs::remove_file(&path)?;
        assert!(matches!(file.excerpt(span), Err(Error::Io { .. })), "{:?}", file.excerpt(span).err());
        let path = dir.join("changed.cl");
        std::fs::write(&path, text)?;
        let file = ClFile::open(&path)?;
        std::fs::write(&path, format!("{text}GOTO/7,8,9\n"))?;
        assert!(matches!(file.excerpt(span), Err(Error::Changed { .. })), "{:?}", file.excerpt(span).err());
        std::fs::remove_dir_all(&dir)?;
        Ok(())
    }
}
