//! Ray queries: the [`Accelerator`] trait and its backends.
//!
//! Every backend answers the same two questions about the same triangles, with
//! the same meaning, so shading code never knows which one answered:
//!
//! - [`Accelerator::intersect`]: the closest hit with `0 < t <= ray.t_max`,
//!   as a [`Hit`] `{ t, prim, u, v }` where the hit point is
//!   `(1 - u - v) p0 + u p1 + v p2` of triangle `prim`. Ties in `t` go to the
//!   lowest primitive index (the naive backend's rule; Embree may differ on a
//!   shared edge, where both answers are correct).
//! - [`Accelerator::occluded`]: whether any hit exists in that range.
//!
//! Backends: `naive` (brute force over every triangle with the watertight test
//! of [`triangle`]; the oracle for tests), `bvh` (the pure-Rust 8-wide BVH of
//! [`bvh`], which gives the naive backend's closest hit bit for bit) and
//! `embree` (Intel Embree through FFI, when built with the `embree` or
//! `embree4` feature).

pub mod bvh;
mod hybrid;
pub mod instance;
pub mod naive;
pub mod sphere;
pub mod triangle;
pub mod wide;

// The crate's one `unsafe` island: the FFI to Embree (lib.rs denies
// `unsafe` everywhere else).
#[cfg(any(feature = "embree", feature = "embree4"))]
#[allow(unsafe_code)]
pub mod embree;

/// Which Embree this build binds: `Some(3)` with the `embree` feature,
/// `Some(4)` with `embree4` (which takes precedence), `None` without Embree.
pub const EMBREE_MAJOR: Option<u32> = if cfg!(feature = "embree4") {
    Some(4)
} else if cfg!(feature = "embree") {
    Some(3)
} else {
    None
};

/// The Embree library this process runs on, as `"Embree 4.4.0"`: `None` in
/// a build without Embree, the reason in place of the version when no device
/// could be made.
pub fn embree_library() -> Option<String> {
    #[cfg(any(feature = "embree", feature = "embree4"))]
    return Some(match embree::library_version() {
        Ok(v) => format!("Embree {v}"),
        Err(e) => format!("Embree (no device: {e})"),
    });
    #[cfg(not(any(feature = "embree", feature = "embree4")))]
    None
}

use crate::error::Result;
use crate::math::{Ray, Vec3};
use crate::shape::Sphere;
pub use instance::{Instances, Placement, Prototype};
use std::fmt;
use std::str::FromStr;

/// The closest hit along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the ray (the ray's direction is unit length).
    pub t: f32,
    /// Index of the primitive hit (see [`TriangleSoup`] for the numbering).
    pub prim: u32,
    /// Barycentric weight of the triangle's second vertex (0 for a sphere,
    /// whose hit point shading rebuilds from `t`).
    pub u: f32,
    /// Barycentric weight of the triangle's third vertex (0 for a sphere).
    pub v: f32,
}

/// A structure that answers closest-hit and occlusion queries.
pub trait Accelerator: Send + Sync {
    /// The backend's name as `--accel` spells it.
    fn name(&self) -> &'static str;
    /// The closest hit with `0 < t <= ray.t_max`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether any hit exists with `0 < t <= ray.t_max`.
    fn occluded(&self, ray: &Ray) -> bool;
    /// Bytes the structure holds (nodes, triangle copies; Embree: what its
    /// memory monitor reported), for `bench`'s memory-per-triangle column.
    fn memory_bytes(&self) -> usize;

    /// [`Accelerator::intersect`] where `alpha` may cut holes: a candidate
    /// hit that [`AlphaTest::ignores`] does not count, and the search goes
    /// on past it. Every backend asks `alpha` about the same `(ray, prim)`
    /// pairs with the render-space ray it was given, so the answer does not
    /// depend on the backend (see [`AlphaTest`]).
    fn intersect_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> Option<Hit>;
    /// [`Accelerator::occluded`] where `alpha` may cut holes (shadow rays
    /// see through them).
    fn occluded_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> bool;

    /// [`Accelerator::intersect`] for each of `rays`, into `hits` (of the
    /// same length), with the same answers a ray at a time would get. A
    /// backend that traces packets overrides it; `coherence` says whether
    /// the rays of a batch are likely to share their paths (camera rays of
    /// neighbouring pixels), which packet traversal exploits.
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>], coherence: Coherence) {
        let _ = coherence;
        debug_assert_eq!(rays.len(), hits.len());
        for (ray, hit) in rays.iter().zip(hits) {
            *hit = self.intersect(ray);
        }
    }

    /// [`Accelerator::occluded`] for each of `rays`, into `occluded`.
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool], coherence: Coherence) {
        let _ = coherence;
        debug_assert_eq!(rays.len(), occluded.len());
        for (ray, o) in rays.iter().zip(occluded) {
            *o = self.occluded(ray);
        }
    }
}

/// Cut-out surfaces (alpha masks): which candidate hits a ray ignores.
///
/// A backend that finds a hit with `0 < t <= t_max` on primitive `prim`, at
/// barycentrics `(u, v)` of the triangle it tested, asks
/// [`AlphaTest::ignores`] before taking it; `ray` is always the render-space
/// ray the query was given (never an instance's object-space copy), and
/// `prim` the global primitive id of [`TriangleSoup`]'s numbering. The answer
/// must be a function of those arguments alone (no state, no thread-local
/// randomness), so that every backend, visiting candidates in whatever
/// order, ignores the same hits and returns the same closest kept one.
/// `(u, v)` is the one input the backends compute differently (Embree's
/// barycentrics and the watertight routine's agree to a few ulps), which
/// can change a textured mask's answer only where the texture's value at
/// the two points straddles the ray's threshold.
pub trait AlphaTest: Sync {
    /// Whether `ray` passes through primitive `prim` at `(u, v)`.
    fn ignores(&self, ray: &Ray, prim: u32, u: f32, v: f32) -> bool;
}

/// Which candidate hits the Rust backends' traversals keep: [`Opaque`]
/// keeps all (and compiles to nothing), [`Masks`] asks an [`AlphaTest`].
pub trait HitFilter {
    /// Whether every hit is kept (lets the traversal skip the calls).
    const OPAQUE: bool;
    /// Whether the hit on primitive `prim` (numbered locally to the
    /// structure being traversed) at `(u, v)` counts.
    fn keep(&self, prim: u32, u: f32, v: f32) -> bool;
}

/// Every hit counts.
pub struct Opaque;

impl HitFilter for Opaque {
    const OPAQUE: bool = true;
    #[inline(always)]
    fn keep(&self, _: u32, _: f32, _: f32) -> bool {
        true
    }
}

/// Hits count unless `alpha` ignores them for `ray` (render space);
/// `first_prim` turns a structure's local primitive ids into global ones
/// (a prototype's triangle `j` in a placement is `first_prim + j`).
pub struct Masks<'a> {
    /// The cut-outs.
    pub alpha: &'a dyn AlphaTest,
    /// The render-space ray of the query.
    pub ray: &'a Ray,
    /// The global id of the structure's primitive 0.
    pub first_prim: u32,
}

impl HitFilter for Masks<'_> {
    const OPAQUE: bool = false;
    #[inline]
    fn keep(&self, prim: u32, u: f32, v: f32) -> bool {
        !self.alpha.ignores(self.ray, self.first_prim + prim, u, v)
    }
}

/// An accelerator whose plain queries honour `alpha` (when there is one):
/// for code that hands a `&dyn Accelerator` on (ray sets, parity, benches)
/// and should see a scene's cut-outs. The path tracer asks for the masked
/// queries itself.
pub struct Masked<'a> {
    /// The backend.
    pub accel: &'a dyn Accelerator,
    /// The cut-outs, if the scene has any.
    pub alpha: Option<&'a dyn AlphaTest>,
}

impl Accelerator for Masked<'_> {
    fn name(&self) -> &'static str {
        self.accel.name()
    }
    fn memory_bytes(&self) -> usize {
        self.accel.memory_bytes()
    }
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match self.alpha {
            None => self.accel.intersect(ray),
            Some(a) => self.accel.intersect_masked(ray, a),
        }
    }
    fn occluded(&self, ray: &Ray) -> bool {
        match self.alpha {
            None => self.accel.occluded(ray),
            Some(a) => self.accel.occluded_masked(ray, a),
        }
    }
    fn intersect_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> Option<Hit> {
        self.accel.intersect_masked(ray, alpha)
    }
    fn occluded_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> bool {
        self.accel.occluded_masked(ray, alpha)
    }
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>], coherence: Coherence) {
        match self.alpha {
            None => self.accel.intersect_batch(rays, hits, coherence),
            Some(a) => {
                for (ray, hit) in rays.iter().zip(hits) {
                    *hit = self.accel.intersect_masked(ray, a);
                }
            }
        }
    }
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool], coherence: Coherence) {
        match self.alpha {
            None => self.accel.occluded_batch(rays, occluded, coherence),
            Some(a) => {
                for (ray, o) in rays.iter().zip(occluded) {
                    *o = self.accel.occluded_masked(ray, a);
                }
            }
        }
    }
}

/// The axis (0, 1, 2) along which `extent` is longest, ties to the lower
/// axis: where the median-split trees over placements and spheres cut.
#[inline]
pub(crate) fn longest_axis(extent: Vec3) -> usize {
    if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    }
}

/// Whether the rays of a batch are likely to traverse the same nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coherence {
    /// Neighbouring origins and directions (camera rays of a pixel block).
    Coherent,
    /// Anything else (bounces, shadow rays).
    Incoherent,
}

/// The primitives every backend receives: triangles (a shared vertex buffer
/// and one index triple per triangle), analytic spheres, and instances of
/// prototype meshes. Primitive ids number the triangles `0..indices.len()`
/// first, then the spheres, so sphere `i` is primitive `indices.len() + i`,
/// then the instanced triangles, placement by placement (each
/// [`Placement::first_prim`](instance::Placement::first_prim) on).
#[derive(Debug, Clone, Copy)]
pub struct TriangleSoup<'a> {
    /// Vertex positions.
    pub positions: &'a [Vec3],
    /// Vertex indices of each triangle, counter-clockwise seen from the front.
    pub indices: &'a [[u32; 3]],
    /// Analytic spheres.
    pub spheres: &'a [Sphere],
    /// Prototype meshes and their placements.
    pub instances: Instances<'a>,
    /// Whether some triangle may be cut out by an alpha mask (see
    /// [`AlphaTest`]). Embree then attaches filter functions to its
    /// triangle geometries, which cost each candidate hit a call, so a
    /// scene without masks leaves this off; the Rust backends ignore it
    /// (their traversal is compiled with and without a filter).
    pub masked: bool,
}

impl<'a> TriangleSoup<'a> {
    /// Triangles only.
    pub fn triangles(positions: &'a [Vec3], indices: &'a [[u32; 3]]) -> Self {
        TriangleSoup {
            positions,
            indices,
            spheres: &[],
            instances: Instances::default(),
            masked: false,
        }
    }

    /// Number of primitives (triangles, spheres and instanced triangles).
    pub fn primitive_count(&self) -> u64 {
        (self.indices.len() + self.spheres.len()) as u64 + self.instances.triangle_count()
    }
}

/// Backend choice (`--accel`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// Intel Embree.
    Embree,
    /// The pure-Rust BVH.
    Bvh,
    /// Brute force over all triangles.
    Naive,
    /// Embree for camera rays, the brute force for the rest
    /// ([`hybrid`]): the default for scenes of at most
    /// [`SMALL_SCENE_TRIANGLES`] triangles ([`Backend::for_scene`]).
    EmbreeNaive,
}

/// The most triangles (and no spheres or instances) for which
/// [`Backend::for_scene`] picks [`Backend::EmbreeNaive`]: the largest race
/// scene it was measured faster on (the Cornell box). The brute force's
/// cost grows with the triangles; at 32 it traced random rays at 12.9 to
/// 13.1 M/s against Embree's 7.1 to 8.3 (`embertrace bench
/// scenes/cornell-box.toml`, one thread).
pub const SMALL_SCENE_TRIANGLES: usize = 32;

impl Backend {
    /// Every backend compiled into this binary.
    pub fn available() -> Vec<Backend> {
        let mut v = Vec::new();
        if cfg!(any(feature = "embree", feature = "embree4")) {
            v.push(Backend::Embree);
        }
        v.push(Backend::Bvh);
        v.push(Backend::Naive);
        v
    }

    /// The default: Embree when compiled in, otherwise the BVH.
    pub fn default_backend() -> Backend {
        Backend::available()[0]
    }

    /// The backend a render takes when `--accel` is not given: for a
    /// scene of triangles alone, at most [`SMALL_SCENE_TRIANGLES`] of them,
    /// [`Backend::EmbreeNaive`] when Embree is compiled in; otherwise
    /// [`Backend::default_backend`].
    pub fn for_scene(soup: &TriangleSoup<'_>) -> Backend {
        let small = soup.indices.len() <= SMALL_SCENE_TRIANGLES
            && soup.spheres.is_empty()
            && soup.instances.triangle_count() == 0;
        match Backend::default_backend() {
            Backend::Embree if small => Backend::EmbreeNaive,
            b => b,
        }
    }

    /// The name `--accel` uses.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Embree => "embree",
            Backend::Bvh => "bvh",
            Backend::Naive => "naive",
            Backend::EmbreeNaive => "embree+naive",
        }
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "embree" => Ok(Backend::Embree),
            "bvh" => Ok(Backend::Bvh),
            "naive" => Ok(Backend::Naive),
            "embree+naive" => Ok(Backend::EmbreeNaive),
            _ => Err(format!(
                "unknown backend `{s}` (expected embree, bvh, naive or embree+naive)"
            )),
        }
    }
}

/// Options that shape how a backend is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AccelOptions {
    /// Embree's robust (watertight) mode, `RTC_SCENE_FLAG_ROBUST`. On by default.
    pub robust: bool,
    /// Build quality of the pure-Rust BVH (`--bvh-quality`).
    pub bvh_quality: bvh::BvhQuality,
}

impl Default for AccelOptions {
    fn default() -> Self {
        AccelOptions {
            robust: true,
            bvh_quality: bvh::BvhQuality::Fast,
        }
    }
}

/// Build the chosen backend over `soup`.
pub fn build(
    backend: Backend,
    soup: TriangleSoup<'_>,
    options: AccelOptions,
) -> Result<Box<dyn Accelerator>> {
    match backend {
        Backend::Naive => Ok(Box::new(naive::Naive::new(soup))),
        Backend::Bvh => Ok(Box::new(bvh::Bvh::new(soup, options.bvh_quality)?)),
        Backend::Embree => build_embree(soup, options),
        Backend::EmbreeNaive => Ok(Box::new(hybrid::Hybrid {
            packets: build_embree(soup, options)?,
            scattered: Box::new(naive::Naive::new(soup)),
        })),
    }
}

#[cfg(any(feature = "embree", feature = "embree4"))]
fn build_embree(soup: TriangleSoup<'_>, options: AccelOptions) -> Result<Box<dyn Accelerator>> {
    Ok(Box::new(embree::EmbreeAccel::new(soup, options)?))
}

#[cfg(not(any(feature = "embree", feature = "embree4")))]
fn build_embree(_: TriangleSoup<'_>, _: AccelOptions) -> Result<Box<dyn Accelerator>> {
    Err(crate::error::Error::Settings(
        "this binary was built without Embree (--no-default-features); use --accel bvh".to_string(),
    ))
}
