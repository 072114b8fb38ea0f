//! Numbers as NC words: fixed decimals, rounded half away from zero, never `-0`, an explicit `+`
//! where the dialect wants one. Integer arithmetic, so it is exact and fast.

/// Writes `value` with `decimals` digits after the point into `out`.
pub fn push_number(out: &mut String, value: f64, decimals: usize, plus: bool) {
    let decimals = decimals.min(9);
    let scale = 10u64.pow(decimals as u32) as f64;
    let scaled = (value.abs() * scale).round();
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
    let divisor = 10u64.pow(decimals as u32);
    push_u64(out, units / divisor);
    if decimals > 0 {
        out.push('.');
        let frac = units % divisor;
        let digits = frac.checked_ilog10().map_or(1, |d| d as usize + 1);
        for _ in digits..decimals {
            out.push('0');
        }
        push_u64(out, frac);
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

fn push_u64(out: &mut String, mut v: u64) {
    let mut buf = [0u8; 20];
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    // The buffer holds ASCII digits only.
    out.push_str(std::str::from_utf8(&buf[i..]).unwrap_or("0"));
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
