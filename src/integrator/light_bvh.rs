//! Light selection by a light BVH: pbrt-v4's `BVHLightSampler` (PBR 4th
//! ed. section 12.6.3), after Conty Estevez and Kulla 2018, "Importance
//! Sampling of Many Lights with Adaptive Tree Splitting".
//!
//! Every light that is not at infinity (area lights, point and spot lights)
//! gets [`LightBounds`]: a box, a power `phi`, a cone of normals (axis `w`,
//! spread `theta_o`) and the angle `theta_e` beyond it up to which it
//! emits, and whether it emits from both sides. The tree is built top-down
//! by pbrt's cost (power times the orientation measure `M_Omega` times the
//! box's surface area, times the box's aspect `K_r`), over 12 buckets per
//! axis, down to one light per leaf. The binary tree is then collapsed into
//! a 4-wide one (each node's children replaced by theirs, where they have
//! them), whose nodes store their children's bounds lane by lane, so that
//! one pass of 4-wide arithmetic evaluates all four importances; it has half
//! the levels to walk. A light is chosen by walking from the root, at each
//! node choosing a child in proportion to its [`LightBounds::importance`]
//! at the shading point (which bounds, from above, how much the lights
//! below can send there); the product of those choices is the light's
//! probability. Each light keeps its trail (the child taken at each
//! depth), so [`LightBvh::pmf`] retraces that path for MIS and multiplies
//! the same factors in the same order: the pmf the sampler returns and the
//! one MIS asks for are the same bits.
//!
//! Lights at infinity (directional lights, the uniform environment, the
//! environment map) are chosen apart, as pbrt does: each with probability
//! `1 / (n_inf + 1)`, the tree with the rest (`n_inf / n_inf` when there
//! is no finite light).
//!
//! Light powers are normalised so that the largest is 1 before they become
//! `f32` (as for the power-based table), so no power overflows.

use crate::math::Vec3;
use crate::sampling::DiscreteSample;
use glam::Vec4;
use std::f32::consts::PI;

/// The largest `f32` below 1, so that a rescaled number stays in `[0, 1)`.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Buckets per axis in the build.
const BUCKETS: usize = 12;

/// From this depth on, ranges are split at their middle, so that no bit
/// trail needs more than 64 bits (`32 + log2(lights)`).
const BALANCED_FROM_DEPTH: u32 = 32;

/// What the tree knows about a light, or about all lights below a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightBounds {
    /// Corner of the box with the smallest coordinates.
    pub min: Vec3,
    /// Corner with the largest.
    pub max: Vec3,
    /// Axis of the cone of normals (unit).
    pub w: Vec3,
    /// Power (normalised: the largest light's is 1).
    pub phi: f32,
    /// Cosine of the cone of normals' half-angle `theta_o`.
    pub cos_theta_o: f32,
    /// Cosine of the angle `theta_e` past the normals up to which the light
    /// emits (pi / 2 for a diffuse emitter).
    pub cos_theta_e: f32,
    /// Emits on both sides of its normals.
    pub two_sided: bool,
}

#[inline]
fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

impl LightBounds {
    fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// An upper bound, up to a constant, of what the lights in these bounds
    /// send to a point `p` with normal `n` (zero: a point in empty space,
    /// no cosine): `phi cos(theta') / d^2` times the receiver's clamped
    /// cosine, with `theta'` the smallest angle between the cone of
    /// emission and the direction to `p`, widened by the angle the box
    /// subtends (pbrt-v4's `LightBounds::Importance`). Zero only where no
    /// light in the bounds can reach `p`. The tree evaluates four at once
    /// ([`Quad::importance`]); this is one lane of that.
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let mut q = Quad::EMPTY;
        q.set(0, self, LEAF);
        q.importance(p, n).x
    }

    /// Bounds of both (pbrt-v4's `Union` of light bounds and of direction
    /// cones).
    fn union(&self, o: &LightBounds) -> LightBounds {
        if self.phi == 0.0 {
            return *o;
        }
        if o.phi == 0.0 {
            return *self;
        }
        let (w, cos_theta_o) = cone_union(self.w, self.cos_theta_o, o.w, o.cos_theta_o);
        LightBounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
            w,
            phi: self.phi + o.phi,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(o.cos_theta_e),
            two_sided: self.two_sided || o.two_sided,
        }
    }

    /// pbrt's build cost: `phi M_Omega K_r` times the box's surface area,
    /// for a split along axis `dim` of a node whose box has diagonal
    /// `extent` (in `f64`).
    fn cost(&self, extent: Vec3, dim: usize) -> f64 {
        let theta_o = (self.cos_theta_o as f64).clamp(-1.0, 1.0).acos();
        let theta_e = (self.cos_theta_e as f64).clamp(-1.0, 1.0).acos();
        let theta_w = (theta_o + theta_e).min(std::f64::consts::PI);
        let sin_o = theta_o.sin();
        let cos_o = theta_o.cos();
        let pi = std::f64::consts::PI;
        let m_omega = 2.0 * pi * (1.0 - cos_o)
            + pi / 2.0
                * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                    + cos_o);
        let e = extent.as_dvec3();
        let k_r = if e[dim] > 0.0 {
            e.max_element() / e[dim]
        } else {
            1.0
        };
        let d = (self.max - self.min).as_dvec3();
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        self.phi as f64 * m_omega * k_r * area
    }
}

/// The smallest cone (of pbrt's construction) holding cones `(a, cos_a)`
/// and `(b, cos_b)`.
fn cone_union(a: Vec3, cos_a: f32, b: Vec3, cos_b: f32) -> (Vec3, f32) {
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = a.dot(b).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (a, cos_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (b, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= PI {
        return (Vec3::Z, -1.0);
    }
    let wr = a.cross(b);
    if wr.length_squared() == 0.0 {
        return (Vec3::Z, -1.0);
    }
    let rot = glam::Quat::from_axis_angle(wr.normalize(), theta_o - theta_a);
    ((rot * a).normalize(), theta_o.cos())
}

/// A node of the binary tree the build makes (and then collapses into
/// [`Quad`]s): a leaf holds one light, an interior node two children, the
/// first right after it.
#[derive(Debug, Clone, Copy)]
struct Node {
    bounds: LightBounds,
    /// A leaf's light (its selection index), or an interior node's second
    /// child.
    index: u32,
    leaf: bool,
}

/// In [`Quad::next`], the flag of a child that is a light (its selection
/// index in the other bits) rather than a node.
const LEAF: u32 = 1 << 31;

/// A node of the tree that sampling walks: up to four children, their
/// bounds stored lane by lane (structure of arrays), so that one pass of
/// 4-wide arithmetic gives all four importances, with a square root or a
/// division per step for all of them at once. The binary tree is collapsed
/// two levels at a time: a binary node's children, each replaced by its
/// own two children where it has them. A lane of power 0 is empty, and its
/// importance is 0. Everything a lane's importance needs that does not
/// depend on the shading point is precomputed: the box's centre, half its
/// diagonal's length, the squared radius of its bounding sphere and the
/// cone's sine.
#[derive(Debug, Clone, Copy)]
struct Quad {
    cx: Vec4,
    cy: Vec4,
    cz: Vec4,
    wx: Vec4,
    wy: Vec4,
    wz: Vec4,
    phi: Vec4,
    cos_o: Vec4,
    sin_o: Vec4,
    cos_e: Vec4,
    /// Half the box's diagonal length, pbrt's floor on the squared distance.
    half_diag: Vec4,
    /// The squared radius of the box's bounding sphere.
    r2: Vec4,
    /// 1 where the lane's lights emit on both sides of their normals.
    two_sided: Vec4,
    /// Per lane: a node's index, or [`LEAF`] with a light's selection index.
    next: [u32; 4],
}

impl Quad {
    const EMPTY: Quad = Quad {
        cx: Vec4::ZERO,
        cy: Vec4::ZERO,
        cz: Vec4::ZERO,
        wx: Vec4::ZERO,
        wy: Vec4::ZERO,
        wz: Vec4::ZERO,
        phi: Vec4::ZERO,
        cos_o: Vec4::ZERO,
        sin_o: Vec4::ZERO,
        cos_e: Vec4::ZERO,
        half_diag: Vec4::ZERO,
        r2: Vec4::ZERO,
        two_sided: Vec4::ZERO,
        next: [LEAF; 4],
    };

    /// Puts bounds `b` in lane `k`, leading to `next`.
    fn set(&mut self, k: usize, b: &LightBounds, next: u32) {
        let c = b.centroid();
        let diag = b.max - b.min;
        self.cx[k] = c.x;
        self.cy[k] = c.y;
        self.cz[k] = c.z;
        self.wx[k] = b.w.x;
        self.wy[k] = b.w.y;
        self.wz[k] = b.w.z;
        self.phi[k] = b.phi;
        self.cos_o[k] = b.cos_theta_o;
        self.sin_o[k] = safe_sqrt(1.0 - b.cos_theta_o * b.cos_theta_o);
        self.cos_e[k] = b.cos_theta_e;
        self.half_diag[k] = 0.5 * diag.length();
        self.r2[k] = 0.25 * diag.length_squared();
        self.two_sided[k] = if b.two_sided { 1.0 } else { 0.0 };
        self.next[k] = next;
    }

    /// The importance of each lane at `p` with normal `n` (see
    /// [`LightBounds::importance`]), lane by lane the same arithmetic as
    /// pbrt-v4's `LightBounds::Importance`.
    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> Vec4 {
        let one = Vec4::ONE;
        let sqrt0 = |x: Vec4| x.max(Vec4::ZERO).sqrt();
        // cos(max(0, a - b)) from sines and cosines
        let cos_sub = |sin_a: Vec4, cos_a: Vec4, sin_b: Vec4, cos_b: Vec4| {
            Vec4::select(cos_a.cmpgt(cos_b), one, cos_a * cos_b + sin_a * sin_b)
        };
        let (dx, dy, dz) = (
            Vec4::splat(p.x) - self.cx,
            Vec4::splat(p.y) - self.cy,
            Vec4::splat(p.z) - self.cz,
        );
        let dc2 = dx * dx + dy * dy + dz * dz;
        // clamped to half the diagonal's length, as pbrt does, so that a
        // point inside a large box does not see it as infinitely close
        let d2 = dc2.max(self.half_diag).max(Vec4::splat(f32::MIN_POSITIVE));
        // the unit direction from the centre to p (zero at the centre)
        let rcp = one / dc2.sqrt();
        let rcp = Vec4::select(
            rcp.cmplt(Vec4::INFINITY) & rcp.cmpgt(Vec4::ZERO),
            rcp,
            Vec4::ZERO,
        );
        let (wx, wy, wz) = (dx * rcp, dy * rcp, dz * rcp);
        let cos_w = self.wx * wx + self.wy * wy + self.wz * wz;
        let cos_w = Vec4::select(self.two_sided.cmpgt(Vec4::ZERO), cos_w.abs(), cos_w);
        let sin_w = sqrt0(one - cos_w * cos_w);
        // the cone of directions from p that the box's bounding sphere fills
        let cos_b = Vec4::select(
            dc2.cmplt(self.r2),
            Vec4::NEG_ONE,
            sqrt0(one - self.r2 / dc2),
        );
        let sin_b = sqrt0(one - cos_b * cos_b);
        let past_cone = cos_w.cmpgt(self.cos_o);
        let cos_x = Vec4::select(past_cone, one, cos_w * self.cos_o + sin_w * self.sin_o);
        let sin_x = Vec4::select(
            past_cone,
            Vec4::ZERO,
            sin_w * self.cos_o - cos_w * self.sin_o,
        );
        let cos_p = cos_sub(sin_x, cos_x, sin_b, cos_b);
        let mut importance = self.phi * cos_p / d2;
        if n != Vec3::ZERO {
            let cos_i = (wx * n.x + wy * n.y + wz * n.z).abs();
            let sin_i = sqrt0(one - cos_i * cos_i);
            importance *= cos_sub(sin_i, cos_i, sin_b, cos_b);
        }
        // NaN (from an empty lane or bad bounds) becomes 0 as well
        let importance = Vec4::select(importance.cmpgt(Vec4::ZERO), importance, Vec4::ZERO);
        Vec4::select(cos_p.cmpgt(self.cos_e), importance, Vec4::ZERO)
    }

    /// Each lane's probability at `(p, n)`, in proportion to its importance,
    /// or `None` when none can light it.
    #[inline]
    fn probabilities(&self, p: Vec3, n: Vec3) -> Option<[f32; 4]> {
        let imp = self.importance(p, n).to_array();
        let total = (imp[0] + imp[1]) + (imp[2] + imp[3]);
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        Some(imp.map(|x| x / total))
    }
}

/// The light BVH over a scene's lights, with the lights at infinity beside
/// it.
#[derive(Debug, Clone)]
pub struct LightBvh {
    /// The 4-wide tree, its root first; empty when no finite light has
    /// power.
    quads: Vec<Quad>,
    /// Selection indices of the lights at infinity.
    infinite: Vec<u32>,
    /// Per selection index: the light's trail in the tree (two bits per
    /// level, the lane taken there, from the low bits up), or `None` (at
    /// infinity, or no power).
    trail: Vec<Option<u64>>,
}

impl LightBvh {
    /// The tree over `lights` (selection index and bounds; lights of zero
    /// power are left out: they are never chosen), with `infinite` (the
    /// selection indices of the lights at infinity) chosen apart; `count`
    /// is the number of selection indices.
    pub fn new(lights: &[(u32, LightBounds)], infinite: Vec<u32>, count: usize) -> Self {
        let mut items: Vec<(u32, LightBounds)> = lights
            .iter()
            .copied()
            .filter(|(_, b)| b.phi > 0.0 && b.phi.is_finite())
            .collect();
        let mut bvh = LightBvh {
            quads: Vec::new(),
            infinite,
            trail: vec![None; count],
        };
        if !items.is_empty() {
            let mut nodes = Vec::with_capacity(2 * items.len());
            build(&mut nodes, &mut items, 0);
            bvh.quads.reserve(nodes.len() / 2 + 1);
            // the root's lanes: its children, or the one light itself
            let root = if nodes[0].leaf {
                vec![0]
            } else {
                children(&nodes, 0).to_vec()
            };
            bvh.collapse(&nodes, &root, 0, 0);
        }
        bvh
    }

    /// Appends the quad over binary nodes `lanes` (two to four, or the
    /// one leaf of a one-light tree), reached by `trail` at quad depth
    /// `depth`, and those below it; returns its index.
    fn collapse(&mut self, nodes: &[Node], lanes: &[usize], trail: u64, depth: u32) -> u32 {
        let at = self.quads.len();
        self.quads.push(Quad::EMPTY);
        for (k, &i) in lanes.iter().enumerate() {
            let node = &nodes[i];
            let trail = trail | ((k as u64) << (2 * depth));
            let next = if node.leaf {
                self.trail[node.index as usize] = Some(trail);
                LEAF | node.index
            } else {
                let mut below = Vec::with_capacity(4);
                for c in children(nodes, i) {
                    if nodes[c].leaf {
                        below.push(c);
                    } else {
                        below.extend(children(nodes, c));
                    }
                }
                self.collapse(nodes, &below, trail, depth + 1)
            };
            self.quads[at].set(k, &node.bounds, next);
        }
        at as u32
    }

    /// Whether nothing can be chosen.
    pub fn is_empty(&self) -> bool {
        self.quads.is_empty() && self.infinite.is_empty()
    }

    /// Probability of the tree (rather than a light at infinity).
    fn p_tree(&self) -> f32 {
        if self.quads.is_empty() {
            0.0
        } else {
            1.0 / (self.infinite.len() + 1) as f32
        }
    }

    /// Probability of each light at infinity.
    fn p_infinite_each(&self) -> f32 {
        if self.quads.is_empty() {
            1.0 / self.infinite.len() as f32
        } else {
            1.0 / (self.infinite.len() + 1) as f32
        }
    }

    /// Choose a light for the point `p` with normal `n` (zero: none) with
    /// `u` in `[0, 1)`: its selection index and probability, or `None` when
    /// no light can reach `p`.
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> Option<DiscreteSample> {
        let mut u = u;
        let n_inf = self.infinite.len();
        if n_inf > 0 {
            let p_inf = n_inf as f32 * self.p_infinite_each();
            if u < p_inf || self.quads.is_empty() {
                let k = ((u / p_inf * n_inf as f32) as usize).min(n_inf - 1);
                return Some(DiscreteSample {
                    index: self.infinite[k] as usize,
                    pmf: self.p_infinite_each(),
                });
            }
            u = ((u - p_inf) / (1.0 - p_inf)).min(ONE_MINUS_EPSILON);
        }
        if self.quads.is_empty() {
            return None;
        }
        let mut pmf = self.p_tree();
        let mut i = 0;
        loop {
            let quad = &self.quads[i];
            let prob = quad.probabilities(p, n)?;
            // the lane whose range of the running sum holds u; rounding can
            // leave u past the last sum, which takes the last lane that can
            // be chosen (one can: the sum is positive)
            let mut k = 0;
            let mut below = 0.0;
            while k < 3 && !(prob[k] > 0.0 && u < below + prob[k]) {
                below += prob[k];
                k += 1;
            }
            while !(prob[k] > 0.0) {
                k -= 1;
            }
            u = ((u - below).max(0.0) / prob[k]).min(ONE_MINUS_EPSILON);
            pmf *= prob[k];
            let next = quad.next[k];
            if next & LEAF != 0 {
                return Some(DiscreteSample {
                    index: (next & !LEAF) as usize,
                    pmf,
                });
            }
            i = next as usize;
        }
    }

    /// Probability that [`LightBvh::sample`] at `(p, n)` chooses the light
    /// with selection index `light`: the same factors, retraced along its
    /// trail.
    pub fn pmf(&self, p: Vec3, n: Vec3, light: usize) -> f32 {
        if self.infinite.iter().any(|&k| k as usize == light) {
            return self.p_infinite_each();
        }
        let Some(Some(trail)) = self.trail.get(light).copied() else {
            return 0.0;
        };
        let mut pmf = self.p_tree();
        let mut i = 0;
        let mut depth = 0;
        loop {
            let quad = &self.quads[i];
            let Some(prob) = quad.probabilities(p, n) else {
                return 0.0;
            };
            let k = ((trail >> (2 * depth)) & 3) as usize;
            pmf *= prob[k];
            let next = quad.next[k];
            if next & LEAF != 0 {
                return pmf;
            }
            i = next as usize;
            depth += 1;
        }
    }

    /// The number of 4-wide nodes.
    pub fn node_count(&self) -> usize {
        self.quads.len()
    }
}

/// The two children of binary interior node `i`.
fn children(nodes: &[Node], i: usize) -> [usize; 2] {
    [i + 1, nodes[i].index as usize]
}

/// Builds the binary subtree over `items` at `depth` into `nodes`; returns
/// its node index.
fn build(nodes: &mut Vec<Node>, items: &mut [(u32, LightBounds)], depth: u32) -> usize {
    let at = nodes.len();
    if items.len() == 1 {
        let (light, bounds) = items[0];
        nodes.push(Node {
            bounds,
            index: light,
            leaf: true,
        });
        return at;
    }
    let bounds = items[1..]
        .iter()
        .fold(items[0].1, |acc, (_, b)| acc.union(b));
    let (mut cmin, mut cmax) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (_, b) in items.iter() {
        cmin = cmin.min(b.centroid());
        cmax = cmax.max(b.centroid());
    }
    let extent = bounds.max - bounds.min;
    let bucket_of = |c: Vec3, dim: usize| -> usize {
        let t = (c[dim] - cmin[dim]) / (cmax[dim] - cmin[dim]);
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    // the cheapest split over every axis and bucket boundary
    let mut best: Option<(f64, usize, usize)> = None;
    if depth < BALANCED_FROM_DEPTH {
        for dim in 0..3 {
            if !(cmax[dim] > cmin[dim]) {
                continue;
            }
            let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
            for (_, b) in items.iter() {
                let k = bucket_of(b.centroid(), dim);
                buckets[k] = Some(buckets[k].map_or(*b, |x| x.union(b)));
            }
            for split in 1..BUCKETS {
                let side = |r: std::ops::Range<usize>| {
                    buckets[r]
                        .iter()
                        .flatten()
                        .fold(None::<LightBounds>, |acc, b| {
                            Some(acc.map_or(*b, |a| a.union(b)))
                        })
                };
                let (Some(lo), Some(hi)) = (side(0..split), side(split..BUCKETS)) else {
                    continue;
                };
                let cost = lo.cost(extent, dim) + hi.cost(extent, dim);
                if best.is_none_or(|(c, ..)| cost < c) {
                    best = Some((cost, dim, split));
                }
            }
        }
    }
    let mut mid = match best {
        Some((_, dim, split)) => {
            // stable partition: the order below the split is kept
            let (lo, hi): (Vec<_>, Vec<_>) = items
                .iter()
                .partition(|(_, b)| bucket_of(b.centroid(), dim) < split);
            let n = lo.len();
            for (slot, item) in items.iter_mut().zip(lo.into_iter().chain(hi)) {
                *slot = item;
            }
            n
        }
        None => items.len() / 2,
    };
    if mid == 0 || mid == items.len() {
        mid = items.len() / 2;
    }
    nodes.push(Node {
        bounds,
        index: 0,
        leaf: false,
    });
    let (lo, hi) = items.split_at_mut(mid);
    build(nodes, lo, depth + 1);
    let second = build(nodes, hi, depth + 1);
    nodes[at].index = second as u32;
    at
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(p: Vec3, phi: f32) -> LightBounds {
        LightBounds {
            min: p,
            max: p,
            w: Vec3::Z,
            phi,
            cos_theta_o: -1.0,
            cos_theta_e: 0.0,
            two_sided: false,
        }
    }

    #[test]
    fn a_one_sided_emitter_has_no_importance_behind_it() {
        let tri = LightBounds {
            min: Vec3::new(-1.0, -1.0, 0.0),
            max: Vec3::new(1.0, 1.0, 0.0),
            w: Vec3::Z,
            phi: 1.0,
            cos_theta_o: 1.0,
            cos_theta_e: 0.0,
            two_sided: false,
        };
        assert!(tri.importance(Vec3::new(0.0, 0.0, 3.0), Vec3::Z) > 0.0);
        assert_eq!(tri.importance(Vec3::new(0.0, 0.0, -3.0), Vec3::Z), 0.0);
        let two = LightBounds {
            two_sided: true,
            ..tri
        };
        assert!(two.importance(Vec3::new(0.0, 0.0, -3.0), Vec3::Z) > 0.0);
        // a point light: inverse square
        let pl = point(Vec3::ZERO, 1.0);
        let a = pl.importance(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO);
        let b = pl.importance(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO);
        assert!((a / b - 4.0).abs() < 1e-5);
    }

    /// Trees of one to five lights (a root of one, two, three and four
    /// lanes, and one a level deeper): a light no point can see behind it
    /// is never chosen there, every u chooses a light whose pmf the sample
    /// carries, and the pmfs sum to 1.
    #[test]
    fn small_trees_choose_every_light_they_should() {
        let facing_up = |x: f32| LightBounds {
            min: Vec3::new(x, 0.0, 0.0),
            max: Vec3::new(x + 0.5, 0.5, 0.0),
            w: Vec3::Z,
            phi: 1.0 + x,
            cos_theta_o: 1.0,
            cos_theta_e: 0.0,
            two_sided: false,
        };
        for count in 1..=5u32 {
            let lights: Vec<_> = (0..count).map(|i| (i, facing_up(i as f32))).collect();
            let bvh = LightBvh::new(&lights, vec![], count as usize);
            let above = Vec3::new(1.0, 0.2, 2.0);
            let sum: f32 = (0..count as usize)
                .map(|k| bvh.pmf(above, Vec3::ZERO, k))
                .sum();
            assert!((sum - 1.0).abs() < 1e-6, "{count} lights: {sum}");
            let mut seen = vec![false; count as usize];
            for j in 0..4096 {
                let u = (j as f32 + 0.5) / 4096.0;
                let s = bvh.sample(above, Vec3::ZERO, u).expect("a light");
                assert_eq!(s.pmf, bvh.pmf(above, Vec3::ZERO, s.index));
                seen[s.index] = true;
            }
            assert!(seen.iter().all(|&x| x), "{count} lights: {seen:?}");
            // below the lights, which face up, nothing can be lit
            let below = Vec3::new(1.0, 0.2, -2.0);
            assert!(bvh.sample(below, Vec3::ZERO, 0.5).is_none());
            assert_eq!(bvh.pmf(below, Vec3::ZERO, 0), 0.0);
        }
    }

    #[test]
    fn cone_union_holds_both_cones() {
        let (w, c) = cone_union(Vec3::X, 1.0, Vec3::Y, 1.0);
        assert!((c - std::f32::consts::FRAC_PI_4.cos()).abs() < 1e-6);
        assert!((w - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        assert_eq!(cone_union(Vec3::X, 0.5, Vec3::X, 0.9), (Vec3::X, 0.5));
        assert_eq!(cone_union(Vec3::X, 1.0, -Vec3::X, 1.0).1, -1.0);
    }

    #[test]
    fn pmfs_sum_to_one_and_match_the_sampler() {
        let lights: Vec<(u32, LightBounds)> = (0..37)
            .map(|i| {
                let f = i as f32;
                (
                    i,
                    point(
                        Vec3::new((f * 1.7).sin() * 5.0, (f * 0.3).cos(), f * 0.1),
                        1.0 + (i % 5) as f32,
                    ),
                )
            })
            .collect();
        let bvh = LightBvh::new(&lights, vec![37, 38], 39);
        for p in [Vec3::ZERO, Vec3::new(3.0, -2.0, 1.0), Vec3::splat(40.0)] {
            let sum: f64 = (0..39).map(|k| bvh.pmf(p, Vec3::Y, k) as f64).sum();
            assert!((sum - 1.0).abs() < 1e-5, "{sum}");
            for j in 0..1000 {
                let u = (j as f32 + 0.5) / 1000.0;
                let s = bvh.sample(p, Vec3::Y, u).unwrap();
                assert_eq!(s.pmf, bvh.pmf(p, Vec3::Y, s.index));
            }
        }
    }
}
