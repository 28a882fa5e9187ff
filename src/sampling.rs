//! Pure sample warps: each `square_to_x(u)` maps uniform numbers in `[0, 1)^n`
//! to a distribution and is paired with `square_to_x_pdf(..)`. No random
//! number generator lives here (pbrt-v4, section A.5 and chapter 2; Shirley
//! and Chiu's concentric map for the disk).

use crate::math::trig::sin_cos_quarter;
use crate::math::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4, PI};

pub mod bilinear;
pub mod distribution;
pub use bilinear::{BilinearSample, PeriodicBilinear2D};
pub use distribution::{PiecewiseConstant1D, PiecewiseConstant2D, Sample1D, Sample2D};

/// Concentric map of the unit square to the unit disk (Shirley and Chiu 1997).
///
/// Written without a branch or a call (the angle is `pi/4` times a ratio
/// in `[-1, 1]`, or `pi/2` less it, whose sine and cosine are the
/// first's cosine and sine), so that [`square_to_cosine_hemisphere_lanes`]
/// vectorises and gives the bits of this scalar form.
#[inline(always)]
pub fn square_to_concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    let wide = o.x.abs() > o.y.abs();
    let (r, across) = if wide { (o.x, o.y) } else { (o.y, o.x) };
    // the centre (r = 0) divides by 1 instead of 0 and scales by 0
    let den = if r == 0.0 { 1.0 } else { r };
    let (s, c) = sin_cos_quarter(FRAC_PI_4 * (across / den));
    let (x, y) = if wide { (c, s) } else { (s, c) };
    Vec2::new(r * x, r * y)
}

/// Density of [`square_to_concentric_disk`] with respect to area.
pub fn square_to_concentric_disk_pdf(p: Vec2) -> f32 {
    if p.length_squared() <= 1.0 {
        FRAC_1_PI
    } else {
        0.0
    }
}

/// Cosine-weighted direction on the hemisphere around +z (Malley's method).
/// The result has `z >= 0`; `z == 0` only on the disk's rim, where the pdf is 0
/// and callers must reject the sample.
#[inline(always)]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// [`square_to_cosine_hemisphere`] of every lane's `(u[0][k], u[1][k])`,
/// into `(x, y, z)`: one loop without a branch, which the compiler turns
/// into vector code for the instruction set the caller was compiled for,
/// each lane the same bits as the scalar call.
#[inline(always)]
pub fn square_to_cosine_hemisphere_lanes<const N: usize>(u: &[[f32; N]; 2]) -> [[f32; N]; 3] {
    let mut w = [[0.0; N]; 3];
    for k in 0..N {
        let v = square_to_cosine_hemisphere(Vec2::new(u[0][k], u[1][k]));
        w[0][k] = v.x;
        w[1][k] = v.y;
        w[2][k] = v.z;
    }
    w
}

/// Density of [`square_to_cosine_hemisphere`] with respect to solid angle: `cos / pi`.
pub fn square_to_cosine_hemisphere_pdf(w: Vec3) -> f32 {
    if w.z > 0.0 { w.z * FRAC_1_PI } else { 0.0 }
}

/// Uniform direction on the unit sphere.
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`square_to_uniform_sphere`]: `1 / (4 pi)`.
pub fn square_to_uniform_sphere_pdf(_w: Vec3) -> f32 {
    0.25 * FRAC_1_PI
}

/// Barycentrics `(b1, b2)` of a uniform point on a triangle (the square-root
/// parameterisation, pbrt-v4 section A.5.5 uses an equal-area variant): the
/// point is `(1 - b1 - b2) p0 + b1 p1 + b2 p2`. Density: `1 / area`.
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// Power heuristic with exponent 2 (Veach 1997, section 9.2.4) for a sample
/// from strategy `f` taken `nf` times with density `f_pdf`, against strategy
/// `g` taken `ng` times with density `g_pdf`. Written as
/// `1 / (1 + (b / a)^2)` so that no square overflows; always in `[0, 1]`.
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let a = nf * f_pdf;
    let b = ng * g_pdf;
    if !(a > 0.0) {
        return 0.0;
    }
    if !(b > 0.0) {
        return 1.0;
    }
    if a.is_infinite() {
        return if b.is_infinite() { 0.5 } else { 1.0 };
    }
    let r = b / a;
    1.0 / (1.0 + r * r)
}

/// A discrete distribution over `n` items with weights, sampled in constant
/// time with an alias table (Walker 1977; Vose 1991, "A Linear Algorithm for
/// Generating Random Numbers with a Given Distribution"; pbrt-v4's
/// `AliasTable`, section A.1): the items of positive weight fill `m` bins of
/// probability `1 / m` each, bin `i` holding item `i` with probability `q_i`
/// and one alias item with the rest. A draw `u` picks bin `floor(u m)` and
/// compares the fraction `u m - floor(u m)` with `q_i`: one multiplication,
/// two loads and a comparison, where inverting the cumulative sum took a
/// binary search (a dependent load per halving, cache misses for thousands
/// of lights). Items of weight zero are in no bin and never chosen, for any
/// `u` in `[0, 1]`. The resolution is that of `u` (24 bits) either way: an
/// item's probability is met to within about `2^-24` per bin it appears in.
#[derive(Debug, Clone)]
pub struct Discrete {
    /// Probability of each item (zero for weights that are zero, negative or
    /// not finite).
    pmf: Vec<f32>,
    /// The bins, over the items of positive weight.
    bins: Vec<AliasBin>,
}

/// One bin of the alias table.
#[derive(Debug, Clone, Copy)]
struct AliasBin {
    /// Below this fraction the bin gives `item`, above it `alias`.
    q: f64,
    item: u32,
    alias: u32,
}

/// One draw from a [`Discrete`] distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiscreteSample {
    /// The chosen item.
    pub index: usize,
    /// Its probability.
    pub pmf: f32,
}

impl Discrete {
    /// A distribution proportional to `weights` (negative or non-finite weights
    /// count as zero).
    pub fn new(weights: &[f32]) -> Self {
        let w: Vec<f64> = weights
            .iter()
            .map(|&w| {
                if w.is_finite() && w > 0.0 {
                    w as f64
                } else {
                    0.0
                }
            })
            .collect();
        let total: f64 = w.iter().sum();
        let positive: Vec<u32> = (0..w.len() as u32)
            .filter(|&i| w[i as usize] > 0.0)
            .collect();
        if !(total > 0.0) || positive.is_empty() {
            return Discrete {
                pmf: vec![0.0; w.len()],
                bins: Vec::new(),
            };
        }
        let pmf = w.iter().map(|&x| (x / total) as f32).collect();
        // Vose: each bin's scaled probability m p_i, small ones topped up by
        // large ones
        let m = positive.len() as f64;
        let mut scaled: Vec<f64> = positive
            .iter()
            .map(|&i| w[i as usize] / total * m)
            .collect();
        let mut bins: Vec<AliasBin> = positive
            .iter()
            .map(|&i| AliasBin {
                q: 1.0,
                item: i,
                alias: i,
            })
            .collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..positive.len()).partition(|&k| scaled[k] < 1.0);
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            bins[s].q = scaled[s];
            bins[s].alias = positive[l];
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // what is left is 1 up to rounding: those bins keep their own item
        // (every item in a bin has positive weight, so rounding can never
        // give a zero-weight item a chance)
        for k in small.into_iter().chain(large) {
            bins[k].q = 1.0;
        }
        Discrete { pmf, bins }
    }

    /// Whether every weight is zero (nothing can be sampled).
    pub fn is_empty(&self) -> bool {
        self.bins.is_empty()
    }

    /// Whether one item has all the weight: then [`Discrete::sample`] gives
    /// it for every `u`, and a caller need not draw `u` at all.
    pub fn is_certain(&self) -> bool {
        self.bins.len() == 1
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf.get(i).copied().unwrap_or(0.0)
    }

    /// Choose an item with `u` in `[0, 1]`.
    #[inline]
    pub fn sample(&self, u: f32) -> Option<DiscreteSample> {
        let m = self.bins.len();
        if m == 0 {
            return None;
        }
        let x = (u as f64).clamp(0.0, 1.0) * m as f64;
        let k = (x as usize).min(m - 1);
        let bin = &self.bins[k];
        let index = if x - (k as f64) < bin.q {
            bin.item
        } else {
            bin.alias
        } as usize;
        Some(DiscreteSample {
            index,
            pmf: self.pmf[index],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXTREMES: [f32; 5] = [0.0, 1.4e-45, 0.5, 1.0 - 5.96e-8, 1.0];

    #[test]
    fn the_lanes_warp_gives_each_lane_the_scalar_bits() {
        // a grid, the square's edges and centre, and the diagonals where
        // the concentric map changes branch
        let mut points: Vec<Vec2> = (0..64 * 64)
            .map(|k| Vec2::new((k % 64) as f32 / 63.0, (k / 64) as f32 / 63.0))
            .collect();
        for &a in &EXTREMES {
            for &b in &EXTREMES {
                points.push(Vec2::new(a, b));
            }
        }
        points.extend((0..256).map(|k| Vec2::splat(k as f32 / 255.0)));
        points.extend((0..256).map(|k| Vec2::new(k as f32 / 255.0, 1.0 - k as f32 / 255.0)));
        for chunk in points.chunks(16) {
            let mut u = [[0.25; 16]; 2];
            for (k, p) in chunk.iter().enumerate() {
                (u[0][k], u[1][k]) = (p.x, p.y);
            }
            let w = square_to_cosine_hemisphere_lanes(&u);
            for (k, p) in chunk.iter().enumerate() {
                let want = square_to_cosine_hemisphere(*p);
                let got = Vec3::new(w[0][k], w[1][k], w[2][k]);
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "{p}"
                );
            }
        }
    }

    #[test]
    fn the_concentric_map_keeps_the_disk_and_the_centre() {
        assert_eq!(square_to_concentric_disk(Vec2::splat(0.5)), Vec2::ZERO);
        for k in 0..=64 {
            let t = k as f32 / 64.0;
            for u in [
                Vec2::new(t, 0.0),
                Vec2::new(0.0, t),
                Vec2::new(t, 1.0),
                Vec2::new(1.0, t),
            ] {
                // the square's edge lands on the unit circle
                let r = square_to_concentric_disk(u).length();
                assert!((r - 1.0).abs() < 1e-6, "{u}: radius {r}");
            }
        }
    }

    #[test]
    fn extreme_numbers_give_finite_unit_directions() {
        for &a in &EXTREMES {
            for &b in &EXTREMES {
                let u = Vec2::new(a, b);
                let w = square_to_cosine_hemisphere(u);
                assert!(
                    w.is_finite() && (w.length() - 1.0).abs() < 1e-5,
                    "{u:?} -> {w:?}"
                );
                assert!(w.z >= 0.0);
                let pdf = square_to_cosine_hemisphere_pdf(w);
                assert!(pdf.is_finite() && pdf >= 0.0);
                let s = square_to_uniform_sphere(u);
                assert!(s.is_finite() && (s.length() - 1.0).abs() < 1e-5);
                let t = square_to_uniform_triangle(u);
                assert!(t.x >= 0.0 && t.y >= 0.0 && t.x + t.y <= 1.0 + 1e-6, "{t:?}");
            }
        }
    }

    #[test]
    fn power_heuristic_stays_in_unit_interval() {
        let pdfs = [0.0, 1e-30, 1.0, 1e30, f32::INFINITY];
        for &a in &pdfs {
            for &b in &pdfs {
                let w = power_heuristic(1.0, a, 1.0, b);
                assert!((0.0..=1.0).contains(&w), "w({a}, {b}) = {w}");
                if a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite() {
                    let sum = w + power_heuristic(1.0, b, 1.0, a);
                    assert!((sum - 1.0).abs() < 1e-6, "weights of {a}, {b} sum to {sum}");
                }
            }
        }
        assert_eq!(power_heuristic(1.0, 0.0, 1.0, 1.0), 0.0);
        assert_eq!(power_heuristic(1.0, 1.0, 1.0, 0.0), 1.0);
    }

    #[test]
    fn alias_table_gives_each_item_its_probability() {
        // every u on a grid of 2^20 points: each item is drawn in proportion
        // to its weight, to within the grid's resolution per bin
        let weights: Vec<f32> = (0..37)
            .map(|i| match i % 5 {
                0 => 0.0,
                1 => 1e-3,
                _ => (i % 11) as f32 + 0.5,
            })
            .collect();
        let d = Discrete::new(&weights);
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        let n = 1u32 << 20;
        let mut count = vec![0u32; weights.len()];
        for k in 0..n {
            count[d.sample(k as f32 / n as f32).unwrap().index] += 1;
        }
        let bins = weights.iter().filter(|&&w| w > 0.0).count() as f64;
        for (i, &w) in weights.iter().enumerate() {
            let p = w as f64 / total;
            let got = count[i] as f64 / n as f64;
            assert!(
                (got - p).abs() <= 2.0 * bins / n as f64,
                "item {i}: {got} vs {p}"
            );
            assert!((d.pmf(i) as f64 - p).abs() < 1e-7);
            if w == 0.0 {
                assert_eq!(count[i], 0, "zero-weight item {i} drawn");
            }
        }
    }

    #[test]
    fn discrete_skips_zero_weights() {
        let d = Discrete::new(&[0.0, 1.0, 0.0, 3.0, 0.0]);
        for &u in &EXTREMES {
            let s = d.sample(u).unwrap();
            assert!(s.index == 1 || s.index == 3, "u={u} chose {}", s.index);
            assert!(s.pmf > 0.0);
        }
        assert_eq!(d.pmf(3), 0.75);
        assert_eq!(d.pmf(0), 0.0);
        assert!(Discrete::new(&[0.0, f32::NAN]).sample(0.5).is_none());
    }

    #[test]
    fn a_certain_choice_ignores_its_number() {
        // one item of positive weight among zeros: every u gives it
        let d = Discrete::new(&[0.0, 2.5, 0.0]);
        assert!(d.is_certain());
        for &u in &EXTREMES {
            assert_eq!(d.sample(u), Some(DiscreteSample { index: 1, pmf: 1.0 }));
        }
        assert!(!Discrete::new(&[1.0, 1e-30]).is_certain());
        assert!(!Discrete::new(&[0.0]).is_certain());
    }
}
