//! Plain decimals read fast and exactly: a recording's volts, parsed to
//! the bits `str::parse::<f64>` gives, by one division where that is
//! exact (Clinger's fast path) and by std otherwise.

/// `text` as `f64`, exactly as `str::parse::<f64>` reads it (`None` where
/// it fails). A plain decimal (an optional sign, at most 15 significant
/// digits, at most 22 after the point, no exponent: how recordings write
/// volts) is one correctly rounded division `m / 10^k` of two values exact
/// in `f64` (Clinger's fast path); anything else goes to std.
pub fn parse_volts(text: &str) -> Option<f64> {
    fast_decimal(text.as_bytes()).or_else(|| text.parse().ok())
}

/// 10^0 … 10^22: exact in `f64`.
const POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

pub(super) fn fast_decimal(bytes: &[u8]) -> Option<f64> {
    decimal_prefix(bytes)
        .filter(|&(_, used)| used == bytes.len())
        .map(|(value, _)| value)
}

/// The plain decimal `bytes` start with, as [`fast_decimal`] reads one,
/// and the bytes it takes: it stops at the first byte that is neither a
/// digit nor the first point (`None` for a decimal with no digit, or with
/// more significant digits than the fast path takes).
pub(super) fn decimal_prefix(bytes: &[u8]) -> Option<(f64, usize)> {
    let (negative, sign) = match bytes.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let (whole_end, mantissa) = append_digits(bytes, sign, 0);
    let (end, mantissa, scale) = if bytes.get(whole_end) == Some(&b'.') {
        let (end, mantissa) = append_digits(bytes, whole_end + 1, mantissa);
        (end, mantissa, end - whole_end - 1)
    } else {
        (whole_end, mantissa, 0)
    };
    let digits = whole_end - sign + scale;
    if digits == 0 {
        return None;
    }
    // The significant digits: from the first one that is not a zero. At
    // most 15, the mantissa never wrapped.
    let mut leading_zeros = 0;
    for &b in bytes.get(sign..end).unwrap_or_default() {
        match b {
            b'0' => leading_zeros += 1,
            b'.' => {}
            _ => break,
        }
    }
    if digits - leading_zeros > 15 {
        return None;
    }
    let power = *POWERS_OF_TEN.get(scale)?;
    let value = mantissa as f64 / power;
    Some((if negative { -value } else { value }, end))
}

/// The digits of `bytes` from `at` on, appended to `mantissa` (wrapping
/// past 19 digits: [`decimal_prefix`] refuses more than 15 significant
/// ones): where they end, and the mantissa.
fn append_digits(bytes: &[u8], mut at: usize, mut mantissa: u64) -> (usize, u64) {
    while let Some(&b) = bytes.get(at) {
        let digit = b.wrapping_sub(b'0');
        if digit > 9 {
            break;
        }
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(digit));
        at += 1;
    }
    (at, mantissa)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fast_path_reads_what_std_reads() {
        for text in [
            "2.5",
            "0",
            "-0",
            "-0.0",
            "+1.25",
            "4.999999999999999",
            "0.000000000000000000001",
            "123456789012345",
            "1.",
            ".5",
            "007.50",
            "0.1",
            "2.4999",
            "3.3000000000000003",
        ] {
            let std: f64 = text.parse().unwrap();
            assert_eq!(
                parse_volts(text).map(f64::to_bits),
                Some(std.to_bits()),
                "{text}"
            );
        }
        for text in ["", ".", "+", "-", "1..2", "1e3x", "abc", "--1", "1,5"] {
            assert_eq!(
                parse_volts(text).map(f64::to_bits),
                text.parse::<f64>().ok().map(f64::to_bits),
                "{text}"
            );
        }
        // Exponents, NaN and the rest go to std.
        assert_eq!(parse_volts("2.5e-1"), Some(0.25));
        assert!(parse_volts("NaN").unwrap().is_nan());
        assert_eq!(parse_volts("inf"), Some(f64::INFINITY));
    }

    /// A decimal from a property test's parts: sign, integer digits and,
    /// if any, the digits after a point.
    fn decimal_text(sign: &str, int: &str, frac: Option<&str>) -> String {
        match frac {
            Some(frac) => format!("{sign}{int}.{frac}"),
            None => format!("{sign}{int}"),
        }
    }

    proptest::proptest! {
        /// Any decimal a recording may hold, and any float printed
        /// shortest or to fixed places: the same bits as std.
        #[test]
        fn any_decimal_parses_to_std_s_bits(
            sign in proptest::sample::select(vec!["", "-", "+"]),
            int in "[0-9]{0,12}",
            frac in proptest::option::of("[0-9]{0,16}"),
            value in proptest::num::f64::ANY,
            places in 0usize..20,
        ) {
            let text = decimal_text(sign, &int, frac.as_deref());
            proptest::prop_assert_eq!(
                parse_volts(&text).map(f64::to_bits),
                text.parse::<f64>().ok().map(f64::to_bits),
                "{}", text
            );
            for text in [format!("{value}"), format!("{value:.places$}")] {
                proptest::prop_assert_eq!(
                    parse_volts(&text).map(f64::to_bits),
                    text.parse::<f64>().ok().map(f64::to_bits),
                    "{}", text
                );
            }
        }
    }

    proptest::proptest! {
        /// The decimal a line's value starts with, read up to the byte
        /// after it: what the whole field would read to, and where it
        /// stops.
        #[test]
        fn a_decimal_prefix_reads_as_the_whole_decimal(
            sign in proptest::sample::select(vec!["", "-", "+"]),
            int in "[0-9]{0,17}",
            frac in proptest::option::of("[0-9]{0,17}"),
            tail in proptest::sample::select(vec!["", "\n", "\n9", ",", "e", " ", "\r", "-", "+", "\"", "x"]),
        ) {
            let text = decimal_text(sign, &int, frac.as_deref());
            let whole = fast_decimal(text.as_bytes()).map(|v| (v.to_bits(), text.len()));
            let prefix = decimal_prefix(format!("{text}{tail}").as_bytes())
                .map(|(v, used)| (v.to_bits(), used));
            proptest::prop_assert_eq!(prefix, whole, "{:?}", text);
        }
    }
}
