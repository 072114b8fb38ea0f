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
const PASSIVE: &[&str] = &[
    "PAINT",
    "MACHIN",
    "MODE",
    "SET",
    "BOX",
    "MOVE_ATTRIB",
    "PPFUN",
    "SYN",
    "SWITCH",
    "REWIND",
    "INTOL",
    "OUTTOL",
    "TOLER",
    "AUTOPS",
    "SETUP",
    "CSI_SET_FLUTE_LENGTH",
    "CSI_SET_EXTENSION_LENGTH",
    "CLPRNT",
    "PRINT",
    "NOPOST",
    "CUT",
    "DNTCUT",
    "ORIGIN",
];

impl Word {
    /// Classifies a major word as written (any case, blanks collapsed).
    pub(crate) fn from_major(raw: &str) -> Word {
        let raw = raw.trim();
        // Fast path for the overwhelmingly common word.
        if raw.len() == 4 && raw.eq_ignore_ascii_case("GOTO") {
            return Word::Goto;
        }
        if raw.contains('=') {
            return Word::AptSource;
        }
        let mut buf = [0u8; 32];
        let Some(key) = normalise(raw, &mut buf) else { return Word::Other };
        if key.contains(',') {
            let last = key.rsplit(',').next().unwrap_or_default();
            return if matches!(last, "GOFWD" | "GOBACK" | "GOLFT" | "GORGT" | "GOUP" | "GODOWN" | "GO") {
                Word::GoMotion
            } else {
                Word::Other
            };
        }
        match key {
            "GOTO" => Word::Goto,
            "FROM" => Word::From,
            "GODLTA" => Word::Godlta,
            "RAPID" => Word::Rapid,
            "FEDRAT" => Word::Fedrat,
            "CIRCLE" => Word::Circle,
            "MOVARC" => Word::Movarc,
            "NURBS" => Word::Nurbs,
            "KNOT" => Word::Knot,
            "CNTRL" => Word::Cntrl,
            "MULTAX" => Word::Multax,
            "TLAXIS" => Word::Tlaxis,
            "INDIRV" => Word::Indirv,
            "LOADTL" => Word::Loadtl,
            "LOAD" => Word::Load,
            "SELECT" => Word::Select,
            "TLDATA" => Word::Tldata,
            "CUTTER" => Word::Cutter,
            "TOOLNO" => Word::Toolno,
            "TURRET" => Word::Turret,
            "SPINDL" => Word::Spindl,
            "COOLNT" => Word::Coolnt,
            "CUTCOM" => Word::Cutcom,
            "CYCLE" => Word::Cycle,
            "DELAY" => Word::Delay,
            "STOP" => Word::Stop,
            "OPSTOP" => Word::Opstop,
            "PPRINT" => Word::Pprint,
            "INSERT" => Word::Insert,
            "TPRINT" => Word::Tprint,
            "PARTNO" => Word::Partno,
            "REMARK" => Word::Remark,
            "OPFEATSTART" => Word::OpFeatStart,
            "OPFEATEND" => Word::OpFeatEnd,
            "MSYS" => Word::Msys,
            "CSYS" => Word::Csys,
            "TRNTYP" => Word::Trntyp,
            "ROTABL" => Word::Rotabl,
            "UNITS" | "UNIT" => Word::Units,
            "TOOL PATH" => Word::ToolPath,
            "END-OF-PATH" => Word::EndOfPath,
            "END" => Word::End,
            "FINI" => Word::Fini,
            "GO" | "GOFWD" | "GOBACK" | "GOLFT" | "GORGT" | "GOUP" | "GODOWN" => Word::GoMotion,
            "PSIS" | "DSIS" | "CSIS" => Word::AptSource,
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
/// `None` when the word is too long or not ASCII (it cannot be a known word then).
fn normalise<'b>(raw: &str, buf: &'b mut [u8; 32]) -> Option<&'b str> {
    let mut n: usize = 0;
    let mut pending_blank = false;
    for &c in raw.as_bytes() {
        if c == b' ' || c == b'\t' {
            pending_blank = n > 0;
            continue;
        }
        if !c.is_ascii() {
            return None;
        }
        if pending_blank && c != b',' && buf.get(n.wrapping_sub(1)) != Some(&b',') {
            *buf.get_mut(n)? = b' ';
            n += 1;
        }
        pending_blank = false;
        *buf.get_mut(n)? = c.to_ascii_uppercase();
        n += 1;
    }
    std::str::from_utf8(&buf[..n]).ok()
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
    }

    #[test]
    fn canonical_spelling() {
        assert_eq!(canonical("tool   path"), "TOOL PATH");
        assert_eq!(canonical("tlon, gofwd"), "TLON,GOFWD");
    }
}
