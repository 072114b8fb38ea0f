//! Numbers as NC words: fixed decimals, rounded half away from zero, never `-0`, an explicit `+`
//! where the dialect wants one. Integer arithmetic, so it is exact and fast.

/// Writes `value` with `decimals` digits after the point into `out`.
pub fn push_number(out: &mut String, value: f64, decimals: usize, plus: bool) {
    const POWERS: [u64; 10] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000, 100_000_000, 1_000_000_000];
    let decimals = decimals.min(9);
    let divisor = POWERS[decimals];
    let scaled = (value.abs() * divisor as f64).round();
    if !scaled.is_finite() || scaled >= 9.0e15 {
        // Out of the exact range (no machine coordinate is): the standard formatting.
        out.push_str(&format!("{value:.decimals$}"));
        return;
    }
    let units = scaled as u64;
    if units == 0 {
        if plus {
            out.push('+');
        }
    } else if value < 0.0 {
        out.push('-');
    } else if plus {
        out.push('+');
    }
    let mut digits = itoa::Buffer::new();
    out.push_str(digits.format(units / divisor));
    if decimals > 0 {
        out.push('.');
        let frac = digits.format(units % divisor);
        for _ in frac.len()..decimals {
            out.push('0');
        }
        out.push_str(frac);
    }
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
}
