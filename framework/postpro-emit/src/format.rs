//! Numbers as NC words: fixed decimals, rounded half away from zero, never `-0`, an explicit `+`
//! where the dialect wants one. Integer arithmetic, so it is exact and fast.

/// Writes `value` with `decimals` digits after the point into `out` (a `String`, a
/// `CompactString`): one write.
pub fn push_number<W: std::fmt::Write + ?Sized>(out: &mut W, value: f64, decimals: usize, plus: bool) {
    // Writing to a string in memory cannot fail: the result is not looked at.
    with_number(value, decimals, plus, |text| {
        let _ = out.write_str(text);
    });
}

/// `value` as [`push_number`] writes it, lent to `f` from a buffer on the stack.
fn with_number<R>(value: f64, decimals: usize, plus: bool, f: impl FnOnce(&str) -> R) -> R {
    with_rounded(value, decimals, Rounded::of(value, decimals, plus), f)
}

/// [`with_number`] from the number's rounding, `rounded` (`Rounded::of` the same arguments): for
/// a text compared before it is kept.
pub(crate) fn with_rounded<R>(value: f64, decimals: usize, rounded: Option<Rounded>, f: impl FnOnce(&str) -> R) -> R {
    let mut buffer = [0; 32];
    match rounded.and_then(|rounded| written(&mut buffer, rounded)) {
        Some(text) => f(text),
        // Out of the exact range (no machine coordinate is): the standard formatting.
        None => f(&format!("{value:.decimals$}")),
    }
}

/// The digits of 00 to 99, two bytes each.
const PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// A number as a word shows it: rounded half away from zero to `decimals` (at most 9) digits
/// after the point, with the sign it is written with (never `-0`) and whether a `+` is written.
/// Two numbers rounded alike are written alike: a word is known unchanged without its text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rounded {
    /// The value in units of the last decimal, signed as written.
    units: i64,
    decimals: u8,
    plus: bool,
}

impl Rounded {
    /// `value` rounded; `None` out of the exact range of the integer arithmetic (no machine
    /// coordinate is), where the standard formatting writes it.
    pub(crate) fn of(value: f64, decimals: usize, plus: bool) -> Option<Rounded> {
        const POWERS: [f64; 10] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];
        let decimals = decimals.min(9);
        let scaled = value.abs() * POWERS[decimals];
        if scaled.is_nan() || scaled >= 9.0e15 {
            return None;
        }
        // Rounded half away from zero, as `f64::round`, without its library call: below 2⁵³ the
        // truncation and the fraction left are exact.
        let whole = scaled as u64;
        let units = (whole + u64::from(scaled - whole as f64 >= 0.5)) as i64;
        let units = if value < 0.0 { -units } else { units };
        Some(Rounded { units, decimals: decimals as u8, plus })
    }
}

/// The text of `rounded`, built in `buffer` from its right end. The whole of `buffer` is checked
/// as UTF-8, so it holds ASCII on entry ([`with_rounded`]'s zeros): a byte that is not would send
/// the number to the standard formatting, which rounds halves to even.
fn written(buffer: &mut [u8; 32], rounded: Rounded) -> Option<&str> {
    let Rounded { units, decimals, plus } = rounded;
    // At most a sign, 16 digits, the point and 9 decimals, written from the last digit back,
    // two digits at a time: the decimals, then the whole part (at least one digit).
    let mut start = buffer.len();
    let mut put = |bytes: &[u8]| {
        start -= bytes.len();
        buffer[start..start + bytes.len()].copy_from_slice(bytes);
    };
    let pair = |n: u64| &PAIRS[2 * n as usize..2 * n as usize + 2];
    let mut rest = units.unsigned_abs();
    for _ in 0..decimals / 2 {
        put(pair(rest % 100));
        rest /= 100;
    }
    if decimals % 2 == 1 {
        put(&[b'0' + (rest % 10) as u8]);
        rest /= 10;
    }
    if decimals > 0 {
        put(b".");
    }
    while rest >= 100 {
        put(pair(rest % 100));
        rest /= 100;
    }
    put(if rest >= 10 { pair(rest) } else { &pair(rest)[1..] });
    if units < 0 {
        put(b"-");
    } else if plus {
        put(b"+");
    }
    // The whole buffer is checked (ASCII: its NULs too), a word at a time, cheaper than the
    // text's bytes one by one.
    std::str::from_utf8(buffer).ok()?.get(start..)
}

/// `value` rounded to `decimals` digits, without trailing zeros (`6.096`, `10`, `0.5`): for
/// header and comment numbers, never `6.095999999999999`.
pub fn number_trimmed(value: f64, decimals: usize) -> String {
    let mut s = number(value, decimals, false);
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    s
}

/// `value` with `decimals` digits after the point.
pub fn number(value: f64, decimals: usize, plus: bool) -> String {
    let mut s = String::with_capacity(16);
    push_number(&mut s, value, decimals, plus);
    s
}

#[cfg(test)]
mod tests {
    use super::number;

    #[test]
    fn fixed_decimals_without_negative_zero() {
        assert_eq!(number(12.3456, 3, false), "12.346");
        assert_eq!(number(-0.0004, 3, false), "0.000");
        assert_eq!(number(-0.0005, 3, false), "-0.001");
        assert_eq!(number(0.5, 0, false), "1");
        assert_eq!(number(-2.5, 0, false), "-3");
        assert_eq!(number(7.0, 3, true), "+7.000");
        assert_eq!(number(-0.0, 4, true), "+0.0000");
        assert_eq!(number(0.05, 3, false), "0.050");
        assert_eq!(number(1234567.891, 2, false), "1234567.89");
    }

    #[test]
    fn the_longest_texts_and_those_out_of_range_are_whole() {
        // The largest in range: a sign, 16 digits; 9 decimals.
        assert_eq!(number(-8_999_999_999_999_998.0, 0, true), "-8999999999999998");
        assert_eq!(number(-8_999_999.5, 9, true), "-8999999.500000000");
        // Beyond it, the standard formatting.
        assert_eq!(number(1e300, 2, false), format!("{:.2}", 1e300));
        assert_eq!(number(f64::NAN, 3, false), "NaN");
        assert_eq!(number(f64::NEG_INFINITY, 3, false), "-inf");
    }

    /// The units of `value` at `decimals` as `f64::round` gives them (what `fixed` rounds
    /// like, without the call).
    fn rounded_units(value: f64, decimals: usize) -> Option<u64> {
        let scaled = (value.abs() * 10f64.powi(decimals as i32)).round();
        (scaled.is_finite() && scaled < 9.0e15).then_some(scaled as u64)
    }

    proptest::proptest! {
        /// Any value, and the halves between two written values, round as `f64::round` does.
        #[test]
        fn numbers_round_half_away_from_zero(
            units in 0u64..2_000_000_000_000,
            half in proptest::bool::ANY,
            jitter in -1e-3f64..1e-3,
            decimals in 0usize..10,
            negative in proptest::bool::ANY,
        ) {
            let step = 10f64.powi(-(decimals as i32));
            let magnitude = (units as f64 + if half { 0.5 } else { jitter }) * step;
            let value = if negative { -magnitude } else { magnitude };
            let text = number(value, decimals, false);
            let written: u64 = text.trim_start_matches('-').replace('.', "").parse().expect("digits");
            proptest::prop_assert_eq!(Some(written), rounded_units(value, decimals), "{} at {}: {}", value, decimals, text);
        }
    }

    /// Values near each other, at any decimals, with and without `+`: rounded alike exactly
    /// when written alike, so the formatter may tell an unchanged word by its rounding.
    #[test]
    fn numbers_rounded_alike_are_written_alike() {
        use super::Rounded;
        let alike = |a: f64, b: f64, decimals: usize, plus: bool| {
            let rounded = Rounded::of(a, decimals, plus) == Rounded::of(b, decimals, plus);
            let written = number(a, decimals, plus) == number(b, decimals, plus);
            assert_eq!(rounded, written, "{a} and {b} at {decimals} decimals, plus {plus}");
            rounded
        };
        // Zero and the negatives written as zero.
        assert!(alike(-0.0004, 0.0, 3, false));
        assert!(alike(-0.0, 0.0004, 3, true));
        assert!(!alike(-0.0005, 0.0, 3, false));
        assert!(!alike(0.5, -0.5, 0, true));
        proptest::proptest!(|(
            units in -2_000_000_000i64..2_000_000_000,
            offsets in proptest::array::uniform2(-1.5f64..1.5),
            decimals in 0usize..10,
            plus in proptest::bool::ANY,
        )| {
            let step = 10f64.powi(-(decimals as i32));
            let [a, b] = offsets.map(|offset| (units as f64 + offset) * step);
            alike(a, b, decimals, plus);
        });
    }

    #[test]
    fn a_compact_string_gets_the_same_text() {
        for (value, decimals, plus) in [(12.3456, 3, false), (-0.0004, 3, true), (-8_999_999.5, 9, true)] {
            let mut text = compact_str::CompactString::default();
            super::push_number(&mut text, value, decimals, plus);
            assert_eq!(text, number(value, decimals, plus));
        }
    }
}
