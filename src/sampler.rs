//! Deterministic sample streams. Every sample owns a [`Sampler`] seeded from
//! (seed, pixel, sample index) alone, so the image is a pure function of the
//! scene, the settings and the seed: the same bits for any thread count or
//! tile order.
//!
//! Two generators, chosen with [`SamplerKind`] (`--sampler`):
//!
//! - `independent`: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast
//!   Space-Efficient Statistically Good Algorithms for Random Number
//!   Generation"), with the stream selected by a SplitMix64 hash of the
//!   triple (Steele, Lea and Flood 2014).
//! - `sobol`: padded, Owen-scrambled Sobol points, the construction of
//!   pbrt-v4's `PaddedSobolSampler` (section 8.7.4): every 1D or 2D request
//!   of a sample takes the first one or two Sobol dimensions (which together
//!   form a (0, 2)-sequence) at the sample's index, permuted per pixel and per
//!   dimension so that different dimensions are not correlated, and
//!   Owen-scrambled (nested uniform scrambling, Owen 1995, approximated by a
//!   Laine-Karras hash, see [`owen_scramble`]) with a seed hashed from (seed,
//!   pixel, dimension). The samples of one pixel are then, in
//!   every dimension pair, a randomised (0, m, 2)-net when their count is a
//!   power of two `2^m`, and each point is uniformly distributed, so the
//!   estimator stays unbiased. The index permutation keeps every dyadic
//!   block `[2^l, 2^(l+1))` of sample indices in place and shuffles within
//!   it, so the first `2^m` samples of a pixel use exactly Sobol indices
//!   `0..2^m` in every dimension: the net property holds after every power
//!   of two, whatever the final count, and a render in passes, or one that
//!   stops on a time limit, draws the same points as one run.
//!
//! Integer requests ([`Sampler::next_u32`]) always come from the PCG stream.

use crate::math::Vec2;
use std::fmt;
use std::str::FromStr;

/// Which generator a render draws its samples from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent uniform random numbers (PCG32).
    #[default]
    Independent,
    /// Padded, Owen-scrambled Sobol points.
    Sobol,
}

impl SamplerKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
        }
    }
}

impl fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for SamplerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "independent" => Ok(SamplerKind::Independent),
            "sobol" => Ok(SamplerKind::Sobol),
            _ => Err(format!(
                "unknown sampler `{s}` (expected independent or sobol)"
            )),
        }
    }
}

/// SplitMix64's finaliser: a bijective 64-bit mix.
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The sample generator for one sample of one pixel.
#[derive(Debug, Clone)]
pub struct Sampler {
    state: u64,
    inc: u64,
    sobol: Option<Sobol>,
}

/// The padded Sobol state of one sample: where it is and which dimension
/// comes next.
#[derive(Debug, Clone, Copy)]
struct Sobol {
    seed: u64,
    pixel: u64,
    /// The sample's index in its pixel (below `2^32`).
    index: u32,
    dimension: u64,
}

/// The `i`-th point of the first Sobol dimension (van der Corput in base 2),
/// as a 32-bit fraction.
fn sobol_dim0(i: u32) -> u32 {
    i.reverse_bits()
}

/// The `i`-th point of the second Sobol dimension (primitive polynomial
/// `x + 1`, direction numbers `v_1 = 1/2`, `v_k = v_{k-1} ^ (v_{k-1} >> 1)`).
fn sobol_dim1(mut i: u32) -> u32 {
    let (mut x, mut v) = (0u32, 1u32 << 31);
    while i != 0 {
        if i & 1 != 0 {
            x ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    x
}

/// Owen scrambling of `v`, approximated by a hash in the manner of Laine and
/// Karras ("Stratified Sampling for Stochastic Transparency", EGSR 2011):
/// with the bits reversed, additions, odd multiplications and
/// `x ^= x * even` only carry information from lower to higher bits, so
/// every original bit is flipped by a function of the bits above it, which
/// is exactly a nested (Owen) scramble, only not drawn from all of them. The
/// constants are Vegdahl's ("Building a Better LK Hash", 2021, also used by
/// pbrt-v4's `FastOwenScrambler`). Six operations instead of a hash per bit:
/// a full per-bit Owen scramble made Sobol renders twice as slow as
/// independent ones.
fn owen_scramble(v: u32, seed: u64) -> u32 {
    let seed = (seed ^ seed >> 32) as u32;
    let mut x = v.reverse_bits();
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x.reverse_bits()
}

/// Element `i` of a pseudo-random permutation of `0..n` chosen by `seed`:
/// a bijection on `bits`-bit integers (xor, odd multiplications and
/// xorshifts, each invertible) applied until the value falls below `n`
/// (cycle walking, as in Kensler's "Correlated Multi-Jittered Sampling",
/// 2013), which is a bijection on `0..n`.
pub fn permutation_element(i: u32, n: u32, seed: u64) -> u32 {
    if n <= 1 {
        return 0;
    }
    let bits = 32 - (n - 1).leading_zeros();
    let mask = u32::MAX >> (32 - bits);
    let (s0, s1) = (seed as u32, (seed >> 32) as u32);
    let mut x = i & mask;
    loop {
        x ^= s0 & mask;
        x = x.wrapping_mul(0x9e37_79b1) & mask;
        x ^= x >> (bits / 2 + 1);
        x = x.wrapping_add(s1) & mask;
        x = x.wrapping_mul(0x85eb_ca6b | 1) & mask;
        x ^= x >> (bits / 3 + 1);
        if x < n {
            return x;
        }
    }
}

impl Sobol {
    /// The permuted sample index and the scrambling seed for the next
    /// dimension (or pair).
    fn next(&mut self, width: u64) -> (u32, u64) {
        let hash = mix64(self.seed ^ mix64(self.pixel ^ mix64(self.dimension ^ 0x0005_0b01)));
        self.dimension += width;
        let i = self.index;
        if i < 2 {
            return (i, hash);
        }
        // shuffle within the dyadic block [2^l, 2^(l+1)) holding i
        let l = 31 - i.leading_zeros();
        let base = 1u32 << l;
        let within = permutation_element(i - base, base, mix64(hash ^ l as u64));
        (base + within, hash)
    }
}

fn unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

const PCG_MULT: u64 = 6_364_136_223_846_793_005;

impl Sampler {
    /// The stream for sample `sample` of pixel `pixel` under `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        let a = mix64(seed ^ mix64(pixel ^ mix64(sample)));
        let b = mix64(a ^ 0x5851_f42d_4c95_7f2d);
        let mut s = Sampler {
            state: 0,
            inc: (b << 1) | 1,
            sobol: None,
        };
        s.next_u32();
        s.state = s.state.wrapping_add(a);
        s.next_u32();
        s
    }

    /// The generator `kind` for sample `sample` of pixel `pixel` under
    /// `seed`. Sample indices of the Sobol sampler wrap at `2^32`.
    pub fn with_kind(kind: SamplerKind, seed: u64, pixel: u64, sample: u64) -> Self {
        let mut s = Sampler::new(seed, pixel, sample);
        if kind == SamplerKind::Sobol {
            s.sobol = Some(Sobol {
                seed,
                pixel,
                index: sample as u32,
                dimension: 0,
            });
        }
        s
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform number in `[0, 1)` (24 random bits, so never exactly 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        match &mut self.sobol {
            None => unit(self.next_u32()),
            Some(s) => {
                let (i, hash) = s.next(1);
                unit(owen_scramble(sobol_dim0(i), hash))
            }
        }
    }

    /// Two uniform numbers in `[0, 1)`.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        match &mut self.sobol {
            None => {
                let x = self.next_1d();
                Vec2::new(x, self.next_1d())
            }
            Some(s) => {
                let (i, hash) = s.next(2);
                Vec2::new(
                    unit(owen_scramble(sobol_dim0(i), hash)),
                    unit(owen_scramble(sobol_dim1(i), mix64(hash))),
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..8)
            .map(|_| 0)
            .scan(Sampler::new(1, 2, 3), |s, _: u32| Some(s.next_u32()))
            .collect();
        let b: Vec<u32> = (0..8)
            .map(|_| 0)
            .scan(Sampler::new(1, 2, 3), |s, _: u32| Some(s.next_u32()))
            .collect();
        assert_eq!(a, b);
        for (seed, px, sm) in [(0, 2, 3), (1, 3, 3), (1, 2, 4)] {
            let mut s = Sampler::new(seed, px, sm);
            let c: Vec<u32> = (0..8).map(|_| s.next_u32()).collect();
            assert_ne!(a, c, "stream ({seed},{px},{sm}) equals (1,2,3)");
        }
    }

    #[test]
    fn sobol_dimensions_start_as_published() {
        // the first eight points of Sobol dimensions 1 and 2 in direct (not
        // Gray-code) order: direction numbers 1/2, 3/4, 5/8 for dimension 2
        // (m = 1, 3, 5 from x + 1), xor-ed by the bits of the index
        let d0: Vec<f64> = (0..8)
            .map(|i| sobol_dim0(i) as f64 / 2f64.powi(32))
            .collect();
        let d1: Vec<f64> = (0..8)
            .map(|i| sobol_dim1(i) as f64 / 2f64.powi(32))
            .collect();
        assert_eq!(d0, [0.0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875]);
        assert_eq!(d1, [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875]);
    }

    #[test]
    fn permutations_are_bijections() {
        for n in (1..=70).chain([255, 256, 257, 1000]) {
            for seed in [0, 1, 0xdead_beef_1234_5678, u64::MAX] {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let p = permutation_element(i, n, seed) as usize;
                    assert!(!seen[p], "n {n} seed {seed}: {p} twice");
                    seen[p] = true;
                }
            }
        }
        // and they depend on the seed
        let a: Vec<u32> = (0..64).map(|i| permutation_element(i, 64, 1)).collect();
        let b: Vec<u32> = (0..64).map(|i| permutation_element(i, 64, 2)).collect();
        assert_ne!(a, b);
    }

    /// Every elementary interval of area `1/n` (all `2^a x 2^(m-a)` shapes)
    /// holds exactly one of `n = 2^m` points.
    fn is_0m2_net(points: &[Vec2]) -> bool {
        let m = points.len().trailing_zeros();
        (0..=m).all(|a| {
            let (nx, ny) = (1u32 << a, 1u32 << (m - a));
            let mut seen = vec![false; points.len()];
            points.iter().all(|p| {
                let cell = (p.x * nx as f32) as usize * ny as usize + (p.y * ny as f32) as usize;
                !std::mem::replace(&mut seen[cell], true)
            })
        })
    }

    #[test]
    fn sobol_pixels_are_scrambled_nets_in_every_dimension_pair() {
        for (spp, pixel) in [(16u32, 0u64), (64, 12345), (256, 7)] {
            let mut dims: Vec<Vec<Vec2>> = vec![Vec::new(); 6];
            let mut one_d: Vec<Vec<f32>> = vec![Vec::new(); 2];
            for s in 0..spp {
                let mut smp = Sampler::with_kind(SamplerKind::Sobol, 3, pixel, s as u64);
                for d in dims.iter_mut() {
                    d.push(smp.next_2d());
                }
                for d in one_d.iter_mut() {
                    d.push(smp.next_1d());
                }
            }
            for (k, d) in dims.iter().enumerate() {
                assert!(is_0m2_net(d), "spp {spp}: pair {k} is not a (0,m,2)-net");
            }
            // 1D: one point per stratum of width 1/spp
            for d in &one_d {
                let mut cells: Vec<usize> = d.iter().map(|x| (x * spp as f32) as usize).collect();
                cells.sort_unstable();
                assert_eq!(cells, (0..spp as usize).collect::<Vec<_>>());
            }
            // different pairs are not the same points in another order
            assert_ne!(dims[0], dims[1]);
        }
    }

    #[test]
    fn sobol_integrates_a_smooth_function_better_than_independent() {
        // f(x, y) = x y over 64 samples per pixel, 2000 pixels: RMSE of the
        // estimate of 1/4. Independent sampling: sigma(xy) / 8 = 0.0276.
        // A scrambled (0, 6, 2)-net converges like n^-1.5 or better here, so
        // the ratio is far below 1; 0.5 leaves a wide margin for the
        // randomness of the 2000-pixel RMSE estimate (its relative standard
        // error is about 1/sqrt(2 * 2000) = 1.6%).
        let rmse = |kind| {
            let mut se = 0.0f64;
            for pixel in 0..2000u64 {
                let mut sum = 0.0f64;
                for s in 0..64 {
                    let mut smp = Sampler::with_kind(kind, 11, pixel, s);
                    let _camera = smp.next_2d();
                    let p = smp.next_2d();
                    sum += (p.x * p.y) as f64;
                }
                se += (sum / 64.0 - 0.25).powi(2);
            }
            (se / 2000.0).sqrt()
        };
        let (ind, sob) = (rmse(SamplerKind::Independent), rmse(SamplerKind::Sobol));
        assert!((ind / 0.0276 - 1.0).abs() < 0.1, "independent RMSE {ind}");
        assert!(
            sob < 0.5 * ind,
            "sobol RMSE {sob} against independent {ind}"
        );
    }

    #[test]
    fn sobol_points_are_uniform_and_samples_past_spp_differ() {
        let (mut sum, n) = (0.0f64, 50_000u64);
        for s in 0..n {
            let mut smp = Sampler::with_kind(SamplerKind::Sobol, 5, s / 16, s % 16);
            smp.next_2d();
            sum += smp.next_1d() as f64;
        }
        // mean of U(0,1): sigma = sqrt(1/12)/sqrt(n) = 1.29e-3; 5 sigma band
        // (within a pixel the points are stratified, which only shrinks it)
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * 1.29e-3);
        // the next 16 samples (a later pass) give new points, and the first
        // 32 together are again a net
        let first = |s: u64| Sampler::with_kind(SamplerKind::Sobol, 5, 9, s).next_2d();
        let a: Vec<Vec2> = (0..16).map(first).collect();
        let b: Vec<Vec2> = (16..32).map(first).collect();
        assert!(a.iter().all(|p| !b.contains(p)));
        assert!(is_0m2_net(&[a, b].concat()));
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut s = Sampler::new(7, 0, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = s.next_1d();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        // mean of U(0,1): sigma = sqrt(1/12)/sqrt(n) = 6.5e-4; 5 sigma band
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * 6.5e-4);
    }
}
