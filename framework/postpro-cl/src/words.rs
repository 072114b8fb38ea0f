//! The vocabulary: major words the reader knows, compared case-insensitively, and the role
//! of each (interpreted, free text, passed through without effect).

/// A classified major word.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Word {
    Goto,
    From,
    Godlta,
    Rapid,
    Fedrat,
    Circle,
    Movarc,
    Nurbs,
    Knot,
    Cntrl,
    Multax,
    Tlaxis,
    Indirv,
    /// `TLON,GOFWD/…` and the other APT-source motion words with modifiers.
    GoMotion,
    Loadtl,
    Load,
    Select,
    Tldata,
    Cutter,
    Toolno,
    /// `TURRET/n,OSETNO,h,…`: a lathe turret index, i.e. a tool change of a turning program
    /// (an error: `cl::turning`).
    Turret,
    Spindl,
    Coolnt,
    Cutcom,
    Cycle,
    Delay,
    Stop,
    Opstop,
    Pprint,
    Insert,
    Tprint,
    Partno,
    Remark,
    OpFeatStart,
    OpFeatEnd,
    Msys,
    Csys,
    Trntyp,
    Rotabl,
    Units,
    ToolPath,
    EndOfPath,
    End,
    Fini,
    /// Known words without an effect on the tool path (display, bookkeeping, tolerances).
    Passive,
    /// APT source language: an assignment (`pl1=plane/…`) or a part-surface word (`PSIS`).
    AptSource,
    /// Anything else: carried as a record and reported.
    Other,
}

/// Known words that carry no motion or machine state: kept as records, not reported as unknown.
const PASSIVE: &[&[u8]] = &[
    b"PAINT",
    b"MACHIN",
    b"MODE",
    b"SET",
    b"BOX",
    b"MOVE_ATTRIB",
    b"PPFUN",
    b"SYN",
    b"SWITCH",
    b"REWIND",
    b"INTOL",
    b"OUTTOL",
    b"TOLER",
    b"AUTOPS",
    b"SETUP",
    b"CSI_SET_FLUTE_LENGTH",
    b"CSI_SET_EXTENSION_LENGTH",
    b"CLPRNT",
    b"PRINT",
    b"NOPOST",
    b"CUT",
    b"DNTCUT",
    b"ORIGIN",
];

impl Word {
    /// Classifies a major word as written (any case, blanks collapsed).
    pub(crate) fn from_major(raw: &str) -> Word {
        let raw = raw.trim();
        // Fast path for the overwhelmingly common word.
        if raw.len() == 4 && raw.eq_ignore_ascii_case("GOTO") {
            return Word::Goto;
        }
        // Most words are written as they are spelt: upper case, no blank, no comma.
        if raw.bytes().all(|c| c.is_ascii_uppercase() || c == b'_' || c == b'-') {
            return Word::from_spelling(raw.as_bytes());
        }
        let mut buf = [0u8; 32];
        let key = match normalise(raw, &mut buf) {
            Ok(key) => key,
            Err(word) => return word,
        };
        if key.contains(&b',') {
            let last = key.rsplit(|&c| c == b',').next().unwrap_or_default();
            return if matches!(last, b"GOFWD" | b"GOBACK" | b"GOLFT" | b"GORGT" | b"GOUP" | b"GODOWN" | b"GO") {
                Word::GoMotion
            } else {
                Word::Other
            };
        }
        Word::from_spelling(key)
    }

    /// Classifies a major word spelt as the vocabulary spells it (upper case, blanks collapsed).
    fn from_spelling(key: &[u8]) -> Word {
        match key {
            b"GOTO" => Word::Goto,
            b"FROM" => Word::From,
            b"GODLTA" => Word::Godlta,
            b"RAPID" => Word::Rapid,
            b"FEDRAT" => Word::Fedrat,
            b"CIRCLE" => Word::Circle,
            b"MOVARC" => Word::Movarc,
            b"NURBS" => Word::Nurbs,
            b"KNOT" => Word::Knot,
            b"CNTRL" => Word::Cntrl,
            b"MULTAX" => Word::Multax,
            b"TLAXIS" => Word::Tlaxis,
            b"INDIRV" => Word::Indirv,
            b"LOADTL" => Word::Loadtl,
            b"LOAD" => Word::Load,
            b"SELECT" => Word::Select,
            b"TLDATA" => Word::Tldata,
            b"CUTTER" => Word::Cutter,
            b"TOOLNO" => Word::Toolno,
            b"TURRET" => Word::Turret,
            b"SPINDL" => Word::Spindl,
            b"COOLNT" => Word::Coolnt,
            b"CUTCOM" => Word::Cutcom,
            b"CYCLE" => Word::Cycle,
            b"DELAY" => Word::Delay,
            b"STOP" => Word::Stop,
            b"OPSTOP" => Word::Opstop,
            b"PPRINT" => Word::Pprint,
            b"INSERT" => Word::Insert,
            b"TPRINT" => Word::Tprint,
            b"PARTNO" => Word::Partno,
            b"REMARK" => Word::Remark,
            b"OPFEATSTART" => Word::OpFeatStart,
            b"OPFEATEND" => Word::OpFeatEnd,
            b"MSYS" => Word::Msys,
            b"CSYS" => Word::Csys,
            b"TRNTYP" => Word::Trntyp,
            b"ROTABL" => Word::Rotabl,
            b"UNITS" | b"UNIT" => Word::Units,
            b"TOOL PATH" => Word::ToolPath,
            b"END-OF-PATH" => Word::EndOfPath,
            b"END" => Word::End,
            b"FINI" => Word::Fini,
            b"GO" | b"GOFWD" | b"GOBACK" | b"GOLFT" | b"GORGT" | b"GOUP" | b"GODOWN" => Word::GoMotion,
            b"PSIS" | b"DSIS" | b"CSIS" => Word::AptSource,
            k if PASSIVE.contains(&k) => Word::Passive,
            _ => Word::Other,
        }
    }

    /// Words whose arguments the reader turns into the tool path (not carried as records).
    pub(crate) fn is_interpreted(self) -> bool {
        !matches!(self, Word::Passive | Word::AptSource | Word::Other) && !self.is_text()
    }

    /// Words whose argument is free text, never split on commas.
    pub(crate) fn is_text(self) -> bool {
        matches!(
            self,
            Word::Pprint
                | Word::Insert
                | Word::Tprint
                | Word::Partno
                | Word::Remark
                | Word::OpFeatStart
                | Word::OpFeatEnd
                | Word::Stop
                | Word::Opstop
        )
    }
}

/// Upper-cases a word into `buf`, collapsing runs of blanks and dropping blanks around commas.
/// Else its class: APT source where it has an `=` (an assignment), `Other` when it is too long
/// or not ASCII (it cannot be a known word then).
fn normalise<'b>(raw: &str, buf: &'b mut [u8; 32]) -> Result<&'b [u8], Word> {
    let mut n: usize = 0;
    let mut pending_blank = false;
    let bytes = raw.as_bytes();
    for (i, &c) in bytes.iter().enumerate() {
        if c == b' ' || c == b'\t' {
            pending_blank = n > 0;
            continue;
        }
        // Not a known word: an assignment still, wherever its `=`.
        let unknown = || if bytes[i..].contains(&b'=') { Word::AptSource } else { Word::Other };
        if c == b'=' {
            return Err(Word::AptSource);
        }
        if !c.is_ascii() {
            return Err(unknown());
        }
        if pending_blank && c != b',' && buf.get(n.wrapping_sub(1)) != Some(&b',') {
            *buf.get_mut(n).ok_or_else(unknown)? = b' ';
            n += 1;
        }
        pending_blank = false;
        *buf.get_mut(n).ok_or_else(unknown)? = c.to_ascii_uppercase();
        n += 1;
    }
    Ok(&buf[..n])
}

/// The canonical spelling of a major word for reports: upper case, blanks collapsed.
pub(crate) fn canonical(raw: &str) -> String {
    let mut out = String::with_capacity(raw.len());
    for part in raw.split_whitespace() {
        if !out.is_empty() && !out.ends_with(',') && !part.starts_with(',') {
            out.push(' ');
        }
        if part.is_ascii() {
            out.extend(part.bytes().map(|b| char::from(b.to_ascii_uppercase())));
        } else {
            out.push_str(&part.to_uppercase());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classification_ignores_case_and_blanks() {
        assert_eq!(Word::from_major("goto"), Word::Goto);
        assert_eq!(Word::from_major("TOOL  PATH"), Word::ToolPath);
        assert_eq!(Word::from_major("Unit"), Word::Units);
        assert_eq!(Word::from_major("tlon, gofwd"), Word::GoMotion);
        assert_eq!(Word::from_major("pl1=plane"), Word::AptSource);
        assert_eq!(Word::from_major("PAINT"), Word::Passive);
        assert_eq!(Word::from_major("SPINDLE"), Word::Other);
        assert_eq!(Word::from_major("A_VERY_LONG_VENDOR_WORD_THAT_DOES_NOT_FIT"), Word::Other);
        // An assignment, wherever its `=`: after a word too long or not ASCII too.
        assert_eq!(Word::from_major("PL1 = PLANE"), Word::AptSource);
        assert_eq!(Word::from_major("A_VERY_LONG_VENDOR_WORD_THAT_DOES_NOT_FIT=PLANE"), Word::AptSource);
        assert_eq!(Word::from_major("ÉBAUCHE=PLANE"), Word::AptSource);
        assert_eq!(Word::from_major("ÉBAUCHE"), Word::Other);
    }

    /// A word spelt as the vocabulary spells it (the fast path) is classified as the same word
    /// written in lower case with blanks around it.
    #[test]
    fn spelt_and_written_otherwise_alike() {
        let spellings = ["GOTO", "CIRCLE", "END-OF-PATH", "OPFEATSTART", "UNIT", "GOFWD", "PSIS", "SPINDLE", "GOT"];
        for spelling in spellings.iter().copied().chain(PASSIVE.iter().map(|p| std::str::from_utf8(p).expect("ASCII")))
        {
            let written = format!(" {}\t", spelling.to_ascii_lowercase());
            assert_eq!(Word::from_major(spelling), Word::from_major(&written), "{spelling}");
        }
        assert_eq!(Word::from_major("CIRCLE"), Word::Circle);
        assert_eq!(Word::from_major("CSI_SET_EXTENSION_LENGTH"), Word::Passive);
    }

    #[test]
    fn canonical_spelling() {
        assert_eq!(canonical("tool   path"), "TOOL PATH");
        assert_eq!(canonical("tlon, gofwd"), "TLON,GOFWD");
    }
}
