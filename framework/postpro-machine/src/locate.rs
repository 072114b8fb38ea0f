//! Where a value sits in the YAML text, for the errors found after deserialization.
//!
//! The YAML library attaches a location to the errors raised *while* deserializing, not to the
//! values it returns. To point at a value afterwards, [`locate`] deserializes the text once more
//! with a probe that walks down a path (`axes`, `2`, `direction`) and fails on purpose at the
//! node it reaches: the library attaches that node's location to the failure, which is exactly
//! the value's start. The length of the span is measured in the text: a quoted scalar up to its
//! closing quote, a flow collection (`[…]`, `{…}`) up to its matching bracket, a plain scalar up
//! to the next `,` `]` `}` (inside brackets), `: `, ` #` or the end of the line. This runs only
//! when there is an error to show. A path that does not exist (a key left out) falls back to
//! its parent, so the caret sits on the enclosing mapping.

use std::fmt;

use serde::de::{self, DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};

/// One step of a path into the document.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Seg<'a> {
    /// A mapping key.
    Key(&'a str),
    /// A sequence index.
    Index(usize),
}

impl From<usize> for Seg<'_> {
    fn from(i: usize) -> Self {
        Seg::Index(i)
    }
}

impl<'a> From<&'a str> for Seg<'a> {
    fn from(k: &'a str) -> Self {
        Seg::Key(k)
    }
}

/// A path into the document: `path!["axes", i, "vmax"]` (visible in the modules declared after
/// this one, by `#[macro_use]`).
macro_rules! path {
    ($($seg:expr),* $(,)?) => { &[$(crate::locate::Seg::from($seg)),*][..] };
}

/// `axes[3].vmax`, as the YAML library writes paths.
pub(crate) fn path_text(path: &[Seg<'_>]) -> String {
    let mut out = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) if out.is_empty() => out.push_str(k),
            Seg::Key(k) => {
                out.push('.');
                out.push_str(k);
            }
            Seg::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// A byte range in the text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Span {
    pub(crate) offset: usize,
    pub(crate) len: usize,
}

/// The message of the probe's deliberate failure.
const FOUND: &str = "\u{0}found";

/// The span of the node at `path`, or of its nearest existing ancestor; the whole first line
/// when the text does not parse at all.
pub(crate) fn locate(text: &str, path: &[Seg<'_>]) -> Span {
    for depth in (0..=path.len()).rev() {
        if let Some(span) = probe(text, &path[..depth]) {
            return span;
        }
    }
    span_at(text, 0)
}

/// The span of the node at `path`, if it exists.
fn probe(text: &str, path: &[Seg<'_>]) -> Option<Span> {
    let seed = Probe { path };
    match seed.deserialize(serde_yaml::Deserializer::from_str(text)) {
        Ok(()) => None,
        Err(e) => {
            let message = e.to_string();
            if !message.contains(FOUND) {
                return None;
            }
            let offset = e.location()?.index().min(text.len());
            // `deserialize_str` on a collection fails with `invalid type: map` (or `sequence`).
            let collection = message.contains("invalid type: map") || message.contains("invalid type: sequence");
            Some(if collection { collection_span(text, offset) } else { span_at(text, offset) })
        }
    }
}

/// The span of a collection that starts at `offset`: a flow collection up to its matching
/// bracket, a block one (which starts at its first key or dash) on its first line.
pub(crate) fn collection_span(text: &str, offset: usize) -> Span {
    let span = span_at(text, offset);
    if text[span.offset..].starts_with(['[', '{']) {
        return span;
    }
    let rest = &text[span.offset..];
    let line = &rest[..line_len(rest)];
    let end = line.find(" #").unwrap_or(line.len());
    Span { offset: span.offset, len: line[..end].trim_end().len() }
}

/// The span of the second `key:` at or after `from`, for a key given twice in a mapping.
pub(crate) fn second_key(text: &str, from: usize, key: &str) -> Option<Span> {
    let mut found = 0;
    let mut at = from.min(text.len());
    while let Some(i) = text.get(at..)?.find(key) {
        let start = at + i;
        let end = start + key.len();
        let before_ok = text[..start].chars().next_back().is_none_or(|c| c.is_whitespace() || c == '{' || c == ',');
        let after_ok = text[end..].trim_start_matches([' ', '\t']).starts_with(':');
        if before_ok && after_ok {
            found += 1;
            if found == 2 {
                return Some(Span { offset: start, len: key.len() });
            }
        }
        at = end;
    }
    None
}

/// The byte offset of a 1-based line and character column.
pub(crate) fn offset_of(text: &str, line: usize, column: usize) -> Option<usize> {
    let mut start = 0;
    for _ in 1..line {
        start += text.get(start..)?.find('\n')? + 1;
    }
    let rest = &text[start..];
    let len = rest.char_indices().nth(column.saturating_sub(1)).map_or(rest.len(), |(i, _)| i);
    Some(start + len)
}

/// The span that starts at `offset`: the token or collection there.
pub(crate) fn span_at(text: &str, offset: usize) -> Span {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let rest = &text[offset..];
    let len = match rest.chars().next() {
        Some(q @ ('"' | '\'')) => quoted_len(rest, q),
        Some('[' | '{') => bracket_len(rest),
        Some(_) => plain_len(rest, in_flow(text, offset)),
        None => 0,
    };
    Span { offset, len }
}

/// The length of a quoted scalar, quotes included.
fn quoted_len(rest: &str, quote: char) -> usize {
    let mut chars = rest.char_indices().skip(1).peekable();
    while let Some((i, c)) = chars.next() {
        if quote == '"' && c == '\\' {
            chars.next();
        } else if c == quote {
            if quote == '\'' && chars.peek().is_some_and(|&(_, n)| n == '\'') {
                chars.next();
            } else {
                return i + c.len_utf8();
            }
        }
    }
    line_len(rest)
}

/// The length of a flow collection up to its matching bracket.
fn bracket_len(rest: &str) -> usize {
    let mut depth = 0usize;
    let mut i = 0;
    while i < rest.len() {
        let c = rest[i..].chars().next().unwrap_or(' ');
        match c {
            '[' | '{' => depth += 1,
            ']' | '}' => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    return i + 1;
                }
            }
            '"' | '\'' => {
                i += quoted_len(&rest[i..], c);
                continue;
            }
            '#' if i > 0 && rest[..i].ends_with([' ', '\t']) => {
                // A comment: skip to the end of the line.
                i += line_len(&rest[i..]);
                continue;
            }
            _ => {}
        }
        i += c.len_utf8();
    }
    line_len(rest)
}

/// The length of a plain scalar.
fn plain_len(rest: &str, flow: bool) -> usize {
    let line = &rest[..line_len(rest)];
    let mut end = line.len();
    for (i, c) in line.char_indices() {
        let next = line[i + c.len_utf8()..].chars().next();
        let stop = match c {
            ',' | ']' | '}' => flow,
            ':' => next.is_none_or(|n| n.is_whitespace() || (flow && matches!(n, ',' | ']' | '}'))),
            '#' => i > 0 && line[..i].ends_with([' ', '\t']),
            _ => false,
        };
        if stop {
            end = i;
            break;
        }
    }
    line[..end].trim_end().len()
}

/// The length of the line up to its end (without the line break).
fn line_len(rest: &str) -> usize {
    rest.find(['\n', '\r']).unwrap_or(rest.len())
}

/// True when `offset` is inside a flow collection opened on the same line.
fn in_flow(text: &str, offset: usize) -> bool {
    let start = text[..offset].rfind(['\n', '\r']).map_or(0, |i| i + 1);
    let mut depth = 0i32;
    let before = &text[start..offset];
    let mut i = 0;
    while i < before.len() {
        let c = before[i..].chars().next().unwrap_or(' ');
        match c {
            '[' | '{' => depth += 1,
            ']' | '}' => depth -= 1,
            '"' | '\'' => {
                i += quoted_len(&before[i..], c);
                continue;
            }
            _ => {}
        }
        i += c.len_utf8();
    }
    depth > 0
}

/// Walks down `path`; fails with [`FOUND`] at its end.
struct Probe<'p> {
    path: &'p [Seg<'p>],
}

impl<'de> DeserializeSeed<'de> for Probe<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        match self.path.first() {
            // `deserialize_str` fails for every node: for a scalar in the visitor, for a collection
            // with a type error. Either way the library attaches the node's start.
            None => deserializer.deserialize_str(Found),
            Some(_) => deserializer.deserialize_any(self),
        }
    }
}

impl<'de> Visitor<'de> for Probe<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("any YAML")
    }

    fn visit_bool<E: de::Error>(self, _: bool) -> Result<(), E> {
        Ok(())
    }
    fn visit_i64<E: de::Error>(self, _: i64) -> Result<(), E> {
        Ok(())
    }
    fn visit_u64<E: de::Error>(self, _: u64) -> Result<(), E> {
        Ok(())
    }
    fn visit_f64<E: de::Error>(self, _: f64) -> Result<(), E> {
        Ok(())
    }
    fn visit_str<E: de::Error>(self, _: &str) -> Result<(), E> {
        Ok(())
    }
    fn visit_unit<E: de::Error>(self) -> Result<(), E> {
        Ok(())
    }
    fn visit_none<E: de::Error>(self) -> Result<(), E> {
        Ok(())
    }
    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let (Some(Seg::Index(want)), rest) = (self.path.first(), &self.path[1..]) else {
            while seq.next_element::<IgnoredAny>()?.is_some() {}
            return Ok(());
        };
        let mut i = 0;
        loop {
            let more = if i == *want {
                seq.next_element_seed(Probe { path: rest })?.is_some()
            } else {
                seq.next_element::<IgnoredAny>()?.is_some()
            };
            if !more {
                return Ok(());
            }
            i += 1;
        }
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let (Some(Seg::Key(want)), rest) = (self.path.first(), &self.path[1..]) else {
            while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
            return Ok(());
        };
        while let Some(key) = map.next_key::<Key>()? {
            if key.0.as_deref() == Some(*want) {
                map.next_value_seed(Probe { path: rest })?;
            } else {
                map.next_value::<IgnoredAny>()?;
            }
        }
        Ok(())
    }
}

/// Fails for any node.
struct Found;

impl Visitor<'_> for Found {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(FOUND)
    }
    fn visit_str<E: de::Error>(self, _: &str) -> Result<(), E> {
        Err(E::custom(FOUND))
    }
}

/// A mapping key, if it is a string.
struct Key(Option<String>);

impl<'de> de::Deserialize<'de> for Key {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct KeyVisitor;
        impl<'de> Visitor<'de> for KeyVisitor {
            type Value = Key;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a key")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Key, E> {
                Ok(Key(Some(v.to_string())))
            }
            fn visit_bool<E: de::Error>(self, _: bool) -> Result<Key, E> {
                Ok(Key(None))
            }
            fn visit_i64<E: de::Error>(self, _: i64) -> Result<Key, E> {
                Ok(Key(None))
            }
            fn visit_u64<E: de::Error>(self, _: u64) -> Result<Key, E> {
                Ok(Key(None))
            }
            fn visit_f64<E: de::Error>(self, _: f64) -> Result<Key, E> {
                Ok(Key(None))
            }
            fn visit_unit<E: de::Error>(self) -> Result<Key, E> {
                Ok(Key(None))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Key, A::Error> {
                while seq.next_element::<IgnoredAny>()?.is_some() {}
                Ok(Key(None))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Key, A::Error> {
                while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
                Ok(Key(None))
            }
        }
        deserializer.deserialize_any(KeyVisitor)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    const TEXT: &str = concat!(
        "# a comment with ° in it\n",
        "name: demo   # the name\n",
        "axes:\n",
        "  - { letter: X, direction: [1, 0, 0], travel: [-600 mm, 600 mm] }\n",
        "  - letter: 'B'   # block style\n",
        "    direction: [0, -1, 0]\n",
        "chain: {linear: [X], part: [B]}\n",
    );

    fn at<'a>(path: &[Seg<'_>]) -> &'a str {
        let s = locate(TEXT, path);
        &TEXT[s.offset..s.offset + s.len]
    }

    #[test]
    fn finds_values() {
        assert_eq!(at(&["name".into()]), "demo");
        assert_eq!(at(&["axes".into(), 0.into(), "letter".into()]), "X");
        assert_eq!(at(&["axes".into(), 0.into(), "direction".into()]), "[1, 0, 0]");
        assert_eq!(at(&["axes".into(), 0.into(), "travel".into(), 1.into()]), "600 mm");
        assert_eq!(at(&["axes".into(), 0.into()]), "{ letter: X, direction: [1, 0, 0], travel: [-600 mm, 600 mm] }");
        assert_eq!(at(&["axes".into(), 1.into(), "letter".into()]), "'B'");
        assert_eq!(at(&["axes".into(), 1.into(), "direction".into(), 1.into()]), "-1");
        assert_eq!(at(&["chain".into(), "part".into(), 0.into()]), "B");
    }

    #[test]
    fn falls_back_to_the_parent() {
        assert_eq!(at(&["axes".into(), 1.into(), "center".into()]), "letter: 'B'");
        assert_eq!(at(&["chain".into(), "tool".into(), 0.into()]), "{linear: [X], part: [B]}");
    }

    #[test]
    fn keys_and_offsets() {
        let text = "a:\n  k: 1\n  j: 2\n  k: 3\n";
        assert_eq!(second_key(text, 0, "k"), Some(Span { offset: 19, len: 1 }));
        assert_eq!(second_key(text, 0, "j"), None);
        assert_eq!(offset_of("ab\n°cd", 2, 2), Some(5));
        assert_eq!(offset_of("ab", 3, 1), None);
    }

    #[test]
    fn spans_handle_multibyte_text() {
        let s = span_at("a: \"x ° y\" # c\n", 3);
        assert_eq!(s, Span { offset: 3, len: "\"x ° y\"".len() });
        assert_eq!(span_at("key: value # c", 5), Span { offset: 5, len: 5 });
        assert_eq!(span_at("[a, b]", 1), Span { offset: 1, len: 1 });
    }
}
