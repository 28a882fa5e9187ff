//! The sRGB transfer functions (IEC 61966-2-1), both ways: encoding a film's
//! linear radiance for PNG, decoding a PNG texture to linear.

/// The sRGB transfer function (IEC 61966-2-1): linear `x` in `[0, 1]` to the
/// encoded value, `12.92 x` below `0.0031308`, else `1.055 x^(1/2.4) - 0.055`.
fn linear_to_srgb(x: f64) -> f64 {
    if x < 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear radiance to an 8-bit sRGB code value: clamped to `[0, 1]` (NaN
/// gives 0), encoded, rounded to nearest.
pub fn srgb8(linear: f64) -> u8 {
    if linear.is_nan() || linear <= 0.0 {
        return 0;
    }
    let encoded = linear_to_srgb(linear.min(1.0)).clamp(0.0, 1.0);
    (encoded * 255.0).round() as u8
}

/// The exact sRGB electro-optical transfer function: encoded value in
/// `[0, 1]` to linear.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_of_known_values() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        // 1.055 * 0.5^(1/2.4) - 0.055 = 0.735356..., * 255 = 187.52
        assert_eq!(srgb8(0.5), 188);
        assert_eq!(srgb8(0.18), 118);
        // Clamped: negative, NaN, above one, infinite.
        assert_eq!(srgb8(-1.0), 0);
        assert_eq!(srgb8(f64::NAN), 0);
        assert_eq!(srgb8(7.0), 255);
        assert_eq!(srgb8(f64::INFINITY), 255);
        // The two pieces meet at 0.0031308 (to the precision of the standard's
        // constants), and the linear piece is used just below it.
        let b = 0.0031308f64;
        let power_piece = 1.055 * b.powf(1.0 / 2.4) - 0.055;
        assert!((12.92 * b - power_piece).abs() < 1e-7);
        assert!((linear_to_srgb(b) - linear_to_srgb(b - 1e-12)).abs() < 1e-7);
        assert_eq!(linear_to_srgb(0.001), 12.92 * 0.001);
        assert_eq!(srgb8(b), 10);
    }

    #[test]
    fn srgb_transfer_function_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_eq!(srgb_to_linear(1.0), 1.0);
        // 0.04045 / 12.92 on the linear segment
        assert!((srgb_to_linear(0.04045) - 0.003130804953560371).abs() < 1e-15);
        // the two pieces meet there to 1e-8 (they are not exactly continuous)
        assert!((srgb_to_linear(0.04045 + 1e-12) - 0.0031308).abs() < 1e-7);
        // 8-bit 128: ((128/255 + 0.055) / 1.055)^2.4 = 0.2158605
        assert!((srgb_to_linear(128.0 / 255.0) - 0.21586050011389923).abs() < 1e-12);
    }
}
