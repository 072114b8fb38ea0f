//! Controller dialects: the facts a template cannot decide (file extension, comment syntax, how
//! numbers are written, line length, feed ranges, which output modes exist). The layout of the
//! program is the template's (`templates/<name>.j2`).

/// How the controller takes the tool orientation in TCP mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TcpStyle {
    /// Siemens `TRAORI` with the tool vector in `A3 B3 C3`.
    Traori,
    /// Fanuc `G43.5` with the tool vector in `I J K`.
    G43_5,
    /// Heidenhain `M128` with `LN` blocks and the tool vector in `TX TY TZ`.
    M128,
    /// No tool-centre-point control.
    None,
}

/// A controller dialect.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Dialect {
    /// The name machine definitions use (`siemens-840d`).
    pub name: &'static str,
    /// File extension of the NC program, without the dot.
    pub extension: &'static str,
    /// Comment opening and closing.
    pub comment_open: &'static str,
    /// Comment closing (empty for line comments).
    pub comment_close: &'static str,
    /// Characters a comment must not contain (replaced by a blank).
    pub comment_forbidden: &'static str,
    /// Numbers carry an explicit `+` (Heidenhain).
    pub explicit_plus: bool,
    /// Longest line the controller accepts.
    pub max_line: usize,
    /// Feed range for feeds per minute (mm/min).
    pub feed_range: (f64, f64),
    /// F range in inverse-time mode (1/min); `None` without inverse time.
    pub inverse_time_range: Option<(f64, f64)>,
    /// Siemens `BSPLINE`.
    pub bspline: bool,
    /// Tool-centre-point control.
    pub tcp: TcpStyle,
    /// Decimals of F words.
    pub feed_decimals: usize,
}

/// Every dialect postpro writes.
pub const DIALECTS: &[Dialect] = &[
    Dialect {
        name: "siemens-840d",
        extension: "mpf",
        comment_open: "; ",
        comment_close: "",
        comment_forbidden: "",
        explicit_plus: false,
        max_line: 512,
        feed_range: (0.001, 999_999.999),
        inverse_time_range: Some((0.001, 999_999.999)),
        bspline: true,
        tcp: TcpStyle::Traori,
        feed_decimals: 3,
    },
    Dialect {
        name: "fanuc",
        extension: "nc",
        comment_open: "(",
        comment_close: ")",
        comment_forbidden: "()",
        explicit_plus: false,
        max_line: 256,
        feed_range: (0.001, 99_999.0),
        inverse_time_range: Some((0.001, 99_999.0)),
        bspline: false,
        tcp: TcpStyle::G43_5,
        feed_decimals: 3,
    },
    Dialect {
        name: "heidenhain",
        extension: "h",
        comment_open: "; ",
        comment_close: "",
        comment_forbidden: "",
        explicit_plus: true,
        max_line: 254,
        feed_range: (0.001, 99_999.0),
        inverse_time_range: None,
        bspline: false,
        tcp: TcpStyle::M128,
        feed_decimals: 0,
    },
    Dialect {
        name: "linuxcnc",
        extension: "ngc",
        comment_open: "(",
        comment_close: ")",
        comment_forbidden: "()",
        explicit_plus: false,
        max_line: 255,
        feed_range: (0.001, 99_999.0),
        inverse_time_range: Some((0.001, 99_999.0)),
        bspline: false,
        tcp: TcpStyle::None,
        feed_decimals: 3,
    },
];

/// The dialect of this name.
pub fn dialect(name: &str) -> Option<&'static Dialect> {
    DIALECTS.iter().find(|d| d.name.eq_ignore_ascii_case(name))
}
