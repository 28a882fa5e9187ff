//! `f32` inverse trigonometry for the per-hit and per-sample paths (a
//! direction's environment-map coordinates, a sphere's texture coordinates)
//! without a call into the C library.
//!
//! glibc's `atan2f` and `acosf` are accurate to an ulp but reach their core
//! routines through error-handling wrappers; under callgrind the two took
//! 5.5 % of the instructions of a `materials` render (an environment sample
//! and every path that escapes to the environment convert a direction).
//! These take a handful of multiplications and one division or square root.
//! glibc's `sincosf` measured cheaper than a polynomial for one scalar
//! angle of any size, so general sines and cosines stay with it; but an
//! angle already in `[-pi/4, pi/4]` needs no reduction, and there
//! [`sin_cos_quarter`] is a plain function of `+ - *` that a loop over a
//! batch's lanes compiles to vector code (issue 37: the concentric map of
//! every diffuse bounce and camera lens).
//!
//! Method and coefficients: the single-precision routines of the Cephes
//! library (S. L. Moshier, `atanf.c` and `asinf.c`): reduction to a short
//! interval, then a minimax polynomial there. Errors, measured against
//! `f64` by the tests below over every input they sweep: at most 2.6 units
//! in the last place for `atan2` and 1.3 for `acos`. Each function is a
//! plain function of its input, so a value computed twice from the same
//! input is the same bits (what the environment map's `eval` and `pdf` of
//! one direction rely on to agree).

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// The minimax polynomial of Cephes's `atanf.c` on `[0, tan(pi / 8)]`,
/// highest power first, as published (the literals carry more digits than
/// an `f32` holds; each is its nearest `f32`).
#[allow(clippy::excessive_precision)]
const ATAN: [f32; 4] = [
    8.053_744_495_38e-2,
    -1.387_768_560_32e-1,
    1.997_771_064_78e-1,
    -3.333_294_915_39e-1,
];

/// The minimax polynomials of Cephes's `sinf.c` on `[-pi/4, pi/4]` (sine
/// less `x`, over `x^3`; cosine less `1 - x^2 / 2`, over `x^4`), as
/// [`ATAN`].
#[allow(clippy::excessive_precision)]
const SIN: [f32; 3] = [-1.951_529_589_1e-4, 8.332_160_873_6e-3, -1.666_665_461_1e-1];
#[allow(clippy::excessive_precision)]
const COS: [f32; 3] = [
    2.443_315_711_809_948e-5,
    -1.388_731_625_493_765e-3,
    4.166_664_568_298_827e-2,
];

/// `(sin x, cos x)` for `x` in `[-pi/4, pi/4]` (no reduction: outside it
/// the error grows). No branch and no call, so a loop of it over lanes
/// vectorises, and every instruction set computes the same bits.
#[inline(always)]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let s = ((SIN[0] * z + SIN[1]) * z + SIN[2]) * z * x + x;
    let c = ((COS[0] * z + COS[1]) * z + COS[2]) * z * z - 0.5 * z + 1.0;
    (s, c)
}

/// `(sin 2 pi t, cos 2 pi t)` for `t` in `[0, 1]` (a fraction of a turn,
/// as the samplers' numbers give it): `4 t` is split exactly into the
/// nearest whole quarter turn and a remainder in `[-1/2, 1/2]`, whose
/// angle [`sin_cos_quarter`] takes; the quarter turns swap and negate.
/// No call and no branch (selects), so it vectorises like
/// [`sin_cos_quarter`]; the reduction is exact, so it is also more
/// accurate than rounding `2 pi t` first.
#[inline(always)]
pub fn sin_cos_turn(t: f32) -> (f32, f32) {
    let q = 4.0 * t;
    // the nearest quarter (a rounding of q + 1/2 may take the other
    // neighbour: the remainder is then 1/2 and an ulp, inside the
    // polynomial's accurate range all the same)
    let k = (q + 0.5) as i32;
    // exact: q and k are within a factor of two of each other (Sterbenz)
    let (s, c) = sin_cos_quarter(FRAC_PI_2 * (q - k as f32));
    let (s, c) = if k & 1 == 0 { (s, c) } else { (c, -s) };
    if k & 2 == 0 { (s, c) } else { (-s, -c) }
}

/// The minimax polynomial of Cephes's `asinf.c` on `[0, 0.5]`, as [`ATAN`].
#[allow(clippy::excessive_precision)]
const ASIN: [f32; 5] = [
    4.216_319_904_8e-2,
    2.418_131_104_9e-2,
    4.547_002_599_8e-2,
    7.495_300_268_6e-2,
    1.666_675_242_2e-1,
];

/// `atan(t)` for `t` in `[0, 1]`.
#[inline(always)]
fn atan_unit(t: f32) -> f32 {
    // above tan(pi / 8), atan(t) = pi / 4 + atan((t - 1) / (t + 1))
    let (base, t) = if t > 0.414_213_56 {
        (FRAC_PI_4, (t - 1.0) / (t + 1.0))
    } else {
        (0.0, t)
    };
    let z = t * t;
    let p = (((ATAN[0] * z + ATAN[1]) * z + ATAN[2]) * z + ATAN[3]) * z;
    base + (t + t * p)
}

/// The angle of the point `(x, y)` from the positive `x` axis, in `[-pi, pi]`
/// (`f32::atan2`'s conventions, signed zeros included, which infinite
/// arguments also follow by going to it).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    if ax.is_infinite() || ay.is_infinite() || (ax == 0.0 && ay == 0.0) {
        return y.atan2(x);
    }
    // NaN in, NaN out: the comparisons below fail and the division gives it
    let swap = ay > ax;
    let t = if swap { ax / ay } else { ay / ax };
    let mut a = atan_unit(t);
    if swap {
        a = FRAC_PI_2 - a;
    }
    if x.is_sign_negative() {
        a = PI - a;
    }
    a.copysign(y)
}

/// `asin(x)` for `x` in `[0, 0.5]`.
#[inline(always)]
fn asin_small(x: f32) -> f32 {
    let z = x * x;
    let p = ((((ASIN[0] * z + ASIN[1]) * z + ASIN[2]) * z + ASIN[3]) * z + ASIN[4]) * z;
    x + x * p
}

/// `acos(x)` in `[0, pi]`, for `x` in `[-1, 1]` (NaN outside).
#[inline]
pub fn acos(x: f32) -> f32 {
    let a = x.abs();
    if a > 0.5 {
        // 1 - a is exact here; acos(a) = 2 asin(sqrt((1 - a) / 2))
        let s = 2.0 * asin_small((0.5 * (1.0 - a)).sqrt());
        if x > 0.0 { s } else { PI - s }
    } else if a <= 0.5 {
        FRAC_PI_2 - asin_small(a).copysign(x)
    } else {
        f32::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FLOOR: f64 = 1.0 / (1 << 20) as f64;

    /// Distance in units in the last place of `got` from the `f64` value
    /// `want` (the spacing of `f32` at `want`'s magnitude, or at `2^-20`
    /// for smaller values).
    fn ulps(got: f32, want: f64) -> f64 {
        let w = if want.abs() < FLOOR {
            FLOOR as f32
        } else {
            want as f32
        };
        let ulp = if w == 0.0 {
            f32::from_bits(1) as f64
        } else {
            (f32::from_bits(w.abs().to_bits() + 1) - w.abs()) as f64
        };
        (got as f64 - want).abs() / ulp
    }

    /// `n + 1` evenly spaced points of `[lo, hi]`, and every `f32` within
    /// 64 ulps of each end and of `extra`.
    fn sweep(lo: f32, hi: f32, n: u32, extra: &[f32]) -> Vec<f32> {
        let mut v: Vec<f32> = (0..=n)
            .map(|i| (lo as f64 + (hi - lo) as f64 * i as f64 / n as f64) as f32)
            .collect();
        for &e in [lo, hi].iter().chain(extra) {
            let mut up = e;
            let mut down = e;
            for _ in 0..64 {
                up = crate::math::next_float_up(up);
                down = crate::math::next_float_down(down);
                v.extend([up, down]);
            }
            v.push(e);
        }
        v.retain(|x| (lo..=hi).contains(x));
        v
    }

    #[test]
    fn atan2_is_within_three_ulps_in_every_octant() {
        let mut worst: (f64, f32, f32) = (0.0, 0.0, 0.0);
        for k in 0..4096 {
            let angle = -PI + 2.0 * PI * (k as f32 + 0.37) / 4096.0;
            let (s, c) = (angle as f64).sin_cos();
            for r in [1e-3f64, 0.5, 1.0, 7.0, 3e4] {
                let (y, x) = ((r * s) as f32, (r * c) as f32);
                let e = ulps(atan2(y, x), (y as f64).atan2(x as f64));
                if e > worst.0 {
                    worst = (e, y, x);
                }
            }
        }
        // small and large ratios, each sign
        for t in sweep(0.0, 1.0, 1 << 18, &[0.414_213_56]) {
            for (y, x) in [(t, 1.0), (1.0, t), (-t, 1.0), (t, -1.0), (-1.0, -t)] {
                let e = ulps(atan2(y, x), (y as f64).atan2(x as f64));
                if e > worst.0 {
                    worst = (e, y, x);
                }
            }
        }
        assert!(
            worst.0 <= 3.0,
            "{} ulps at ({}, {})",
            worst.0,
            worst.1,
            worst.2
        );
        // the library's conventions at the edges
        for (y, x) in [
            (0.0, 0.0),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (0.0, 1.0),
            (-0.0, 1.0),
            (1.0, 0.0),
            (-1.0, -0.0),
            (f32::INFINITY, 1.0),
            (1.0, f32::NEG_INFINITY),
            (f32::INFINITY, f32::INFINITY),
        ] {
            assert_eq!(atan2(y, x).to_bits(), y.atan2(x).to_bits(), "({y}, {x})");
        }
        assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
    }

    /// Over `points`, the largest errors of a sine-cosine pair `f` against
    /// the `f64` angle `angle(x)` by the measure `err`, each with where.
    fn worst_sin_cos(
        points: Vec<f32>,
        f: impl Fn(f32) -> (f32, f32),
        angle: impl Fn(f32) -> f64,
        err: impl Fn(f32, f64) -> f64,
    ) -> [(f64, f32); 2] {
        let mut worst = [(0.0, 0.0); 2];
        for x in points {
            let (s, c) = f(x);
            let a = angle(x);
            for (w, e) in worst.iter_mut().zip([err(s, a.sin()), err(c, a.cos())]) {
                if e > w.0 {
                    *w = (e, x);
                }
            }
        }
        worst
    }

    #[test]
    fn sin_cos_quarter_is_within_one_ulp() {
        let q = FRAC_PI_4;
        let [ws, wc] = worst_sin_cos(
            sweep(-q, q, 1 << 20, &[0.0]),
            sin_cos_quarter,
            f64::from,
            ulps,
        );
        assert!(ws.0 <= 1.0, "sine: {} ulps at {}", ws.0, ws.1);
        assert!(wc.0 <= 1.0, "cosine: {} ulps at {}", wc.0, wc.1);
        assert_eq!(sin_cos_quarter(0.0), (0.0, 1.0));
    }

    #[test]
    fn sin_cos_turn_is_within_one_ulp_of_the_turn() {
        // against the exact angle 2 pi t; near a zero of the function the
        // error is counted in ulps of 1 (the absolute error is what a
        // direction built of them feels)
        let quarters = [0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875];
        let [ws, wc] = worst_sin_cos(
            sweep(0.0, 1.0, 1 << 20, &quarters),
            sin_cos_turn,
            |t| 2.0 * std::f64::consts::PI * t as f64,
            |got, want| ulps(got, want).min((got as f64 - want).abs() / f32::EPSILON as f64),
        );
        assert!(ws.0 <= 1.0, "sine: {} ulps at {}", ws.0, ws.1);
        assert!(wc.0 <= 1.0, "cosine: {} ulps at {}", wc.0, wc.1);
        // the quarter turns are exact
        for (t, want) in [
            (0.0, (0.0, 1.0)),
            (0.25, (1.0, 0.0)),
            (0.5, (0.0, -1.0)),
            (0.75, (-1.0, 0.0)),
            (1.0, (0.0, 1.0)),
        ] {
            assert_eq!(sin_cos_turn(t), want, "{t}");
        }
    }

    #[test]
    fn acos_is_within_two_ulps() {
        let mut worst: (f64, f32) = (0.0, 0.0);
        for x in sweep(-1.0, 1.0, 1 << 20, &[-0.5, 0.5, 0.0]) {
            let e = ulps(acos(x), (x as f64).acos());
            if e > worst.0 {
                worst = (e, x);
            }
        }
        assert!(worst.0 <= 2.0, "{} ulps at {}", worst.0, worst.1);
        assert_eq!((acos(1.0), acos(-1.0), acos(0.0)), (0.0, PI, FRAC_PI_2));
        assert!(acos(1.5).is_nan() && acos(-1.0001).is_nan() && acos(f32::NAN).is_nan());
    }
}
