//! Analytic spheres: the one ray-sphere routine every backend calls (the
//! naive and BVH backends directly, Embree through a user-geometry callback),
//! so all of them report the same `t`, bit for bit; and [`SphereSet`], a
//! small binary BVH over sphere bounds for the pure-Rust backends.
//!
//! The routine follows Haines, Guenther and Akenine-Moeller, "Precision
//! Improvements for Ray/Sphere Intersection" (Ray Tracing Gems, 2019,
//! chapter 7), computed in `f64`. With `f = o - c` and a unit direction `d`,
//! the roots of `t^2 - 2 b t + c' = 0` (`b = -f.d`, `c' = |f|^2 - r^2`) are
//! `b +- sqrt(disc)`. The discriminant is taken as `r^2 - |f + b d|^2` (the
//! squared distance from the centre to the line, subtracted from `r^2`),
//! not `b^2 - c'`, which cancels catastrophically for a small sphere far
//! away; and the roots as `q = b + sign(b) sqrt(disc)` and `c' / q`, so
//! neither subtracts nearly equal numbers.
//!
//! Self-intersection: shading rebuilds a hit point as
//! `c + r normalize(o + t d - c)` with an error bound of
//! `gamma(5) (|c| + r)` per axis ([`crate::math::SurfacePoint::on_sphere`]),
//! and spawned rays start past that bound along the normal. In `f64` the
//! routine's own error on a root near the origin is a few `f64` ulps of
//! `|f|^2 / r`, far below that offset, so a ray leaving a sphere outwards
//! never sees it again at a tiny `t` (its near root is at about minus the
//! offset), and a ray leaving inwards finds the far side at about
//! `2 r cos`, never the near side (tested in `tests/conformance.rs`).

use crate::math::{Ray, Vec3};
use crate::shape::Sphere;

/// The nearest `t` in `(0, t_max]` where `o + t d` (with `|d| = 1`) meets
/// sphere `s`, or `None`. Non-finite input and radii that are not positive
/// never hit.
#[inline]
pub fn intersect_sphere(o: Vec3, d: Vec3, t_max: f32, s: &Sphere) -> Option<f32> {
    let (o, d, c) = (o.as_dvec3(), d.as_dvec3(), s.center.as_dvec3());
    let r = s.radius as f64;
    let f = o - c;
    let b = -f.dot(d);
    let r2 = r * r;
    let l = f + b * d;
    let disc = r2 - l.dot(l);
    // NaN fails both comparisons below, so non-finite input never hits
    if !(disc >= 0.0) || !(r > 0.0) {
        return None;
    }
    let q = b + b.signum() * disc.sqrt();
    if q == 0.0 {
        return None;
    }
    let cc = f.dot(f) - r2;
    let (t0, t1) = (cc / q, q);
    let (near, far) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    let t_max = t_max as f64;
    for t in [near, far] {
        let tf = t as f32;
        if tf > 0.0 && (tf as f64) <= t_max {
            return Some(tf);
        }
    }
    None
}

/// Bounds of sphere `s` (`min`, `max`), padded outwards by a relative
/// `1e-6` so that rounding never puts a surface point outside them.
pub fn sphere_bounds(s: &Sphere) -> (Vec3, Vec3) {
    let pad = s.radius + 1e-6 * (s.center.abs().max_element() + s.radius);
    (s.center - Vec3::splat(pad), s.center + Vec3::splat(pad))
}

/// A node of [`SphereSet`]: a box and either two children or a range of
/// spheres.
#[derive(Debug, Clone, Copy)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Inner node: index of the first child (the second follows it).
    /// Leaf: first sphere (into `order`).
    first: u32,
    /// 0 for an inner node, else the number of spheres in the leaf.
    count: u32,
}

/// Spheres in a binary BVH (median splits on the longest axis of the
/// centres' bounds, leaves of at most [`SphereSet::LEAF`] spheres). Scenes
/// have few spheres next to their triangles, so this stays simple. Sphere
/// `i` is reported as primitive `base + i`.
#[derive(Debug, Clone, Default)]
pub struct SphereSet {
    spheres: Vec<Sphere>,
    /// Sphere indices in leaf order.
    order: Vec<u32>,
    nodes: Vec<Node>,
    base: u32,
}

/// Depth bound of the median-split tree: `2^32` spheres need 32 levels.
const STACK: usize = 64;

impl SphereSet {
    /// Spheres per leaf at most.
    pub const LEAF: usize = 4;

    /// The set of `spheres`, numbered from primitive `base`.
    pub fn new(spheres: &[Sphere], base: u32) -> Self {
        let mut set = SphereSet {
            spheres: spheres.to_vec(),
            order: (0..spheres.len() as u32).collect(),
            nodes: Vec::new(),
            base,
        };
        if !spheres.is_empty() {
            set.nodes.push(Node {
                min: Vec3::ZERO,
                max: Vec3::ZERO,
                first: 0,
                count: 0,
            });
            set.build(0, 0, spheres.len());
        }
        set
    }

    /// Fill node `n` over `order[lo..hi]`.
    fn build(&mut self, n: usize, lo: usize, hi: usize) {
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let (mut cmin, mut cmax) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &i in &self.order[lo..hi] {
            let s = &self.spheres[i as usize];
            let (a, b) = sphere_bounds(s);
            min = min.min(a);
            max = max.max(b);
            cmin = cmin.min(s.center);
            cmax = cmax.max(s.center);
        }
        self.nodes[n].min = min;
        self.nodes[n].max = max;
        if hi - lo <= Self::LEAF {
            self.nodes[n].first = lo as u32;
            self.nodes[n].count = (hi - lo) as u32;
            return;
        }
        let axis = super::longest_axis(cmax - cmin);
        let mid = (lo + hi) / 2;
        let spheres = &self.spheres;
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |a, b| {
            let (ca, cb) = (
                spheres[*a as usize].center[axis],
                spheres[*b as usize].center[axis],
            );
            ca.total_cmp(&cb).then(a.cmp(b))
        });
        let left = self.nodes.len();
        let blank = self.nodes[n];
        self.nodes.push(blank);
        self.nodes.push(blank);
        self.nodes[n].first = left as u32;
        self.nodes[n].count = 0;
        self.build(left, lo, mid);
        self.build(left + 1, mid, hi);
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty()
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.spheres.capacity() * std::mem::size_of::<Sphere>()
            + self.order.capacity() * 4
            + self.nodes.capacity() * std::mem::size_of::<Node>()
    }

    /// Visit the spheres whose node boxes `ray` may cross before `t_max()`,
    /// calling `f(sphere index)`; `f` returns `true` to stop.
    #[inline]
    fn visit(&self, ray: &Ray, t_max: impl Fn() -> f32, mut f: impl FnMut(u32) -> bool) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = ray.d.recip();
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            // slab test, widened by a relative ulp bound so that rounding
            // never drops a box the routine would hit
            let t0 = (node.min - ray.o) * inv;
            let t1 = (node.max - ray.o) * inv;
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0.max(t1).min_element() * (1.0 + 4.0 * f32::EPSILON);
            if !(near <= far.min(t_max())) {
                continue;
            }
            if node.count > 0 {
                for k in node.first..node.first + node.count {
                    if f(self.order[k as usize]) {
                        return;
                    }
                }
            } else if top + 2 <= STACK {
                stack[top] = node.first;
                stack[top + 1] = node.first + 1;
                top += 2;
            }
        }
    }

    /// Lower the closest hit `best` (whose `t` bounds the search, `t_max`
    /// when `None`) with the spheres; ties in `t` keep the lower primitive.
    pub fn closest(&self, ray: &Ray, best: &mut Option<(f32, u32)>) {
        let cell = std::cell::Cell::new(*best);
        self.visit(
            ray,
            || cell.get().map_or(ray.t_max, |b| b.0),
            |i| {
                let t_max = cell.get().map_or(ray.t_max, |b| b.0);
                if let Some(t) = intersect_sphere(ray.o, ray.d, t_max, &self.spheres[i as usize]) {
                    let prim = self.base + i;
                    let better = match cell.get() {
                        None => true,
                        Some((bt, bp)) => t < bt || (t == bt && prim < bp),
                    };
                    if better {
                        cell.set(Some((t, prim)));
                    }
                }
                false
            },
        );
        *best = cell.get();
    }

    /// Whether any sphere is hit in `(0, ray.t_max]`.
    pub fn any(&self, ray: &Ray) -> bool {
        let mut hit = false;
        self.visit(
            ray,
            || ray.t_max,
            |i| {
                hit =
                    intersect_sphere(ray.o, ray.d, ray.t_max, &self.spheres[i as usize]).is_some();
                hit
            },
        );
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_from_outside_inside_and_misses() {
        let s = Sphere {
            center: Vec3::new(0.0, 0.0, -5.0),
            radius: 1.0,
        };
        assert_eq!(intersect_sphere(Vec3::ZERO, -Vec3::Z, 100.0, &s), Some(4.0));
        assert_eq!(intersect_sphere(Vec3::ZERO, -Vec3::Z, 3.9, &s), None);
        assert_eq!(
            intersect_sphere(Vec3::new(0.0, 0.0, -5.0), Vec3::X, 100.0, &s),
            Some(1.0)
        );
        assert_eq!(intersect_sphere(Vec3::ZERO, Vec3::Z, 100.0, &s), None);
        assert_eq!(
            intersect_sphere(Vec3::new(2.0, 0.0, 0.0), -Vec3::Z, 100.0, &s),
            None
        );
        let bad = Sphere {
            center: Vec3::new(f32::NAN, 0.0, 0.0),
            radius: 1.0,
        };
        assert_eq!(intersect_sphere(Vec3::ZERO, Vec3::X, 100.0, &bad), None);
        let flat = Sphere {
            center: Vec3::X,
            radius: 0.0,
        };
        assert_eq!(intersect_sphere(Vec3::ZERO, Vec3::X, 100.0, &flat), None);
    }

    #[test]
    fn a_tiny_sphere_far_away_keeps_its_precision() {
        // b^2 - c' would cancel to nothing here
        let s = Sphere {
            center: Vec3::new(0.0, 0.0, -1.0e4),
            radius: 1.0e-3,
        };
        let t = intersect_sphere(Vec3::ZERO, -Vec3::Z, f32::MAX, &s).unwrap();
        assert!(
            (t - (1.0e4 - 1.0e-3)).abs() <= 1e-3 * f32::EPSILON * 1e4,
            "{t}"
        );
    }

    #[test]
    fn the_tree_agrees_with_a_linear_scan() {
        let mut spheres = Vec::new();
        let mut x = 0x1234_5678u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32) * 2.0 - 1.0
        };
        for _ in 0..300 {
            spheres.push(Sphere {
                center: Vec3::new(next(), next(), next()) * 10.0,
                radius: 0.1 + 0.5 * next().abs(),
            });
        }
        let set = SphereSet::new(&spheres, 7);
        for _ in 0..2000 {
            let o = Vec3::new(next(), next(), next()) * 12.0;
            let d = Vec3::new(next(), next(), next()).normalize();
            let ray = Ray::new(o, d);
            let mut linear: Option<(f32, u32)> = None;
            for (i, s) in spheres.iter().enumerate() {
                if let Some(t) = intersect_sphere(o, d, ray.t_max, s) {
                    if linear.is_none_or(|b| t < b.0) {
                        linear = Some((t, 7 + i as u32));
                    }
                }
            }
            let mut tree = None;
            set.closest(&ray, &mut tree);
            assert_eq!(tree, linear);
            assert_eq!(set.any(&ray), linear.is_some());
        }
    }
}
