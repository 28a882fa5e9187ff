//! BVH traversal: a closest-hit loop that visits children near-first (sorted
//! by entry distance) and an any-hit loop for occlusion that descends into
//! the nearest child first, both over a fixed-size stack on the call stack
//! (no allocation per ray).
//!
//! The slab test (Kay and Kajiya, "Ray Tracing Complex Scenes", SIGGRAPH
//! 1986; Williams et al., "An Efficient and Robust Ray-Box Intersection
//! Algorithm", JGT 2005) tests the child boxes of a node four at a time, with
//! the robustness measures of Ize ("Robust BVH Ray Traversal", JCGT 2(2),
//! 2013) and pbrt-v4 (section 6.8.2), so that no box holding a triangle the
//! watertight test would report is ever culled:
//!
//! - the near and far planes of each axis are chosen by the sign of the
//!   direction, so `1 / 0 = +-inf` needs no special case;
//! - `0 * inf = NaN` (a ray parallel to a slab with its origin on a plane)
//!   must impose no constraint: the running maxima and minima are
//!   `if t > t0 { t } else { t0 }`, which keeps `t0` when `t` is NaN (SSE's
//!   `maxps` and `minps`, see [`nan_keeps_max`]);
//! - the far distance is enlarged by `1 + 2 gamma(4)` (pbrt-v4 uses
//!   `gamma(3)`; one more covers the leaf test's rounding of `t`, below):
//!   rounding can neither cull a box the ray touches nor a box whose entry
//!   equals the best `t` so far (the tie rule needs those);
//! - boxes are culled against the best `t` (or `t_max`) by their near plane
//!   on the leaf test's distance axis only, see [`SlabRay::test`];
//! - every box is padded, per ray, by the rounding error of the watertight
//!   test's sheared vertex coordinates (Woop et al. 2013, section 4; bounded
//!   as in pbrt-v4 section 6.8.4): that test can report a hit for a ray that
//!   passes beside a triangle by up to that error, which must not be lost
//!   when the triangle's edge lies on its box's face. The padding costs
//!   nothing per node: it moves the origin used for near and far planes.
//!
//! Leaves use the naive backend's routine on the same `f32` corners, four
//! triangles at a time ([`WatertightRay::intersect4`]), and the same tie
//! rule ([`Hits4::fold_closest`](crate::accel::triangle::Hits4::fold_closest)):
//! a hit at the same `t` as the best so far replaces it only if its original
//! index is lower.

use super::node::{Aabb, ChildRef, Node, WIDTH};
use super::{Bvh, STACK_SIZE};
use crate::accel::triangle::WatertightRay;
use crate::accel::{Hit, HitFilter};
use crate::math::{Ray, Vec3, next_float_down, next_float_up};
use glam::Vec4;

const _: () = assert!(
    WIDTH % 4 == 0,
    "the slab test takes children four at a time"
);

/// `1 + 2 gamma(4)`: the relative enlargement of far distances.
const WIDEN: f32 = {
    let g4 = 4.0 * (f32::EPSILON * 0.5) / (1.0 - 4.0 * (f32::EPSILON * 0.5));
    1.0 + 2.0 * g4
};

/// `gamma(16)`: the box padding's factor on the ray's distance to the scene.
const PAD_GAMMA: f32 = 16.0 * (f32::EPSILON * 0.5) / (1.0 - 16.0 * (f32::EPSILON * 0.5));

/// A ray prepared for the slab test, every per-axis value splatted over the
/// four lanes of a node.
#[derive(Debug, Clone, Copy)]
struct SlabRay {
    /// Origin used with the near plane of each axis (padded outwards).
    o_near: [Vec4; 3],
    /// Origin used with the far plane of each axis (padded outwards).
    o_far: [Vec4; 3],
    /// Reciprocal direction.
    inv: [Vec4; 3],
    /// Index in [`Node::planes`] of each axis's near plane (`a` when the
    /// direction's component is positive, `3 + a` when negative, `-0`
    /// included), and of its far plane.
    near: [usize; 3],
    far: [usize; 3],
    /// The triangle test's distance axis ([`WatertightRay::kz`]).
    kz: usize,
}

impl SlabRay {
    /// Prepare `ray` for a BVH whose triangles lie in `scene`.
    #[inline]
    fn new(ray: &Ray, wr: &WatertightRay, scene: &Aabb) -> Self {
        let inv = ray.d.recip();
        // Every vertex p satisfies |p - o| <= s componentwise; the sheared
        // coordinates of the watertight test are off by at most about
        // gamma(5) (|x| + |z|) of those, and the edge functions by a few
        // ulps more: pad by gamma(16) of the sum, at least one ulp.
        let (lo, hi) = (Vec3::from(scene.min), Vec3::from(scene.max));
        let s = (lo - ray.o).abs().max((hi - ray.o).abs());
        let pad = PAD_GAMMA * (s.x + s.y + s.z);
        let lo = (ray.o - Vec3::splat(pad)).to_array().map(next_float_down);
        let hi = (ray.o + Vec3::splat(pad)).to_array().map(next_float_up);
        let inv = inv.to_array();
        let neg = inv.map(|x| x.is_sign_negative());
        // d >= 0: near plane min - (o + pad), far plane max - (o - pad);
        // d < 0: near plane max - (o - pad), far plane min - (o + pad)
        let pick = |a: usize, near: bool| Vec4::splat(if neg[a] == near { lo[a] } else { hi[a] });
        let plane = |a: usize, near: bool| if neg[a] == near { 3 + a } else { a };
        SlabRay {
            o_near: [pick(0, true), pick(1, true), pick(2, true)],
            o_far: [pick(0, false), pick(1, false), pick(2, false)],
            inv: inv.map(Vec4::splat),
            near: [plane(0, true), plane(1, true), plane(2, true)],
            far: [plane(0, false), plane(1, false), plane(2, false)],
            kz: wr.kz(),
        }
    }

    /// Test the ray against the node's four (padded) boxes. Returns, per
    /// child, the entry distance (for near-first ordering) and the cull key
    /// (the distance to the box's near plane on the triangle test's axis
    /// `kz`), and the mask of children to visit: those whose box the ray
    /// crosses at some `t >= 0` and whose cull key is at most `t_max`
    /// (widened).
    ///
    /// Why cull on `kz` alone: the watertight test's `t` is a convex
    /// combination of the corners' `kz` distances, so it cannot be less than
    /// the box's near `kz` distance, whereas for a large, thin triangle seen
    /// from far away it can be well below the ray's true entry into its box
    /// (relative errors of 1e-4 were observed). Culling on the full entry
    /// distance would then skip a hit the naive backend reports.
    #[inline(always)]
    fn test(&self, node: &Node, t_max: f32) -> ([f32; WIDTH], [f32; WIDTH], u32) {
        let mut entry = [0.0; WIDTH];
        let mut keys = [0.0; WIDTH];
        let mut mask = 0;
        let cull = Vec4::splat(t_max * WIDEN);
        // four children at a time
        for g in 0..WIDTH / 4 {
            let lanes = g * 4..g * 4 + 4;
            let plane = |p: usize| Vec4::from_slice(&node.planes[p][lanes.clone()]);
            let mut t0 = Vec4::ZERO;
            let mut t1 = Vec4::INFINITY;
            let mut tn = [Vec4::ZERO; 3];
            for (a, tn) in tn.iter_mut().enumerate() {
                *tn = (plane(self.near[a]) - self.o_near[a]) * self.inv[a];
                let tf = (plane(self.far[a]) - self.o_far[a]) * self.inv[a];
                (t0, t1) = (nan_keeps_max(*tn, t0), nan_keeps_min(tf, t1));
            }
            let key = tn[self.kz];
            let enter = t0.cmple(t1 * Vec4::splat(WIDEN));
            mask |= (enter & key.cmple(cull)).bitmask() << (g * 4);
            t0.write_to_slice(&mut entry[lanes.clone()]);
            key.write_to_slice(&mut keys[lanes]);
        }
        (entry, keys, mask)
    }
}

/// `max(a, b)` that returns `b` when `a` is NaN (0 * inf: a ray parallel
/// to a slab with its origin on a plane), so such an axis imposes no
/// constraint on the running bound `b`, which is never NaN. On x86 this is
/// SSE's `maxps` (`a > b ? a : b`), which glam's `max` is; elsewhere a
/// select, as glam's other backends may propagate NaN.
#[inline(always)]
fn nan_keeps_max(a: Vec4, b: Vec4) -> Vec4 {
    if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
        a.max(b)
    } else {
        Vec4::select(a.cmpgt(b), a, b)
    }
}

/// `min(a, b)` that returns `b` when `a` is NaN; see [`nan_keeps_max`].
#[inline(always)]
fn nan_keeps_min(a: Vec4, b: Vec4) -> Vec4 {
    if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
        a.min(b)
    } else {
        Vec4::select(a.cmplt(b), a, b)
    }
}

/// A deferred child: its reference and cull key.
#[derive(Debug, Clone, Copy)]
struct Entry {
    child: ChildRef,
    key: f32,
}

impl Bvh {
    /// The closest hit with `0 < t <= ray.t_max`; equal `t` goes to the
    /// lowest original index.
    ///
    /// `filter` decides which triangle hits count (see [`HitFilter`]).
    #[inline(always)]
    pub(crate) fn closest_hit<F: HitFilter>(&self, ray: &Ray, filter: &F) -> Option<Hit> {
        let mut cur = self.root?;
        if !ray.is_finite() {
            return None;
        }
        let wr = WatertightRay::new(ray);
        let sr = SlabRay::new(ray, &wr, &self.bounds);
        let (nodes, blocks) = (self.nodes.as_slice(), self.blocks.as_slice());
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        let mut stack = [Entry {
            child: ChildRef(0),
            key: 0.0,
        }; STACK_SIZE];
        let mut sp = 0;
        loop {
            if !cur.is_leaf() {
                let node = &nodes[cur.index()];
                let (t, key, mask) = sr.test(node, t_max);
                if mask != 0 {
                    let first = mask.trailing_zeros() as usize;
                    let rest = mask & (mask - 1);
                    if rest == 0 {
                        // one child: descend without touching the stack
                        cur = node.child[first];
                        continue;
                    }
                    if rest & (rest - 1) == 0 {
                        // two: descend into the nearer, push the farther
                        let second = rest.trailing_zeros() as usize;
                        let (near, far) = if t[second] < t[first] {
                            (second, first)
                        } else {
                            (first, second)
                        };
                        stack[sp] = Entry {
                            child: node.child[far],
                            key: key[far],
                        };
                        sp += 1;
                        cur = node.child[near];
                        continue;
                    }
                    // more: sort by entry distance, push all but the nearest,
                    // far ones first
                    let mut order = [0u64; WIDTH];
                    let mut n = 0;
                    let mut m = mask;
                    while m != 0 {
                        let k = m.trailing_zeros() as usize;
                        m &= m - 1;
                        // t >= 0, so its bits order like its value
                        let ok = (t[k].to_bits() as u64) << 32 | k as u64;
                        let mut j = n;
                        while j > 0 && order[j - 1] < ok {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = ok;
                        n += 1;
                    }
                    // order descend: the nearest is last
                    for &ok in &order[..n - 1] {
                        let k = ok as u32 as usize;
                        stack[sp] = Entry {
                            child: node.child[k],
                            key: key[k],
                        };
                        sp += 1;
                    }
                    cur = node.child[order[n - 1] as u32 as usize];
                    continue;
                }
            } else {
                // every block of a leaf is full but the last; their loads
                // do not depend on each other
                let (first, n) = (cur.block(), cur.blocks());
                for (k, block) in blocks[first..first + n].iter().enumerate() {
                    let lanes = if k + 1 == n { cur.last_lanes() } else { 0b1111 };
                    wr.intersect4(block, lanes, t_max)
                        .fold_closest(block, &mut best, &mut t_max, filter);
                }
            }
            // pop the next child the ray can still reach before t_max
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let e = stack[sp];
                if e.key <= t_max * WIDEN {
                    cur = e.child;
                    break;
                }
            }
        }
    }

    /// Whether any hit exists with `0 < t <= ray.t_max`.
    #[inline(always)]
    pub(crate) fn any_hit<F: HitFilter>(&self, ray: &Ray, filter: &F) -> bool {
        let Some(mut cur) = self.root else {
            return false;
        };
        if !ray.is_finite() {
            return false;
        }
        let wr = WatertightRay::new(ray);
        let sr = SlabRay::new(ray, &wr, &self.bounds);
        let (nodes, blocks) = (self.nodes.as_slice(), self.blocks.as_slice());
        let t_max = ray.t_max;
        let mut stack = [ChildRef(0); STACK_SIZE];
        let mut sp = 0;
        loop {
            if !cur.is_leaf() {
                let node = &nodes[cur.index()];
                let (t, _, mask) = sr.test(node, t_max);
                if mask != 0 {
                    // descend into the nearest child (an occluder near the
                    // origin is found sooner), push the others
                    let mut near = mask.trailing_zeros() as usize;
                    let mut m = mask & (mask - 1);
                    while m != 0 {
                        let k = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let other = if t[k] < t[near] {
                            std::mem::replace(&mut near, k)
                        } else {
                            k
                        };
                        stack[sp] = node.child[other];
                        sp += 1;
                    }
                    cur = node.child[near];
                    continue;
                }
            } else {
                let (first, n) = (cur.block(), cur.blocks());
                for (k, block) in blocks[first..first + n].iter().enumerate() {
                    let lanes = if k + 1 == n { cur.last_lanes() } else { 0b1111 };
                    if wr.intersect4(block, lanes, t_max).any_kept(block, filter) {
                        return true;
                    }
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            cur = stack[sp];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    /// A node holding the unit cube in slot 0 (the other slots empty), and
    /// the slab test's mask and entry for `ray`.
    fn unit_cube(ray: Ray) -> (bool, f32, f32) {
        let cube = Aabb {
            min: Vec3A::ZERO,
            max: Vec3A::ONE,
        };
        let mut node = Node::EMPTY;
        node.set(0, &cube, ChildRef::leaf(0, 1));
        let wr = WatertightRay::new(&ray);
        let (t, key, mask) = SlabRay::new(&ray, &wr, &cube).test(&node, ray.t_max);
        assert_eq!(mask & !1, 0, "an empty slot was hit by {ray:?}");
        (mask == 1, t[0], key[0])
    }

    #[test]
    fn axis_parallel_rays_on_slab_planes_enter_the_box() {
        for y in [0.0, 1.0] {
            for z in [0.0, 0.5, 1.0] {
                // 1 / d = inf on y and z, origin exactly on their planes
                let (hit, t, _) = unit_cube(Ray::new(Vec3::new(-1.0, y, z), Vec3::X));
                assert!(hit && (t - 1.0).abs() < 1e-5, "y {y} z {z}");
                let (hit, _, _) = unit_cube(Ray::new(Vec3::new(2.0, y, z), -Vec3::X));
                assert!(hit, "y {y} z {z}, backwards");
                let d = Vec3::new(1.0, -0.0, 0.0);
                assert!(unit_cube(Ray::new(Vec3::new(-1.0, y, z), d)).0);
            }
        }
        // parallel but outside the slab
        assert!(!unit_cube(Ray::new(Vec3::new(-1.0, -1e-3, 0.5), Vec3::X)).0);
        assert!(!unit_cube(Ray::new(Vec3::new(-1.0, 1.001, 0.5), Vec3::X)).0);
    }

    #[test]
    fn rays_inside_behind_and_beyond() {
        let (hit, t, _) = unit_cube(Ray::new(
            Vec3::splat(0.5),
            Vec3::new(0.3, -0.4, 0.5).normalize(),
        ));
        assert!(hit && t == 0.0, "starting inside enters at 0");
        assert!(
            !unit_cube(Ray::new(Vec3::new(2.0, 0.5, 0.5), Vec3::X)).0,
            "behind"
        );
        let r = Ray {
            t_max: 0.9,
            ..Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X)
        };
        assert!(!unit_cube(r).0, "beyond t_max");
        // a box whose near plane is exactly at t_max stays (ties need it)
        assert!(unit_cube(Ray { t_max: 1.0, ..r }).0);
        // grazing a face at a tiny angle
        let d = Vec3::new(1.0, 1e-7, 0.0).normalize();
        assert!(unit_cube(Ray::new(Vec3::new(-1.0, 1.0 - 1e-8, 0.5), d)).0);
    }

    #[test]
    fn cull_key_is_the_near_plane_on_the_distance_axis() {
        // kz = x; the ray enters through the y face at t = 2 but the box's
        // x range starts at t = 1: the key is the lower of the two
        let r = Ray::new(
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(1.0, 0.5, 0.0).normalize(),
        );
        let (hit, t, key) = unit_cube(r);
        let s = 1.25f32.sqrt();
        assert!(hit && (t - 2.0 * s).abs() < 1e-5 && (key - s).abs() < 1e-5);
    }

    #[test]
    fn a_nan_lane_leaves_the_running_bound_alone() {
        let a = Vec4::new(f32::NAN, 2.0, -1.0, 0.0);
        let b = Vec4::new(1.0, 1.0, 1.0, -0.0);
        let (hi, lo) = (nan_keeps_max(a, b), nan_keeps_min(a, b));
        assert_eq!(hi.to_array(), [1.0, 2.0, 1.0, -0.0]);
        assert_eq!(lo.to_array(), [1.0, 1.0, -1.0, -0.0]);
        assert!(
            hi.w.is_sign_negative() && lo.w.is_sign_negative(),
            "ties keep b"
        );
    }

    #[test]
    fn empty_slots_are_never_entered() {
        let comps = [1.0, -1.0, 0.0, -0.0, 1e-30];
        for x in comps {
            for y in comps {
                for z in comps {
                    let d = Vec3::new(x, y, z);
                    if d.length() > 0.0 {
                        unit_cube(Ray::new(Vec3::splat(0.5), d.normalize()));
                        unit_cube(Ray::new(Vec3::ZERO, d.normalize()));
                    }
                }
            }
        }
    }
}
