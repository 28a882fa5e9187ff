//! The pure-Rust BVH backend (`--accel bvh`, and the fast backend of
//! `--no-default-features` builds).
//!
//! - Build ([`build`]): binned SAH, parallel over subtrees, leaves of at most
//!   [`LEAF_MAX`] triangles, collapsed into 4-wide nodes whose child boxes are
//!   stored as structure-of-arrays, so one slab test covers four children.
//! - Traversal: a closest-hit loop that visits hit children near-first and a
//!   separate any-hit loop for occlusion, both with a fixed-size stack of
//!   [`STACK_SIZE`] entries on the call stack: no allocation per ray.
//! - Slab test: robust to adversarial rays (Ize, "Robust BVH Ray Traversal",
//!   JCGT 2013; pbrt-v4 section 6.1.2): `1/0 = inf` directions, NaN from
//!   `0 * inf` when an origin lies on a slab plane (comparisons written so that
//!   NaN imposes no constraint), and the far distance enlarged by
//!   `1 + 2 gamma(3)` so rounding never culls a box the ray touches.
//! - Triangles: the same watertight routine as the naive backend
//!   ([`super::triangle`]), on the same `f32` corners, with the same tie rule
//!   (equal `t` goes to the lowest original index): the closest hit equals
//!   the naive backend's bit for bit.

mod build;

use super::triangle::WatertightRay;
use super::{Accelerator, Hit, TriangleSoup};
use crate::math::{Ray, Vec3, gamma};
use build::{BinNode, PrimRef};
use glam::Vec4;
use rayon::prelude::*;

/// Most triangles in a leaf.
pub const LEAF_MAX: usize = 4;
/// Traversal stack entries: three per 4-wide level over the depth bound of
/// [`build`] (`SAH_DEPTH + 28 + 1` binary levels for up to 2^28 triangles).
pub const STACK_SIZE: usize = 256;
const _: () = assert!(3 * (build::SAH_DEPTH + 29) < STACK_SIZE);

/// Build quality.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BvhQuality {
    /// Binned SAH (16 bins per axis).
    #[default]
    Fast,
    /// Full SAH sweep over sorted centroids on every axis (up to 65536
    /// primitives per node; binned above that).
    High,
}

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (inverted, so it never intersects anything).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// Grow to contain `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Half the surface area (0 for the empty box).
    pub fn area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Child reference: an inner node index, or a leaf (top bit set) holding
/// `start << 3 | (count - 1)` into the reordered triangles.
const LEAF_BIT: u32 = 1 << 31;
const EMPTY_CHILD: u32 = u32::MAX;

/// A 4-wide node: the four child boxes as structure-of-arrays, one SIMD
/// lane per child (glam's `Vec4` is an SSE register on x86-64).
#[derive(Debug, Clone, Copy)]
struct Node4 {
    min: [Vec4; 3],
    max: [Vec4; 3],
    child: [u32; 4],
}

const EMPTY_NODE: Node4 = Node4 {
    min: [Vec4::splat(f32::INFINITY); 3],
    max: [Vec4::splat(f32::NEG_INFINITY); 3],
    child: [EMPTY_CHILD; 4],
};

/// The pure-Rust BVH.
pub struct Bvh {
    nodes: Vec<Node4>,
    /// Triangle corners in leaf order.
    tris: Vec<[Vec3; 3]>,
    /// Original index of each triangle in leaf order.
    ids: Vec<u32>,
    root: u32,
}

fn leaf_ref(start: usize, count: usize) -> u32 {
    debug_assert!((1..=8).contains(&count) && start < 1 << 28);
    LEAF_BIT | (start as u32) << 3 | (count as u32 - 1)
}

impl Bvh {
    /// Build over `soup` (triangles with non-finite corners are left out:
    /// they can never be hit).
    pub fn new(soup: TriangleSoup<'_>, quality: BvhQuality) -> Self {
        let mut prims: Vec<PrimRef> = soup
            .indices
            .par_iter()
            .enumerate()
            .filter_map(|(i, t)| {
                let p = t.map(|k| soup.positions[k as usize]);
                if !p.iter().all(|q| q.is_finite()) {
                    return None;
                }
                let mut b = Aabb::EMPTY;
                p.iter().for_each(|&q| b.grow(q));
                Some(PrimRef {
                    bounds: b,
                    centroid: 0.5 * (b.min + b.max),
                    id: i as u32,
                })
            })
            .collect();
        let mut bvh = Bvh {
            nodes: Vec::new(),
            tris: Vec::new(),
            ids: Vec::new(),
            root: EMPTY_CHILD,
        };
        if prims.is_empty() {
            return bvh;
        }
        let tree = build::build(&mut prims, 0, 0, quality == BvhQuality::High);
        bvh.ids = prims.par_iter().map(|p| p.id).collect();
        bvh.tris = bvh
            .ids
            .par_iter()
            .map(|&i| soup.indices[i as usize].map(|k| soup.positions[k as usize]))
            .collect();
        bvh.root = match &tree {
            BinNode::Leaf { start, count, .. } => {
                // a single leaf still goes under one node so traversal is uniform
                let mut n = EMPTY_NODE;
                set_slot(&mut n, 0, tree.bounds(), leaf_ref(*start, *count));
                bvh.nodes.push(n);
                0
            }
            BinNode::Inner { .. } => bvh.collapse(&tree),
        };
        bvh
    }

    /// Flatten binary inner node `node` into a 4-wide node; returns its index.
    fn collapse(&mut self, node: &BinNode) -> u32 {
        let BinNode::Inner { children, .. } = node else {
            unreachable!("collapse is called on inner nodes only");
        };
        let mut slots: Vec<&BinNode> = children.iter().collect();
        while slots.len() < 4 {
            // open the inner child with the largest area
            let pick = slots
                .iter()
                .enumerate()
                .filter(|(_, n)| matches!(n, BinNode::Inner { .. }))
                .max_by(|a, b| a.1.bounds().area().total_cmp(&b.1.bounds().area()))
                .map(|(i, _)| i);
            let Some(i) = pick else { break };
            let BinNode::Inner { children, .. } = slots.swap_remove(i) else {
                unreachable!("picked an inner node");
            };
            slots.extend(children.iter());
        }
        let index = self.nodes.len();
        self.nodes.push(EMPTY_NODE);
        for (k, child) in slots.iter().enumerate() {
            let r = match child {
                BinNode::Leaf { start, count, .. } => leaf_ref(*start, *count),
                BinNode::Inner { .. } => self.collapse(child),
            };
            let mut n = self.nodes[index];
            set_slot(&mut n, k, child.bounds(), r);
            self.nodes[index] = n;
        }
        index as u32
    }

    /// Distances at which the ray enters each of the node's four boxes, or
    /// infinity for a box it misses within `(0, t_max]`.
    #[inline(always)]
    fn slab4(node: &Node4, o: &[Vec4; 3], inv: &[Vec4; 3], t_max: f32) -> [f32; 4] {
        let widen = Vec4::splat(1.0 + 2.0 * gamma(3));
        let mut t0 = Vec4::ZERO;
        let mut t1 = Vec4::splat(t_max) * widen;
        for a in 0..3 {
            let n = (node.min[a] - o[a]) * inv[a];
            let f = (node.max[a] - o[a]) * inv[a];
            // NaN is 0 * inf: the ray runs parallel to this slab with its
            // origin exactly on one of its planes, so the slab constrains
            // nothing (the ray touches the box's boundary, where a triangle
            // edge or vertex can be hit)
            let unconstrained = n.is_nan_mask() | f.is_nan_mask();
            let near = Vec4::select(unconstrained, Vec4::NEG_INFINITY, n.min(f));
            let far = Vec4::select(unconstrained, Vec4::INFINITY, n.max(f) * widen);
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        Vec4::select(t0.cmple(t1), t0, Vec4::INFINITY).to_array()
    }

    #[inline(always)]
    fn leaf_range(r: u32) -> (usize, usize) {
        let start = ((r & !LEAF_BIT) >> 3) as usize;
        (start, start + (r & 7) as usize + 1)
    }
}

fn set_slot(n: &mut Node4, k: usize, b: &Aabb, r: u32) {
    for a in 0..3 {
        n.min[a][k] = b.min[a];
        n.max[a][k] = b.max[a];
    }
    n.child[k] = r;
}

/// A ray's origin and reciprocal direction, one axis per `Vec4`, each
/// broadcast to the four lanes.
#[inline(always)]
fn broadcast(ray: &Ray) -> ([Vec4; 3], [Vec4; 3]) {
    let inv = ray.d.recip();
    (
        [
            Vec4::splat(ray.o.x),
            Vec4::splat(ray.o.y),
            Vec4::splat(ray.o.z),
        ],
        [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
    )
}

impl Accelerator for Bvh {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node4>()
            + self.tris.capacity() * std::mem::size_of::<[Vec3; 3]>()
            + self.ids.capacity() * 4
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.root == EMPTY_CHILD || !ray.is_finite() {
            return None;
        }
        let wr = WatertightRay::new(ray);
        let (o, inv) = broadcast(ray);
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        let mut stack = [0u32; STACK_SIZE];
        stack[0] = self.root;
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let r = stack[sp];
            if r & LEAF_BIT != 0 {
                let (a, b) = Self::leaf_range(r);
                for i in a..b {
                    let [p0, p1, p2] = self.tris[i];
                    if let Some(mut h) = wr.intersect(p0, p1, p2, t_max) {
                        let id = self.ids[i];
                        if best.is_none_or(|b| h.t < b.t || (h.t == b.t && id < b.prim)) {
                            h.prim = id;
                            t_max = h.t;
                            best = Some(h);
                        }
                    }
                }
                continue;
            }
            let node = &self.nodes[r as usize];
            let t = Self::slab4(node, &o, &inv, t_max);
            // push hit children far-to-near so the nearest is popped first
            let mut order = [(f32::INFINITY, EMPTY_CHILD); 4];
            let mut n = 0;
            for (&tk, &child) in t.iter().zip(&node.child) {
                if tk < f32::INFINITY && child != EMPTY_CHILD {
                    let mut j = n;
                    while j > 0 && order[j - 1].0 < tk {
                        order[j] = order[j - 1];
                        j -= 1;
                    }
                    order[j] = (tk, child);
                    n += 1;
                }
            }
            for &(_, c) in &order[..n] {
                stack[sp] = c;
                sp += 1;
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if self.root == EMPTY_CHILD || !ray.is_finite() {
            return false;
        }
        let wr = WatertightRay::new(ray);
        let (o, inv) = broadcast(ray);
        let mut stack = [0u32; STACK_SIZE];
        stack[0] = self.root;
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let r = stack[sp];
            if r & LEAF_BIT != 0 {
                let (a, b) = Self::leaf_range(r);
                for [p0, p1, p2] in &self.tris[a..b] {
                    if wr.intersect(*p0, *p1, *p2, ray.t_max).is_some() {
                        return true;
                    }
                }
                continue;
            }
            let node = &self.nodes[r as usize];
            let t = Self::slab4(node, &o, &inv, ray.t_max);
            for (&tk, &child) in t.iter().zip(&node.child) {
                if tk < f32::INFINITY && child != EMPTY_CHILD {
                    stack[sp] = child;
                    sp += 1;
                }
            }
        }
        false
    }
}
