//! Instancing: one copy of a mesh's triangles (a [`Prototype`], in its own
//! object space) placed any number of times by affine transforms
//! ([`Placement`]s), and [`InstanceSet`], the top level of the pure-Rust
//! backends' two-level search (Embree has its own instance geometry).
//!
//! Primitive numbering: the triangles of placement `k` are the primitives
//! `first_prim + j` for the prototype's triangles `j`, numbered after every
//! placed triangle and sphere, in placement order (see [`super::TriangleSoup`]).
//!
//! A query transforms the ray into the prototype's object space with
//! [`Placement::object_ray`] (the inverse affine map, computed once in `f64`
//! and rounded to `f32`), direction not renormalised, so `t` keeps the
//! render-space ray's parametrisation: a hit's `t` needs no conversion, and
//! barycentrics are those of the object-space triangle (an affine map keeps
//! them). Both pure-Rust backends run the same transform and the same
//! triangle routine on the same object-space corners, so their answers stay
//! bit-identical; the naive backend scans every placement, the BVH culls
//! placements by a binary tree over their render-space boxes, padded by a
//! bound on the transform's rounding so that no placement the scan would
//! hit is ever culled, and ties in `t` go to the lower primitive as
//! everywhere else.

use super::{Accelerator, AlphaTest, Hit, HitFilter, Masks, Opaque};
use crate::math::{Ray, Vec3};
use glam::{Affine3A, DAffine3, DVec3};

/// A mesh stored once, in object space, for instances to place: vertex
/// positions and counter-clockwise index triples.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Prototype {
    /// Vertex positions (object space).
    pub positions: Vec<Vec3>,
    /// Vertex indices per triangle.
    pub indices: Vec<[u32; 3]>,
}

impl Prototype {
    /// The three corners of triangle `t`.
    #[inline]
    pub fn triangle(&self, t: u32) -> [Vec3; 3] {
        self.indices[t as usize].map(|i| self.positions[i as usize])
    }

    /// Object-space bounds of the vertices its triangles use, `(min, max)`
    /// (`min > max` when it has none).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for t in &self.indices {
            for &i in t {
                let p = self.positions[i as usize];
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo, hi)
    }
}

/// One placement of a prototype: object-to-render and render-to-object
/// maps (each rounded once from an `f64` composition, so the inverse is as
/// exact as `f32` allows) and the primitive id of its first triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Index into the prototypes.
    pub prototype: u32,
    /// Object space to render space.
    pub to_render: Affine3A,
    /// Render space to object space.
    pub to_object: Affine3A,
    /// The primitive id of the prototype's triangle 0 in this placement.
    pub first_prim: u32,
    /// [`Placement::condition`], computed once.
    pub cond: f32,
}

impl Placement {
    /// A placement of `prototype` by the object-to-render map `m`, its
    /// triangles numbered from `first_prim`. `None` when `m` is singular or
    /// not finite.
    pub fn new(prototype: u32, m: DAffine3, first_prim: u32) -> Option<Placement> {
        let det = m.matrix3.determinant();
        if !(det.is_finite() && det != 0.0 && m.translation.is_finite()) {
            return None;
        }
        let inv = m.inverse();
        let f32s = |a: DAffine3| Affine3A::from_cols_array(&a.to_cols_array().map(|x| x as f32));
        let (to_render, to_object) = (f32s(m), f32s(inv));
        let finite = |a: &Affine3A| a.to_cols_array().iter().all(|x| x.is_finite());
        let mut p = Placement {
            prototype,
            to_render,
            to_object,
            first_prim,
            cond: 1.0,
        };
        p.cond = p.condition();
        (finite(&to_render) && finite(&to_object)).then_some(p)
    }

    /// `ray` in object space: origin and direction through the inverse map,
    /// the direction not renormalised, so `t` means the same on both sides.
    #[inline]
    pub fn object_ray(&self, ray: &Ray) -> Ray {
        Ray {
            o: self.to_object.transform_point3(ray.o),
            d: self.to_object.transform_vector3(ray.d),
            t_max: ray.t_max,
        }
    }

    /// `|| L || * || L^-1 ||` (max-row-sum norms) of the linear part: how
    /// much the round trip through object space can magnify a relative
    /// rounding error. At least 1.
    pub fn condition(&self) -> f32 {
        let norm = |a: &Affine3A| {
            let m = glam::Mat3::from(a.matrix3).transpose();
            [m.x_axis, m.y_axis, m.z_axis]
                .iter()
                .map(|r| r.abs().element_sum())
                .fold(0.0f32, f32::max)
        };
        (norm(&self.to_render) * norm(&self.to_object)).max(1.0)
    }

    /// Render-space bounds of the object box `(lo, hi)`: its eight corners
    /// mapped in `f64`.
    pub fn render_bounds(&self, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
        let m = DAffine3::from_cols_array(&self.to_render.to_cols_array().map(f64::from));
        let (mut a, mut b) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for k in 0..8 {
            let c = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x } as f64,
                if k & 2 == 0 { lo.y } else { hi.y } as f64,
                if k & 4 == 0 { lo.z } else { hi.z } as f64,
            );
            let p = m.transform_point3(c);
            a = a.min(p);
            b = b.max(p);
        }
        (a.as_vec3(), b.as_vec3())
    }
}

/// The instances a backend receives: the prototypes and their placements.
#[derive(Debug, Clone, Copy, Default)]
pub struct Instances<'a> {
    /// Meshes in object space.
    pub prototypes: &'a [Prototype],
    /// Placements, in primitive order.
    pub placements: &'a [Placement],
}

impl Instances<'_> {
    /// Whether there is nothing to place.
    pub fn is_empty(&self) -> bool {
        self.placements.is_empty()
    }

    /// Triangles placed in all (what the placements number).
    pub fn triangle_count(&self) -> u64 {
        self.placements
            .iter()
            .map(|p| self.prototypes[p.prototype as usize].indices.len() as u64)
            .sum()
    }
}

/// A node of the top-level tree: a padded box and either two children or
/// a range of placements.
#[derive(Debug, Clone, Copy)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// The largest coordinate magnitude of the box (for the per-ray pad).
    reach: f32,
    /// Inner node: index of the first child (the second follows). Leaf:
    /// first entry of `order`.
    first: u32,
    /// 0 for an inner node, else the number of placements in the leaf.
    count: u32,
}

/// Placements in the leaves of the top-level tree.
const LEAF: usize = 2;

/// Depth bound of the median-split tree (`2^32` placements need 32 levels).
const STACK: usize = 64;

/// The top level of a two-level search: one object-space accelerator per
/// prototype (`A`: the naive backend or the BVH) and the placements, either
/// scanned in order (`tree` off: the oracle) or culled by a binary tree of
/// their render-space boxes.
pub struct InstanceSet<A> {
    prototypes: Vec<A>,
    placements: Vec<Placement>,
    /// Leaf order of the placements.
    order: Vec<u32>,
    nodes: Vec<Node>,
    /// `64 eps` times the largest [`Placement::condition`]: the pad of a box
    /// per unit of coordinate magnitude (of the box and the ray origin).
    pad_rate: f32,
}

/// A prototype's structure as [`InstanceSet`] queries it: its triangles
/// only, with a [`HitFilter`] (the placement's view of a scene's alpha
/// masks).
pub trait PrototypeQuery: Accelerator {
    /// The closest triangle hit `filter` keeps.
    fn closest_triangle<F: HitFilter>(&self, ray: &Ray, filter: &F) -> Option<Hit>;
    /// Whether some triangle hit is kept by `filter`.
    fn any_triangle<F: HitFilter>(&self, ray: &Ray, filter: &F) -> bool;
}

impl<A: PrototypeQuery> InstanceSet<A> {
    /// The set of `instances`, each prototype built by `build`; with `tree`,
    /// placements are culled by their boxes, otherwise scanned.
    pub fn new<E>(
        instances: Instances<'_>,
        tree: bool,
        build: impl Fn(&Prototype) -> Result<A, E>,
    ) -> Result<Self, E> {
        let prototypes = instances
            .prototypes
            .iter()
            .map(build)
            .collect::<Result<Vec<A>, E>>()?;
        let mut set = InstanceSet {
            prototypes,
            placements: instances.placements.to_vec(),
            order: (0..instances.placements.len() as u32).collect(),
            nodes: Vec::new(),
            pad_rate: 0.0,
        };
        if tree && !instances.is_empty() {
            let cond = set.placements.iter().map(|p| p.cond).fold(1.0f32, f32::max);
            set.pad_rate = 64.0 * f32::EPSILON * cond;
            let object_bounds: Vec<(Vec3, Vec3)> =
                instances.prototypes.iter().map(Prototype::bounds).collect();
            let boxes: Vec<(Vec3, Vec3)> = set
                .placements
                .iter()
                .map(|p| {
                    let (lo, hi) = object_bounds[p.prototype as usize];
                    if lo.x > hi.x {
                        (Vec3::INFINITY, Vec3::NEG_INFINITY)
                    } else {
                        p.render_bounds(lo, hi)
                    }
                })
                .collect();
            set.nodes.push(Node {
                min: Vec3::ZERO,
                max: Vec3::ZERO,
                reach: 0.0,
                first: 0,
                count: 0,
            });
            set.build(&boxes, 0, 0, boxes.len());
        }
        Ok(set)
    }

    /// Fill node `n` over `order[lo..hi]`: median split on the longest axis
    /// of the box centres.
    fn build(&mut self, boxes: &[(Vec3, Vec3)], n: usize, lo: usize, hi: usize) {
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let (mut cmin, mut cmax) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let centre = |i: u32| {
            let (a, b) = boxes[i as usize];
            if a.x > b.x { Vec3::ZERO } else { 0.5 * (a + b) }
        };
        for &i in &self.order[lo..hi] {
            let (a, b) = boxes[i as usize];
            min = min.min(a);
            max = max.max(b);
            cmin = cmin.min(centre(i));
            cmax = cmax.max(centre(i));
        }
        let reach = min.abs().max(max.abs()).max_element();
        let node = &mut self.nodes[n];
        node.min = min;
        node.max = max;
        node.reach = if reach.is_finite() { reach } else { 0.0 };
        if hi - lo <= LEAF {
            node.first = lo as u32;
            node.count = (hi - lo) as u32;
            return;
        }
        let axis = super::longest_axis(cmax - cmin);
        let mid = (lo + hi) / 2;
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |a, b| {
            centre(*a)[axis].total_cmp(&centre(*b)[axis]).then(a.cmp(b))
        });
        let left = self.nodes.len();
        let blank = self.nodes[n];
        self.nodes.push(blank);
        self.nodes.push(blank);
        self.nodes[n].first = left as u32;
        self.nodes[n].count = 0;
        self.build(boxes, left, lo, mid);
        self.build(boxes, left + 1, mid, hi);
    }

    /// Whether there are no placements.
    pub fn is_empty(&self) -> bool {
        self.placements.is_empty()
    }

    /// Bytes held: the prototypes' structures once, plus the placements.
    pub fn memory_bytes(&self) -> usize {
        self.prototypes.iter().map(A::memory_bytes).sum::<usize>()
            + self.placements.capacity() * std::mem::size_of::<Placement>()
            + self.order.capacity() * 4
            + self.nodes.capacity() * std::mem::size_of::<Node>()
    }

    /// Call `f(placement index)` for the placements whose boxes `ray` may
    /// cross before `t_max()` (every placement, in order, without a tree);
    /// `f` returns `true` to stop.
    #[inline]
    fn visit(&self, ray: &Ray, t_max: impl Fn() -> f32, mut f: impl FnMut(usize) -> bool) {
        if self.nodes.is_empty() {
            for k in 0..self.placements.len() {
                if f(k) {
                    return;
                }
            }
            return;
        }
        let inv = ray.d.recip();
        let o_reach = ray.o.abs().max_element();
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            // the box padded by the transform's rounding at this distance
            // from the origin; a 0 * inf = NaN slab bound is ignored by
            // min/max (that axis then culls nothing)
            let scale = self.pad_rate * (o_reach + node.reach);
            let pad = Vec3::splat(scale);
            let t0 = (node.min - pad - ray.o) * inv;
            let t1 = (node.max + pad - ray.o) * inv;
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0.max(t1).min_element() * (1.0 + 4.0 * f32::EPSILON);
            // The triangle routine's `t` can fall short of the exact hit
            // distance (hence of the box's entry) by a few ulps of the
            // corners' distances (see the BVH's cull key); a box is culled
            // against the best `t` only beyond four pads of that.
            if !(near <= far && near <= t_max() + 4.0 * scale) {
                continue;
            }
            if node.count > 0 {
                for k in node.first..node.first + node.count {
                    if f(self.order[k as usize] as usize) {
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

    /// The closest of `best` and the placements' hits (a placement's hit
    /// wins at a smaller `t`, or at an equal `t` with a lower primitive),
    /// less those `alpha` ignores (asked with the render-space `ray`).
    pub fn closest(
        &self,
        ray: &Ray,
        best: Option<Hit>,
        alpha: Option<&dyn AlphaTest>,
    ) -> Option<Hit> {
        if self.placements.is_empty() || !ray.is_finite() {
            return best;
        }
        let cell = std::cell::Cell::new(best);
        let bound = || cell.get().map_or(ray.t_max, |b| b.t);
        self.visit(ray, bound, |k| {
            let p = &self.placements[k];
            let mut r = p.object_ray(ray);
            r.t_max = bound();
            let proto = &self.prototypes[p.prototype as usize];
            let found = match alpha {
                None => proto.closest_triangle(&r, &Opaque),
                Some(alpha) => proto.closest_triangle(
                    &r,
                    &Masks {
                        alpha,
                        ray,
                        first_prim: p.first_prim,
                    },
                ),
            };
            if let Some(h) = found {
                let prim = p.first_prim + h.prim;
                let better = match cell.get() {
                    None => true,
                    Some(b) => h.t < b.t || (h.t == b.t && prim < b.prim),
                };
                if better {
                    cell.set(Some(Hit { prim, ..h }));
                }
            }
            false
        });
        cell.get()
    }

    /// Whether any placement is hit in `(0, ray.t_max]` (by a hit `alpha`
    /// does not ignore).
    pub fn any(&self, ray: &Ray, alpha: Option<&dyn AlphaTest>) -> bool {
        if self.placements.is_empty() || !ray.is_finite() {
            return false;
        }
        let mut hit = false;
        self.visit(
            ray,
            || ray.t_max,
            |k| {
                let p = &self.placements[k];
                let proto = &self.prototypes[p.prototype as usize];
                let r = p.object_ray(ray);
                hit = match alpha {
                    None => proto.any_triangle(&r, &Opaque),
                    Some(alpha) => proto.any_triangle(
                        &r,
                        &Masks {
                            alpha,
                            ray,
                            first_prim: p.first_prim,
                        },
                    ),
                };
                hit
            },
        );
        hit
    }
}
