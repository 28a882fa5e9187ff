//! The pure-Rust BVH backend (`--accel bvh`, and the default backend of
//! `--no-default-features` builds). No `unsafe`.
//!
//! - Build (`build.rs`): SAH splits (binned on all three axes, Wald, "On fast
//!   Construction of SAH-based Bounding Volume Hierarchies", IEEE RT 2007;
//!   or a full sweep with [`BvhQuality::High`]), parallel over subtrees with
//!   rayon, leaves of at most [`LEAF_MAX`] triangles, made directly into
//!   8-wide nodes whose child boxes are stored plane by plane (`[f32; 8]`
//!   per plane, Embree's BVH8 layout), so the slab test covers four children
//!   per vector operation. Each leaf's triangles are copied into one
//!   to four consecutive blocks of four, coordinate by coordinate
//!   ([`Tri4`]), with their original indices, which is what [`Hit::prim`]
//!   reports; blocks follow the depth-first order of the leaves. The SAH
//!   charges a leaf per block lane, so leaves fill their blocks, and a leaf
//!   of several blocks saves the node step above it: in a large scene that
//!   step is a cache miss that the next node's address waits for, whereas
//!   the blocks' loads are independent of each other. Nodes and blocks
//!   live on transparent huge pages where they are large (`pages.rs`):
//!   traversal is bound by the latency of their loads.
//! - Traversal (`traverse.rs`): closest-hit (children visited near-first)
//!   and any-hit loops over a fixed stack of [`STACK_SIZE`] entries on the
//!   call stack, sized by the depth bound the builder guarantees: no
//!   allocation per ray.
//! - Robust culling (Ize, "Robust BVH Ray Traversal", JCGT 2(2), 2013;
//!   pbrt-v4 section 6.8.2): infinite reciprocal directions, `0 * inf = NaN`
//!   on slab planes and rounding in the box test cull nothing they should
//!   not; boxes are padded per ray by the leaf test's rounding error; and
//!   boxes are culled against the best `t` by their near plane on the leaf
//!   test's distance axis, a bound that test's `t` provably respects (the
//!   ray's entry into a box does not bound it for large slivers).
//! - Leaves: the naive backend's watertight routine
//!   ([`WatertightRay::intersect4`](super::triangle::WatertightRay::intersect4),
//!   four triangles at a time, as the naive backend runs it too) on the same
//!   `f32` corners, with the same tie rule (equal `t` goes to the lowest
//!   original index): for every ray, the closest hit equals the naive
//!   backend's bit for bit, and so does occlusion.
//!
//! Triangles with a non-finite corner are left out (the watertight test
//! never reports them); degenerate ones stay, since the leaf test decides.

mod build;
mod node;
mod pages;
mod traverse;

#[cfg(test)]
mod tests;

pub use build::TreeStats;
pub use node::{LEAF_MAX, MAX_TRIANGLES};

use super::instance::{InstanceSet, PrototypeQuery};
use super::sphere::SphereSet;
use super::triangle::Tri4;
use super::{Accelerator, AlphaTest, Hit, HitFilter, Masks, Opaque, TriangleSoup};
use crate::error::{Error, Result};
use crate::math::Ray;
use crate::simd::{Dispatch, Level};
use build::PrimRef;
use node::{Aabb, ChildRef, Node};
use pages::PageArray;
use rayon::prelude::*;

/// Traversal stack entries (99). Each 8-wide node on the path to the
/// current one leaves at most seven siblings on the stack, and the builder
/// keeps every leaf within 42 binary levels of the root with each node
/// spanning at least three of them, so the path holds at most 14 nodes and
/// 98 entries always suffice.
pub const STACK_SIZE: usize = (node::WIDTH - 1) * build::MAX_DEPTH.div_ceil(node::LEVELS) + 1;

/// Build quality.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BvhQuality {
    /// Binned SAH, 16 bins on each axis.
    #[default]
    Fast,
    /// Full SAH sweep over sorted centroids on every axis for ranges up to
    /// 65536 triangles, 64 bins per axis above that. Slower to build.
    High,
}

/// The pure-Rust BVH.
pub struct Bvh {
    /// Nodes, depth-first (on huge pages where large, as the blocks).
    nodes: PageArray<Node>,
    /// Triangle blocks, one to four per leaf, in depth-first order.
    blocks: PageArray<Tri4>,
    /// The root: an inner node, or a leaf for tiny scenes; `None` when no
    /// triangle is finite.
    root: Option<ChildRef>,
    /// Bounds of every triangle in the tree (the traversal pads boxes by a
    /// multiple of the ray's distance to it).
    bounds: Aabb,
    stats: TreeStats,
    /// The analytic spheres, in their own small tree, searched after the
    /// triangles (empty, and skipped at once, in triangle-only scenes).
    spheres: SphereSet,
    /// The instanced prototypes, each a BVH in its own object space, under
    /// a tree of their placements' boxes: searched last (empty, and skipped
    /// at once, without instances).
    instances: InstanceSet<Bvh>,
    /// The instruction set the traversal runs with ([`crate::simd`]; the
    /// same answers, bit for bit, on every level).
    simd: Dispatch,
}

/// A closest-hit traversal, run by [`Dispatch::run`] so that the inlined
/// traversal compiles for the chosen instruction set.
struct Closest<'q, F> {
    bvh: &'q Bvh,
    ray: &'q Ray,
    filter: &'q F,
}

impl<F: HitFilter> pulp::WithSimd for Closest<'_, F> {
    type Output = Option<Hit>;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Option<Hit> {
        self.bvh.closest_hit(self.ray, self.filter)
    }
}

/// An any-hit traversal, as [`Closest`].
struct Any<'q, F> {
    bvh: &'q Bvh,
    ray: &'q Ray,
    filter: &'q F,
}

impl<F: HitFilter> pulp::WithSimd for Any<'_, F> {
    type Output = bool;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> bool {
        self.bvh.any_hit(self.ray, self.filter)
    }
}

impl Bvh {
    /// Build over `soup` with the given quality. Triangles with a non-finite
    /// corner are left out (they can never be hit). Fails only for more than
    /// [`MAX_TRIANGLES`] triangles.
    pub fn new(soup: TriangleSoup<'_>, quality: BvhQuality) -> Result<Self> {
        Self::with_simd(soup, quality, crate::simd::active())
    }

    /// [`Bvh::new`], traversed with the instruction set of `level`.
    pub fn with_simd(soup: TriangleSoup<'_>, quality: BvhQuality, level: Level) -> Result<Self> {
        let simd = level.dispatcher();
        let too_many = || Error::Backend {
            backend: "bvh",
            message: format!(
                "{} triangles: the BVH holds at most {MAX_TRIANGLES}",
                soup.indices.len()
            ),
        };
        if soup.indices.len() > u32::MAX as usize {
            return Err(too_many());
        }
        let corners = |t: &[u32; 3]| t.map(|k| soup.positions[k as usize]);
        // an exact-size parallel collect, then the (rare) non-finite
        // triangles dropped: an empty box marks them
        let mut prims: Vec<PrimRef> = soup
            .indices
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let p = corners(t);
                let bounds = if p.iter().all(|q| q.is_finite()) {
                    Aabb::of_triangle(&p)
                } else {
                    Aabb::EMPTY
                };
                PrimRef::new(&bounds, i as u32)
            })
            .collect();
        prims.retain(|p| !p.bounds().is_empty());
        if prims.len() > MAX_TRIANGLES {
            return Err(too_many());
        }
        let spheres = SphereSet::new(soup.spheres, soup.indices.len() as u32);
        let instances = InstanceSet::new(soup.instances, true, |p| {
            Bvh::with_simd(
                TriangleSoup::triangles(&p.positions, &p.indices),
                quality,
                level,
            )
        })?;
        if prims.is_empty() {
            return Ok(Bvh {
                nodes: PageArray::zeroed(0),
                blocks: PageArray::zeroed(0),
                root: None,
                bounds: Aabb::EMPTY,
                stats: TreeStats::default(),
                spheres,
                instances,
                simd,
            });
        }
        let tree = build::build(&mut prims, quality);
        // every block is written below
        let mut blocks = PageArray::<Tri4>::zeroed(tree.blocks.len());
        blocks
            .par_iter_mut()
            .zip(tree.blocks.par_iter())
            .for_each(|(b, r)| {
                // a block holds 1 to 4 triangles; unused lanes repeat the first
                let leaf = &prims[r.clone()];
                for l in 0..4 {
                    let p = &leaf[if l < leaf.len() { l } else { 0 }];
                    b.set(l, corners(&soup.indices[p.id() as usize]), p.id());
                }
            });
        Ok(Bvh {
            nodes: tree.nodes,
            blocks,
            root: Some(tree.root),
            bounds: tree.bounds,
            stats: tree.stats,
            spheres,
            instances,
            simd,
        })
    }

    /// The tree's shape: node and leaf counts and depth.
    pub fn stats(&self) -> TreeStats {
        self.stats
    }

    /// The instruction set the traversal runs with.
    pub fn simd(&self) -> Level {
        self.simd.level()
    }

    #[inline(always)]
    fn closest<F: HitFilter>(&self, ray: &Ray, filter: &F) -> Option<Hit> {
        self.simd.run(Closest {
            bvh: self,
            ray,
            filter,
        })
    }

    #[inline(always)]
    fn any<F: HitFilter>(&self, ray: &Ray, filter: &F) -> bool {
        self.simd.run(Any {
            bvh: self,
            ray,
            filter,
        })
    }
}

impl Accelerator for Bvh {
    fn name(&self) -> &'static str {
        "bvh"
    }

    fn memory_bytes(&self) -> usize {
        self.nodes.memory_bytes()
            + self.blocks.memory_bytes()
            + self.spheres.memory_bytes()
            + self.instances.memory_bytes()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let best = self.closest(ray, &Opaque);
        let best = super::naive::with_spheres(&self.spheres, ray, best);
        self.instances.closest(ray, best, None)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.any(ray, &Opaque)
            || (!self.spheres.is_empty() && ray.is_finite() && self.spheres.any(ray))
            || self.instances.any(ray, None)
    }

    fn intersect_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> Option<Hit> {
        let masks = Masks {
            alpha,
            ray,
            first_prim: 0,
        };
        let best = self.closest(ray, &masks);
        let best = super::naive::with_spheres(&self.spheres, ray, best);
        self.instances.closest(ray, best, Some(alpha))
    }

    fn occluded_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> bool {
        let masks = Masks {
            alpha,
            ray,
            first_prim: 0,
        };
        self.any(ray, &masks)
            || (!self.spheres.is_empty() && ray.is_finite() && self.spheres.any(ray))
            || self.instances.any(ray, Some(alpha))
    }
}

impl PrototypeQuery for Bvh {
    fn closest_triangle<F: HitFilter>(&self, ray: &Ray, filter: &F) -> Option<Hit> {
        self.closest(ray, filter)
    }
    fn any_triangle<F: HitFilter>(&self, ray: &Ray, filter: &F) -> bool {
        self.any(ray, filter)
    }
}
