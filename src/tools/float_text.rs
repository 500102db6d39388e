//! `f64`s written exactly as `format!("{}", x)` writes them (the shortest
//! digits that read back as `x`, never an exponent; `-0`, `NaN`, `inf`),
//! for the `--trace` files: 16 numbers a row, 1000 rows a second of
//! recording. Where `ryu` is known to give std's digits, it finds them
//! (faster) and they are laid out as std lays them out; the rest std
//! writes. The tests hold std's own formatting as the oracle.

/// Appends `x` to `out` as `format!("{x}")` would.
pub fn push_f64(out: &mut Vec<u8>, x: f64) {
    if !x.is_finite() {
        out.extend_from_slice(if x.is_nan() {
            b"NaN"
        } else if x > 0.0 {
            b"inf"
        } else {
            b"-inf"
        });
        return;
    }
    if x == 0.0 {
        out.extend_from_slice(if x.is_sign_negative() { b"-0" } else { b"0" });
        return;
    }
    if !past_ties(x) {
        use std::io::Write;
        // Writing to a Vec cannot fail.
        let _ = write!(out, "{x}");
        return;
    }
    let mut buffer = ryu::Buffer::new();
    let text = buffer.format_finite(x).as_bytes();
    if !text.contains(&b'e') {
        // Without an exponent ryu lays digits out as std does, but for
        // the `.0` it gives a whole number.
        out.extend_from_slice(text.strip_suffix(b".0").unwrap_or(text));
        return;
    }
    let (negative, text) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    // ryu writes `D.DDDeN`, `D.DDD` or `0.000DDD`: its digits (leading
    // zeros dropped) and the power of ten of the first one.
    let (mantissa, exponent) = match text.iter().position(|&b| b == b'e') {
        Some(at) => (&text[..at], parse_exponent(&text[at + 1..])),
        None => (text, 0),
    };
    let mut digits = [0u8; 24];
    let mut count = 0;
    let mut point = None;
    let mut leading = true;
    let mut leading_zeros_after_point = 0i32;
    for &b in mantissa {
        match b {
            b'.' => point = Some(count),
            b'0' if leading => {
                if point.is_some() {
                    leading_zeros_after_point += 1;
                }
            }
            _ => {
                leading = false;
                if count < digits.len() {
                    digits[count] = b;
                    count += 1;
                }
            }
        }
    }
    // Trailing zeros are no digits of the value (ryu writes `1.0`).
    while count > 1 && digits[count - 1] == b'0' {
        count -= 1;
    }
    // The position of the decimal point after the first digit's place:
    // value = 0.d1d2d3… × 10^point_at.
    let integer_digits = match point {
        Some(p) if p > 0 => p as i32,
        Some(_) => -leading_zeros_after_point,
        None => count as i32,
    };
    let point_at = integer_digits + exponent;
    let digits = &digits[..count];
    if negative {
        out.push(b'-');
    }
    if point_at <= 0 {
        out.extend_from_slice(b"0.");
        out.extend(std::iter::repeat_n(b'0', (-point_at) as usize));
        out.extend_from_slice(digits);
    } else if point_at as usize >= digits.len() {
        out.extend_from_slice(digits);
        out.extend(std::iter::repeat_n(b'0', point_at as usize - digits.len()));
    } else {
        let (integer, fraction) = digits.split_at(point_at as usize);
        out.extend_from_slice(integer);
        out.push(b'.');
        out.extend_from_slice(fraction);
    }
}

/// Whether `ryu` gives std's digits for `x` (finite, not zero): `x` is
/// `m·2^q` with `m` odd and `q < −25`, as a trace's speeds and positions
/// mostly are.
fn past_ties(x: f64) -> bool {
    // Both give the shortest digits that round-trip, the closest to `x`;
    // they differ only on a tie (`x` exactly halfway between two shortest
    // candidates: ryu rounds to even, std up). A tie needs `x`'s exact
    // decimal expansion to end one digit after the 17th at the latest;
    // with `q < −25` it has more than 18 significant digits (`m·5^−q`).
    let bits = x.to_bits();
    let field = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1 << 52) - 1);
    let (mantissa, exponent) = if field == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1 << 52), field - 1075)
    };
    mantissa != 0 && exponent + (mantissa.trailing_zeros() as i32) < -25
}

fn parse_exponent(text: &[u8]) -> i32 {
    let (negative, digits) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    let value = digits
        .iter()
        .fold(0i32, |v, &d| v * 10 + i32::from(d.wrapping_sub(b'0')));
    if negative { -value } else { value }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(x: f64) -> String {
        let mut out = Vec::new();
        push_f64(&mut out, x);
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn written_as_std_writes_them() {
        for x in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            0.2,
            0.3,
            1.5,
            2.5,
            10.0,
            100.0,
            123456.0,
            0.001,
            1e-7,
            1.2345e-7,
            1e15,
            1e16,
            1.5e16,
            1e21,
            1e22,
            1e100,
            1e-100,
            5e-324,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            f64::EPSILON,
            0.21,
            -0.26,
            0.48,
            6534.0,
            0.2000000000000001,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            9007199254740993.0,
            4.35,
            0.07,
            -1963075628841850.2,
            1152921504606846976.0,
            0.5,
            0.25,
            1e23,
        ] {
            assert_eq!(text(x), format!("{x}"), "{x:e}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]
        /// Any bits at all, and the values a trace holds (small speeds
        /// and positions): the same text as std.
        #[test]
        fn any_f64_is_written_as_std_writes_it(
            bits in proptest::num::u64::ANY,
            small in -10.0f64..10.0,
            scale in -30i32..30,
        ) {
            let x = f64::from_bits(bits);
            proptest::prop_assert_eq!(text(x), format!("{x}"));
            let y = small * 10f64.powi(scale);
            proptest::prop_assert_eq!(text(y), format!("{y}"));
        }
    }
}
