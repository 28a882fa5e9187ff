//! Deterministic sample streams. Every sample owns a [`Sampler`] seeded from
//! (seed, pixel, sample index) alone, so the image is a pure function of the
//! scene, the settings and the seed: the same bits for any thread count or
//! tile order.
//!
//! Three generators, chosen with [`SamplerKind`] (`--sampler`):
//!
//! - `independent`: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast
//!   Space-Efficient Statistically Good Algorithms for Random Number
//!   Generation"), with the stream selected by a SplitMix64 hash of the
//!   triple (Steele, Lea and Flood 2014).
//! - `sobol` (the default): padded, Owen-scrambled Sobol points, after
//!   pbrt-v4's `PaddedSobolSampler` (section 8.7.4): every 1D or 2D request
//!   of a sample takes the first one or two Sobol dimensions (which together
//!   form a (0, 2)-sequence) at the sample's index, permuted per pixel and per
//!   dimension so that different dimensions are not correlated, and
//!   Owen-scrambled (nested uniform scrambling, Owen 1995, approximated by a
//!   Laine-Karras hash, see [`lk_hash`]) with a seed hashed from (seed,
//!   pixel, dimension). The samples of one pixel are then, in every
//!   dimension pair, a randomised (0, m, 2)-net when their count is a power
//!   of two `2^m`, and each point is uniformly distributed, so the estimator
//!   stays unbiased. The index permutation is a nested uniform scramble of
//!   all 32 bits of the index (Burley 2020's progressive shuffle): the
//!   first `2^k` samples of a pixel use one aligned block of Sobol indices
//!   in every dimension (a net at every power of two), and sample `i` is
//!   the same point whatever the render's total, so a render in passes, one
//!   that stops on a time limit, and one resumed from a checkpoint to more
//!   samples all draw the points of one run.
//! - `zsobol`: pbrt-v4's `ZSobolSampler` (Ahmed and Wonka 2020): the same
//!   points, indexed along a Morton curve over the pixels, so neighbouring
//!   pixels' errors spread as blue noise; the same error per pixel, at a
//!   higher cost per sample (a digit permutation over the whole Morton
//!   index, not a pixel's own samples).
//!
//! Integer requests ([`Sampler::next_u32`]) always come from the PCG stream.

use crate::math::Vec2;
use std::fmt;
use std::str::FromStr;

/// Which generator a render draws its samples from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent uniform random numbers (PCG32).
    Independent,
    /// Padded, Owen-scrambled Sobol points.
    #[default]
    Sobol,
    /// Owen-scrambled Sobol points along a Morton curve of the pixels
    /// (pbrt-v4's `ZSobolSampler`).
    ZSobol,
}

impl SamplerKind {
    /// Whether renders of `a` and of `b` samples per pixel draw the same
    /// points for the samples they share: always for `independent` and
    /// `sobol` (whose shuffle spans every index); for `zsobol` when `a` and
    /// `b` round up to the same power of two (its Morton layout spans that
    /// many samples a pixel). A checkpoint may be resumed to another spp
    /// only then.
    pub fn same_points(self, a: u32, b: u32) -> bool {
        match self {
            SamplerKind::Independent | SamplerKind::Sobol => true,
            SamplerKind::ZSobol => a.max(1).next_power_of_two() == b.max(1).next_power_of_two(),
        }
    }

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
            SamplerKind::ZSobol => "zsobol",
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
            "zsobol" => Ok(SamplerKind::ZSobol),
            _ => Err(format!(
                "unknown sampler `{s}` (expected independent, sobol or zsobol)"
            )),
        }
    }
}

/// SplitMix64's finaliser: a bijective 64-bit mix.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Where a render's samples come from: the generator, the seed, and for
/// `zsobol` the layout of the image's sample indices along the Morton
/// curve, which depends on the image size and on how many samples per
/// pixel the whole render takes (all its passes together). Every sample's
/// generator is a function of this, its pixel and its index alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleSpace {
    kind: SamplerKind,
    seed: u64,
    width: u32,
    /// `zsobol`: log2 of the samples per pixel, rounded up.
    log2_spp: u32,
    /// `zsobol`: base-4 digits of a sample's Morton index.
    digits: u32,
}

impl SampleSpace {
    /// The samples of a `resolution` image rendered with `total_spp` samples
    /// per pixel in all, drawn by `kind` under `seed`.
    pub fn new(kind: SamplerKind, seed: u64, resolution: [u32; 2], total_spp: u32) -> Self {
        let log2_spp = total_spp.max(1).next_power_of_two().trailing_zeros();
        let side = resolution[0].max(resolution[1]).max(1).next_power_of_two();
        SampleSpace {
            kind,
            seed,
            width: resolution[0],
            log2_spp,
            digits: side.trailing_zeros() + log2_spp.div_ceil(2),
        }
    }

    /// The generator of sample `sample` of pixel `(x, y)`.
    #[inline]
    pub fn sampler(&self, x: u32, y: u32, sample: u32) -> Sampler {
        let pixel = y as u64 * self.width as u64 + x as u64;
        if self.kind == SamplerKind::Independent {
            return Sampler::new(self.seed, pixel, sample as u64);
        }
        // the Sobol kinds draw integers (tests only) from a PCG stream
        // seeded without the full mix
        let mut s = Sampler {
            state: self.seed ^ pixel.rotate_left(24) ^ sample as u64,
            inc: (pixel << 1) | 1,
            seq: Seq::Independent,
        };
        s.seq = match self.kind {
            SamplerKind::Independent => Seq::Independent,
            SamplerKind::Sobol => Seq::Sobol(Padded::new(
                mix64(self.seed ^ mix64(pixel ^ 0x005e_ed0f_50b0)),
                sample,
            )),
            SamplerKind::ZSobol => Seq::ZSobol(ZOrder {
                seed: mix64(self.seed ^ 0x2_50b0),
                morton: (morton2(x, y) << self.log2_spp) | sample as u64,
                dimension: 0,
                log2_spp: self.log2_spp,
                digits: self.digits,
            }),
        };
        s
    }
}

/// The sample generator for one sample of one pixel.
#[derive(Debug, Clone)]
pub struct Sampler {
    state: u64,
    inc: u64,
    seq: Seq,
}

/// Where `next_1d` and `next_2d` come from.
#[derive(Debug, Clone, Copy)]
enum Seq {
    Independent,
    Sobol(Padded),
    ZSobol(ZOrder),
}

/// The padded Sobol state of one sample: a hash of its seed and pixel, its
/// index, and the dimension that comes next.
#[derive(Debug, Clone, Copy)]
struct Padded {
    base: u64,
    /// The sample's index, bit-reversed.
    reversed: u32,
    dimension: u32,
}

/// The ZSobol state of one sample: its Morton index (the pixel's Morton
/// code, then the sample's index in `log2_spp` bits) and the next dimension.
#[derive(Debug, Clone, Copy)]
struct ZOrder {
    seed: u64,
    morton: u64,
    dimension: u32,
    log2_spp: u32,
    digits: u32,
}

/// The `i`-th point of the first Sobol dimension (van der Corput in base 2),
/// as a 32-bit fraction.
#[cfg(test)]
fn sobol_dim0(i: u32) -> u32 {
    i.reverse_bits()
}

/// The `i`-th point of the second Sobol dimension (primitive polynomial
/// `x + 1`, direction numbers `v_1 = 1/2`, `v_k = v_{k-1} ^ (v_{k-1} >> 1)`).
#[cfg(test)]
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

/// `sobol_dim1(i).reverse_bits()`, in five shift-and-xor steps. Reversed,
/// the direction numbers are `w_k = (1 + x)^k` as polynomials over GF(2)
/// (`w_0 = 1`, `w_k = w_{k-1} ^ (w_{k-1} << 1)`), and `(1 + x)^k` is the
/// product of `1 + x^(2^j)` over the set bits `j` of `k`: the sum of `x^m`
/// over every `m` whose bits are a subset of `k`'s. So bit `m` of the
/// point is the xor of the index's bits `k` over the supersets of `m`, a
/// superset transform with one step per bit of the position `m` (each
/// step's mask selects the positions where that bit is clear). This
/// replaced byte tables (two lookups below `2^16`, four above, 4 KB):
/// the same bits, and no loads.
#[inline(always)]
fn sobol_dim1_reversed(i: u32) -> u32 {
    let mut v = i;
    v ^= (v >> 1) & 0x5555_5555;
    v ^= (v >> 2) & 0x3333_3333;
    v ^= (v >> 4) & 0x0f0f_0f0f;
    v ^= (v >> 8) & 0x00ff_00ff;
    v ^= (v >> 16) & 0x0000_ffff;
    v
}

/// The core of the Laine-Karras hash on a bit-reversed value: with the bits
/// reversed, additions, odd multiplications and `x ^= x * even` only carry
/// information from lower to higher bits, so every original bit is flipped
/// by a function of the bits above it, which is exactly a nested (Owen)
/// scramble, only not drawn from all of them (Laine and Karras, "Stratified
/// Sampling for Stochastic Transparency", EGSR 2011). The constants are
/// Vegdahl's ("Building a Better LK Hash", 2021, also used by pbrt-v4's
/// `FastOwenScrambler`).
#[inline(always)]
fn lk_hash(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Owen scrambling of the fraction `v` (32 bits), approximated by the
/// Laine-Karras hash ([`lk_hash`]) under `seed`. Six operations instead of
/// a hash per bit: a full per-bit Owen scramble made Sobol renders twice as
/// slow as independent ones. The samplers use [`lk_hash`] on the reversed
/// value directly, skipping the reversals a Sobol point's own reversal
/// cancels.
#[cfg(test)]
fn owen_scramble(v: u32, seed: u64) -> u32 {
    lk_hash(v.reverse_bits(), fold(seed)).reverse_bits()
}

/// A 64-bit hash folded to a 32-bit scrambling seed.
#[inline]
fn fold(h: u64) -> u32 {
    (h ^ h >> 32) as u32
}

impl Padded {
    /// Sample `index` of the pixel hashed to `base`. The shuffle spans all
    /// 32 bits of the index, whatever the render's total, so a sample's
    /// points do not depend on how many samples the render takes.
    fn new(base: u64, index: u32) -> Self {
        Padded {
            base,
            reversed: index.reverse_bits(),
            dimension: 0,
        }
    }

    /// The shuffled sample index and the scrambling hash for the next
    /// dimension (or pair). The index's 32 bits are shuffled by a nested
    /// uniform scramble (Burley, "Practical Hash-based Owen Scrambling",
    /// JCGT 2020, section 5: the progressive shuffle): the Laine-Karras hash
    /// on the reversed bits flips each bit by a function of the bits above
    /// it, under a seed per pixel and dimension. So every aligned block of
    /// `2^k` indices lands on an aligned block of Sobol indices, for every
    /// `k`: any first `2^k` samples of a pixel are a scrambled net in every
    /// dimension pair, two dimensions' shuffles agree on which samples go
    /// together at every scale, and sample `i` is the same point whether
    /// the render takes 16 samples or 16 million, so a finished render can
    /// be taken on to more samples with the bits of one run.
    #[inline]
    fn next(&mut self, width: u32) -> (u32, u64) {
        // `base` is a full hash of the seed and pixel already: one
        // multiply-xorshift round separates the dimensions
        let h = (self.base ^ (self.dimension as u64) << 32).wrapping_mul(0xd6e8_feb8_6659_fd93);
        let hash = h ^ (h >> 32);
        self.dimension += width;
        // the hash's halves scramble the two coordinates; the shuffle's seed
        // is the high half of one more multiplication
        let seed = (hash.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 32) as u32;
        (lk_hash(self.reversed, seed).reverse_bits(), hash)
    }
}

/// The 24 permutations of four digits, in lexicographic order.
static PERMUTATIONS_4: [[u8; 4]; 24] = {
    let mut t = [[0u8; 4]; 24];
    let mut n = 0;
    let mut a = 0;
    while a < 4 {
        let mut b = 0;
        while b < 4 {
            let mut c = 0;
            while c < 4 {
                if a != b && a != c && b != c {
                    t[n] = [a, b, c, 6 - a - b - c];
                    n += 1;
                }
                c += 1;
            }
            b += 1;
        }
        a += 1;
    }
    t
};

/// `x` and `y` interleaved bit by bit, `x` in the even bits (a Morton code).
fn morton2(x: u32, y: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = v as u64;
        v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
        v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        (v | (v << 1)) & 0x5555_5555_5555_5555
    }
    spread(x) | (spread(y) << 1)
}

/// The low `bits` bits of `index` under a nested random permutation of its
/// base-4 digits: each digit, most significant first, goes through one of
/// the 24 permutations of four values, chosen by a hash of `salt` and the
/// digits above it; with an odd `bits` the lowest digit is binary and is
/// flipped or not. A nested permutation maps every aligned block of indices
/// that ends at a digit boundary (`2^(bits - 2t)` long) onto an aligned
/// block, so an aligned block of Sobol points stays
/// a (scrambled) net, and, unlike an unstructured shuffle, two dimensions'
/// permutations agree on which samples go together at every scale. This is
/// the digit permutation of pbrt-v4's `ZSobolSampler` (Ahmed and Wonka
/// 2020), applied to the Morton index. (The padded sampler once shuffled a
/// pixel's own indices this way too, which lowered the Cornell box's RMSE
/// by 8 % at 64 spp and 14 % at 256 spp against a hash-based permutation
/// within dyadic blocks, as pbrt-v4's `PaddedSobolSampler` shuffles; a
/// nested scramble of the index's bits, [`Padded::next`], keeps that gain
/// with fewer instructions.)
#[inline(always)]
fn nested_digits(index: u64, bits: u32, salt: u64) -> u64 {
    let odd = bits & 1;
    let digits = bits >> 1;
    // the digits from the lowest up (the same hashes as from the top: each
    // digit's permutation is chosen by the digits above it, `rest`); each
    // output enters at the top of `out` and moves down two bits a digit, so
    // no shift depends on the digit's place until the last one
    let mut rest = index >> odd;
    let mut out = 0u64;
    for _ in 0..digits {
        let digit = (rest & 3) as usize;
        rest >>= 2;
        let p = PERMUTATIONS_4[choose_of_24(rest ^ salt)][digit] as u64;
        out = (out >> 2) | (p << 62);
    }
    // the digits fill the top `2 digits` bits (none: `out` is 0, and a
    // shift by 64 wraps to 0)
    let out = out.wrapping_shr(64 - 2 * digits);
    if odd == 1 {
        (out << 1) | ((index & 1) ^ (choose_of_24((index >> 1) ^ salt) as u64 & 1))
    } else {
        out
    }
}

/// A number in `0..24` from a hash of `x`: one multiplication by an odd
/// constant (which carries every bit of `x` into the high word), then the
/// high 32 bits scaled to 24 values. `x` already holds a full hash (the
/// salt), so this only has to tell prefixes of one index apart.
#[inline(always)]
fn choose_of_24(x: u64) -> usize {
    // the low 32 bits of the product are those of the 32-bit product
    let h = ((x.wrapping_mul(0xd1b5_4a32_d192_ed03) >> 32) ^ (x >> 32)) as u32;
    ((h.wrapping_mul(0x9e37_79b9) as u64 * 24) >> 32) as usize
}

impl ZOrder {
    /// The Sobol index of this sample for the next dimension (or pair), and
    /// the scrambling hash: its Morton index (the pixel's Morton code, then
    /// the sample's index) under a nested permutation of all its digits
    /// ([`nested_digits`]; Ahmed and Wonka, "Screen-Space Blue-Noise
    /// Diffusion of Monte Carlo Sampling Error via Hierarchical Ordering of
    /// Pixels", 2020; pbrt-v4 section 8.7.7). A pixel's samples keep one
    /// aligned block of indices, so they are a scrambled net, while
    /// neighbouring pixels share the higher digits' structure, which spreads
    /// their errors as blue noise.
    #[inline]
    fn next(&mut self, width: u32) -> (u64, u64) {
        let salt = mix64(self.seed ^ self.dimension as u64);
        self.dimension += width;
        let index = nested_digits(self.morton, 2 * self.digits - (self.log2_spp & 1), salt);
        // the points use 32 bits of the index; the rest (images of more than
        // 2^32 samples) goes into the scrambling seed
        (index, mix64(salt ^ (index >> 32)))
    }
}

#[inline(always)]
fn unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

const PCG_MULT: u64 = 6_364_136_223_846_793_005;

impl Sampler {
    /// The independent stream for sample `sample` of pixel `pixel` under
    /// `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        let a = mix64(seed ^ mix64(pixel ^ mix64(sample)));
        let b = mix64(a ^ 0x5851_f42d_4c95_7f2d);
        let mut s = Sampler {
            state: 0,
            inc: (b << 1) | 1,
            seq: Seq::Independent,
        };
        s.next_u32();
        s.state = s.state.wrapping_add(a);
        s.next_u32();
        s
    }

    /// The next 32 random bits (always from the independent stream).
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
        match &mut self.seq {
            Seq::Independent => unit(self.next_u32()),
            Seq::Sobol(s) => {
                let (i, hash) = s.next(1);
                // the scrambled first dimension: reverse(lk(reverse(reverse(i))))
                unit(lk_hash(i, fold(hash)).reverse_bits())
            }
            Seq::ZSobol(z) => {
                let (i, hash) = z.next(1);
                unit(lk_hash(i as u32, fold(hash)).reverse_bits())
            }
        }
    }

    /// Move past the number [`Sampler::next_1d`] would give, without
    /// computing it: the stream goes on exactly as if it had been drawn.
    #[inline]
    pub fn skip_1d(&mut self) {
        match &mut self.seq {
            Seq::Independent => {
                self.next_u32();
            }
            Seq::Sobol(s) => s.dimension += 1,
            Seq::ZSobol(z) => z.dimension += 1,
        }
    }

    /// Two uniform numbers in `[0, 1)`.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let (i, hash) = match &mut self.seq {
            Seq::Independent => {
                let x = self.next_1d();
                return Vec2::new(x, self.next_1d());
            }
            Seq::Sobol(s) => s.next(2),
            Seq::ZSobol(z) => {
                let (i, hash) = z.next(2);
                (i as u32, hash)
            }
        };
        // the hash's two halves scramble the two dimensions; one 64-bit
        // reversal reverses both (and swaps them)
        let x = lk_hash(i, hash as u32);
        let y = lk_hash(sobol_dim1_reversed(i), (hash >> 32) as u32);
        let r = ((y as u64) << 32 | x as u64).reverse_bits();
        Vec2::new(unit((r >> 32) as u32), unit(r as u32))
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

    /// [`nested_digits`] as first written: the digits from the top, each
    /// shifted into place.
    fn nested_digits_from_the_top(index: u64, bits: u32, salt: u64) -> u64 {
        let odd = bits & 1;
        let mut out = 0u64;
        let mut shift = bits;
        while shift >= 2 + odd {
            shift -= 2;
            let digit = (index >> shift) & 3;
            let higher = index >> (shift + 2);
            out |= (PERMUTATIONS_4[choose_of_24(higher ^ salt)][digit as usize] as u64) << shift;
        }
        if odd == 1 {
            out |= (index & 1) ^ (choose_of_24((index >> 1) ^ salt) as u64 & 1);
        }
        out
    }

    #[test]
    fn nested_digits_match_the_form_from_the_top() {
        let mut salt = 0x1234_5678_9abc_def0u64;
        // (at 64 bits the form from the top shifts by 64; no image has
        // that many: zsobol's Morton index of a 2^16-pixel square at 2^31
        // spp has 63)
        for bits in 0..=63 {
            for k in 0..200u64 {
                salt = mix64(salt);
                // small and large indices, and bits above `bits` (samples
                // past the layout)
                let index = mix64(k ^ salt) >> (k % 64);
                assert_eq!(
                    nested_digits(index, bits, salt),
                    nested_digits_from_the_top(index, bits, salt),
                    "index {index:#x} bits {bits} salt {salt:#x}"
                );
            }
        }
    }

    #[test]
    fn padded_shuffles_map_every_prefix_and_aligned_block_onto_an_aligned_block() {
        let shuffle = |base: u64, dimension: u32, i: u32| {
            let mut p = Padded::new(base, i);
            p.dimension = dimension;
            p.next(2).0
        };
        for base in [0, 1, 0xdead_beef_1234_5678, u64::MAX] {
            for dimension in [0, 2, 9] {
                // the first 2^12 samples, and a block further on
                for start in [0u32, 5 << 12, u32::MAX - 4095] {
                    let p: Vec<u32> = (start..=start + 4095)
                        .map(|i| shuffle(base, dimension, i))
                        .collect();
                    // every aligned block of every power-of-two size, the
                    // whole run included, lands on an aligned block of that
                    // size, one to one
                    for k in 0..=12 {
                        let j = 1u32 << k;
                        for block in p.chunks(j as usize) {
                            let lo = *block.iter().min().unwrap();
                            assert_eq!(lo % j, 0, "base {base} dim {dimension} k {k}");
                            let mut offs: Vec<u32> = block.iter().map(|x| x - lo).collect();
                            offs.sort_unstable();
                            assert_eq!(offs, (0..j).collect::<Vec<_>>());
                        }
                    }
                }
            }
        }
        // the shuffle depends on the pixel's hash and on the dimension, and
        // leaves no index where it was (the first 64 fill one random block)
        let at = |base, dimension| (0..64).map(move |i| shuffle(base, dimension, i));
        assert!(at(1, 0).ne(at(2, 0)));
        assert!(at(1, 0).ne(at(1, 2)));
        assert!(at(1, 0).min().unwrap() >= 64 || at(2, 0).min().unwrap() >= 64);
    }

    #[test]
    fn nested_digit_permutations_are_bijections_that_keep_aligned_blocks() {
        for bits in 0..=9 {
            for salt in [0, 1, 0xdead_beef_1234_5678, u64::MAX] {
                let n = 1u64 << bits;
                let p: Vec<u64> = (0..n).map(|i| nested_digits(i, bits, salt)).collect();
                let mut sorted = p.clone();
                sorted.sort_unstable();
                assert_eq!(
                    sorted,
                    (0..n).collect::<Vec<_>>(),
                    "bits {bits} salt {salt}"
                );
                // each aligned block at a digit boundary (2^(bits - 2t))
                // lands on an aligned block
                for t in 0..=bits / 2 {
                    let j = 1u64 << (bits - 2 * t);
                    for block in p.chunks(j as usize) {
                        let lo = block.iter().min().unwrap();
                        assert!(lo % j == 0 && block.iter().all(|x| x / j == lo / j));
                    }
                }
            }
        }
        // and they depend on the salt
        let a: Vec<u64> = (0..64).map(|i| nested_digits(i, 6, 1)).collect();
        let b: Vec<u64> = (0..64).map(|i| nested_digits(i, 6, 2)).collect();
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

    /// The generator of sample `s` of pixel number `pixel` of a 4096-pixel
    /// wide image rendered at `spp`.
    fn at(kind: SamplerKind, seed: u64, pixel: u64, s: u32, spp: u32) -> Sampler {
        let space = SampleSpace::new(kind, seed, [4096, 4096], spp);
        space.sampler((pixel % 4096) as u32, (pixel / 4096) as u32, s)
    }

    #[test]
    fn sobol_pixels_are_scrambled_nets_in_every_dimension_pair() {
        for kind in [SamplerKind::Sobol, SamplerKind::ZSobol] {
            for (spp, pixel) in [(16u32, 0u64), (64, 12345), (256, 7), (128, 4097)] {
                let mut dims: Vec<Vec<Vec2>> = vec![Vec::new(); 6];
                let mut one_d: Vec<Vec<f32>> = vec![Vec::new(); 2];
                for s in 0..spp {
                    let mut smp = at(kind, 3, pixel, s, spp);
                    for d in dims.iter_mut() {
                        d.push(smp.next_2d());
                    }
                    for d in one_d.iter_mut() {
                        d.push(smp.next_1d());
                    }
                }
                for (k, d) in dims.iter().enumerate() {
                    assert!(
                        is_0m2_net(d),
                        "{kind} spp {spp}: pair {k} is not a (0,m,2)-net"
                    );
                }
                // 1D: one point per stratum of width 1/spp
                for d in &one_d {
                    let mut cells: Vec<usize> =
                        d.iter().map(|x| (x * spp as f32) as usize).collect();
                    cells.sort_unstable();
                    assert_eq!(cells, (0..spp as usize).collect::<Vec<_>>(), "{kind}");
                }
                // different pairs are not the same points in another order
                assert_ne!(dims[0], dims[1], "{kind}");
            }
        }
    }

    #[test]
    fn zsobol_neighbouring_pixels_share_one_net() {
        // the samples of an aligned 2 x 2 block of pixels together are a
        // scrambled net of four times the size (neighbours' points
        // interleave: what spreads their errors as blue noise), and each
        // prefix of 4^j samples of a pixel is a net too
        let spp = 16u32;
        let space = SampleSpace::new(SamplerKind::ZSobol, 9, [64, 64], spp);
        for (bx, by) in [(0u32, 0u32), (6, 10), (30, 2)] {
            let mut block = Vec::new();
            for (x, y) in [(bx, by), (bx + 1, by), (bx, by + 1), (bx + 1, by + 1)] {
                for s in 0..spp {
                    let mut smp = space.sampler(x, y, s);
                    smp.next_2d();
                    block.push(smp.next_2d());
                }
            }
            assert!(is_0m2_net(&block), "block at ({bx}, {by})");
            for prefix in [1u32, 4, 16] {
                let p: Vec<Vec2> = (0..prefix)
                    .map(|s| space.sampler(bx, by, s).next_2d())
                    .collect();
                assert!(is_0m2_net(&p), "prefix {prefix} at ({bx}, {by})");
            }
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
                    let mut smp = at(kind, 11, pixel, s, 64);
                    let _camera = smp.next_2d();
                    let p = smp.next_2d();
                    sum += (p.x * p.y) as f64;
                }
                se += (sum / 64.0 - 0.25).powi(2);
            }
            (se / 2000.0).sqrt()
        };
        let ind = rmse(SamplerKind::Independent);
        assert!((ind / 0.0276 - 1.0).abs() < 0.1, "independent RMSE {ind}");
        for kind in [SamplerKind::Sobol, SamplerKind::ZSobol] {
            let q = rmse(kind);
            assert!(q < 0.5 * ind, "{kind} RMSE {q} against independent {ind}");
        }
    }

    #[test]
    fn sobol_points_are_uniform_and_samples_past_spp_differ() {
        for kind in [SamplerKind::Sobol, SamplerKind::ZSobol] {
            let (mut sum, n) = (0.0f64, 50_000u64);
            for s in 0..n {
                let mut smp = at(kind, 5, s / 16, (s % 16) as u32, 16);
                smp.next_2d();
                sum += smp.next_1d() as f64;
            }
            // mean of U(0,1): sigma = sqrt(1/12)/sqrt(n) = 1.29e-3; 5 sigma
            // band (within a pixel the points are stratified, which only
            // shrinks it)
            assert!((sum / n as f64 - 0.5).abs() < 5.0 * 1.29e-3, "{kind}");
            // the next 16 samples (a later pass of a 32-spp render) give new
            // points, and the first 32 together are again a net
            let first = |s: u32| at(kind, 5, 9, s, 32).next_2d();
            let a: Vec<Vec2> = (0..16).map(first).collect();
            let b: Vec<Vec2> = (16..32).map(first).collect();
            assert!(a.iter().all(|p| !b.contains(p)), "{kind}");
            assert!(is_0m2_net(&[a, b].concat()), "{kind}");
        }
    }

    #[test]
    fn the_second_dimension_by_superset_transform_is_the_sobol_point() {
        // every index below 2^16, and a spread of 32-bit ones (the padded
        // sampler's shuffled indices)
        let mut h = 0x1234_5678u32;
        for i in (0..1u32 << 16).chain((0..1 << 16).map(|_| {
            h = h.wrapping_mul(0x9e37_79b9).wrapping_add(0x7f4a_7c15);
            h
        })) {
            assert_eq!(
                sobol_dim1_reversed(i),
                sobol_dim1(i).reverse_bits(),
                "index {i}"
            );
        }
    }

    #[test]
    fn fast_owen_forms_match_the_reference_scramble() {
        // the samplers skip the reversals of `owen_scramble(sobol_dim(i))`
        for i in [0u32, 1, 2, 3, 77, 1 << 20, u32::MAX] {
            for seed in [0u64, 5, 0xdead_beef_0123_4567] {
                assert_eq!(
                    owen_scramble(sobol_dim0(i), seed),
                    lk_hash(i, fold(seed)).reverse_bits()
                );
                assert_eq!(sobol_dim1_reversed(i), sobol_dim1(i).reverse_bits());
                assert_eq!(
                    owen_scramble(sobol_dim1(i), seed),
                    lk_hash(sobol_dim1_reversed(i), fold(seed)).reverse_bits()
                );
            }
        }
        // the permutation table holds each ordering of four digits once
        let mut seen = std::collections::HashSet::new();
        for p in PERMUTATIONS_4 {
            let mut q = p;
            q.sort_unstable();
            assert_eq!(q, [0, 1, 2, 3]);
            assert!(seen.insert(p));
        }
        assert_eq!(morton2(0b11, 0b01), 0b0111);
    }

    /// A hash of the bits of every value the three samplers draw for a
    /// few images, spp counts (odd and even `log2`, a pass past the
    /// layout) and seeds, in a render's order of 2D and 1D requests.
    fn stream_digest(kind: SamplerKind) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |v: f32| {
            h = (h ^ v.to_bits() as u64).wrapping_mul(0x0100_0000_01b3);
        };
        for (res, spp, seed) in [
            ([7u32, 5u32], 1u32, 0u64),
            ([16, 16], 8, 3),
            ([33, 17], 32, 0xdead_beef),
            ([64, 48], 64, 1),
            ([3, 300], 2048, 12),
        ] {
            let space = SampleSpace::new(kind, seed, res, spp);
            for y in (0..res[1]).step_by(3) {
                for x in (0..res[0]).step_by(2) {
                    for s in (0..spp + 2).step_by((spp as usize / 16).max(1)) {
                        let mut smp = space.sampler(x, y, s);
                        for d in 0..12 {
                            if d % 3 == 2 {
                                eat(smp.next_1d());
                            } else {
                                let p = smp.next_2d();
                                eat(p.x);
                                eat(p.y);
                            }
                        }
                    }
                }
            }
        }
        h
    }

    #[test]
    fn sample_values_are_pinned() {
        // the values of commit 7f7fa7c (`sobol`'s: those since its index
        // shuffle spans all 32 bits, issue 42): optimisations must keep every
        // bit (reference images and resumed checkpoints depend
        // on them)
        for (kind, digest) in [
            (SamplerKind::Independent, 0x584c_3d45_7171_3ffb),
            (SamplerKind::Sobol, 0xac66_38f1_1df9_327f),
            (SamplerKind::ZSobol, 0xf2c0_b5a8_3833_f882),
        ] {
            assert_eq!(stream_digest(kind), digest, "{kind}");
        }
    }

    #[test]
    fn skipping_a_number_leaves_the_stream_as_drawing_it() {
        for kind in [
            SamplerKind::Independent,
            SamplerKind::Sobol,
            SamplerKind::ZSobol,
        ] {
            let space = SampleSpace::new(kind, 3, [20, 10], 16);
            for (x, y, i) in [(0, 0, 0), (7, 3, 5), (19, 9, 15)] {
                let (mut drawn, mut skipped) = (space.sampler(x, y, i), space.sampler(x, y, i));
                for k in 0..12 {
                    if k % 3 == 1 {
                        drawn.next_1d();
                        skipped.skip_1d();
                    }
                    let (a, b) = (drawn.next_2d(), skipped.next_2d());
                    assert_eq!(
                        a.to_array().map(f32::to_bits),
                        b.to_array().map(f32::to_bits)
                    );
                    assert_eq!(
                        drawn.next_1d().to_bits(),
                        skipped.next_1d().to_bits(),
                        "{kind}"
                    );
                }
                assert_eq!(drawn.next_u32(), skipped.next_u32(), "{kind}");
            }
        }
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
