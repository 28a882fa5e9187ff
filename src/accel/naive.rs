//! The brute-force backend: every ray is tested against every triangle with
//! the watertight routine of [`super::triangle`], sixteen at a time in index
//! order ([`super::wide`]), each lane answering bit for bit as the BVH's
//! four-wide leaf test. Quadratic: the oracle the other backends are
//! checked against; on scenes of a few dozen triangles its single-ray
//! queries outrun Embree's (1.2x to 1.5x on the Cornell box's incoherent
//! rays, `embertrace bench`).

use super::instance::{InstanceSet, PrototypeQuery};
use super::sphere::SphereSet;
use super::triangle::WatertightRay;
use super::wide::{LANES, Tri16};
use super::{Accelerator, AlphaTest, Coherence, Hit, HitFilter, Masks, Opaque, TriangleSoup};
use crate::math::{Ray, Vec3};
use crate::simd::{Dispatch, Level};

/// Brute force over a copy of the triangles, in blocks of sixteen, then over
/// the spheres (which a small tree holds: it answers exactly as a scan, see
/// [`SphereSet`]'s tests), then over every placement of every instanced
/// prototype, in order, each prototype brute-forced in object space.
pub struct Naive {
    blocks: Vec<Tri16>,
    /// Triangles in the last block (1 to 16).
    last: usize,
    /// The instruction set the tests run with ([`crate::simd`]; the same
    /// answers, bit for bit, on every level).
    simd: Dispatch,
    spheres: SphereSet,
    instances: InstanceSet<Naive>,
}

impl Naive {
    /// Copy the triangles of `soup`.
    pub fn new(soup: TriangleSoup<'_>) -> Self {
        Self::with_simd(soup, crate::simd::active())
    }

    /// [`Naive::new`], testing with the instruction set of `level`.
    pub fn with_simd(soup: TriangleSoup<'_>, level: Level) -> Self {
        let tris: Vec<(u32, [Vec3; 3])> = soup
            .indices
            .iter()
            .enumerate()
            .map(|(i, t)| (i as u32, t.map(|k| soup.positions[k as usize])))
            .collect();
        let blocks = tris.chunks(LANES).map(Tri16::new).collect();
        let last = tris.len().saturating_sub(1) % LANES + 1;
        let instances = InstanceSet::new(soup.instances, false, |p| {
            Ok::<_, std::convert::Infallible>(Naive::with_simd(
                TriangleSoup::triangles(&p.positions, &p.indices),
                level,
            ))
        });
        Naive {
            blocks,
            last,
            simd: level.dispatcher(),
            spheres: SphereSet::new(soup.spheres, soup.indices.len() as u32),
            instances: match instances {
                Ok(set) => set,
                Err(never) => match never {},
            },
        }
    }

    /// The closest of the triangle hit `best` of the finite `ray` and the
    /// spheres' and placements' hits (`alpha` cutting the placements'
    /// triangles).
    #[inline]
    fn with_others(
        &self,
        ray: &Ray,
        best: Option<Hit>,
        alpha: Option<&dyn AlphaTest>,
    ) -> Option<Hit> {
        let best = with_spheres(&self.spheres, ray, best);
        self.instances.closest(ray, best, alpha)
    }

    /// Each block with its lane mask.
    #[inline(always)]
    fn blocks(&self) -> impl Iterator<Item = (&Tri16, u32)> {
        let n = self.blocks.len();
        self.blocks.iter().enumerate().map(move |(i, b)| {
            let count = if i + 1 == n { self.last } else { LANES };
            (b, (1u32 << count).wrapping_sub(1))
        })
    }
}

impl Accelerator for Naive {
    fn name(&self) -> &'static str {
        "naive"
    }

    fn memory_bytes(&self) -> usize {
        self.blocks.capacity() * std::mem::size_of::<Tri16>()
            + self.spheres.memory_bytes()
            + self.instances.memory_bytes()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_finite() {
            return None;
        }
        self.with_others(ray, self.closest_triangle(ray, &Opaque), None)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_finite() {
            return false;
        }
        self.any_triangle(ray, &Opaque) || self.spheres.any(ray) || self.instances.any(ray, None)
    }

    /// [`Accelerator::intersect`] for each ray, the triangles' scans in one
    /// dispatch to the instruction set instead of one per ray (the same
    /// answers).
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>], _: Coherence) {
        debug_assert_eq!(rays.len(), hits.len());
        self.simd.run(ClosestEach {
            naive: self,
            rays,
            hits: &mut *hits,
        });
        if self.spheres.is_empty() && self.instances.is_empty() {
            return;
        }
        for (ray, hit) in rays.iter().zip(hits) {
            if ray.is_finite() {
                *hit = self.with_others(ray, *hit, None);
            }
        }
    }

    fn intersect_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> Option<Hit> {
        if !ray.is_finite() {
            return None;
        }
        let masks = Masks {
            alpha,
            ray,
            first_prim: 0,
        };
        self.with_others(ray, self.closest_triangle(ray, &masks), Some(alpha))
    }

    fn occluded_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> bool {
        if !ray.is_finite() {
            return false;
        }
        let masks = Masks {
            alpha,
            ray,
            first_prim: 0,
        };
        self.any_triangle(ray, &masks)
            || self.spheres.any(ray)
            || self.instances.any(ray, Some(alpha))
    }
}

impl PrototypeQuery for Naive {
    fn closest_triangle<F: HitFilter>(&self, ray: &Ray, filter: &F) -> Option<Hit> {
        if !ray.is_finite() {
            return None;
        }
        self.simd.run(Closest {
            naive: self,
            ray,
            filter,
        })
    }

    fn any_triangle<F: HitFilter>(&self, ray: &Ray, filter: &F) -> bool {
        if !ray.is_finite() {
            return false;
        }
        self.simd.run(Any {
            naive: self,
            ray,
            filter,
        })
    }
}

/// A closest-hit scan, run by [`Dispatch::run`] so that the inlined
/// sixteen-wide test compiles for the chosen instruction set.
struct Closest<'q, F> {
    naive: &'q Naive,
    ray: &'q Ray,
    filter: &'q F,
}

impl<F: HitFilter> pulp::WithSimd for Closest<'_, F> {
    type Output = Option<Hit>;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Option<Hit> {
        self.naive.scan_closest(simd, self.ray, self.filter)
    }
}

/// [`Closest`] over the triangles alone for each of a batch's rays (none
/// for a non-finite ray), in one run.
struct ClosestEach<'q> {
    naive: &'q Naive,
    rays: &'q [Ray],
    hits: &'q mut [Option<Hit>],
}

impl pulp::WithSimd for ClosestEach<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        for (ray, hit) in self.rays.iter().zip(self.hits) {
            *hit = if ray.is_finite() {
                self.naive.scan_closest(simd, ray, &Opaque)
            } else {
                None
            };
        }
    }
}

impl Naive {
    /// The closest triangle hit of `ray` that `filter` keeps, block by
    /// block in index order.
    #[inline(always)]
    fn scan_closest<S: pulp::Simd, F: HitFilter>(
        &self,
        simd: S,
        ray: &Ray,
        filter: &F,
    ) -> Option<Hit> {
        let wr = WatertightRay::new(ray);
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        for (block, lanes) in self.blocks() {
            wr.intersect16(simd, block, lanes, t_max)
                .fold_closest(block, &mut best, &mut t_max, filter);
        }
        best
    }
}

/// An any-hit scan, as [`Closest`].
struct Any<'q, F> {
    naive: &'q Naive,
    ray: &'q Ray,
    filter: &'q F,
}

impl<F: HitFilter> pulp::WithSimd for Any<'_, F> {
    type Output = bool;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> bool {
        let wr = WatertightRay::new(self.ray);
        // a loop, not `Iterator::any`: its closure is not inlined into the
        // function compiled for the instruction set, and the test's
        // compares would then be calls
        for (block, lanes) in self.naive.blocks() {
            if wr
                .intersect16(simd, block, lanes, self.ray.t_max)
                .any_kept(block, self.filter)
            {
                return true;
            }
        }
        false
    }
}

/// The closest of the triangle hit `best` and the spheres' (a sphere wins
/// only at a smaller `t`: on a tie the triangle's lower index wins).
#[inline]
pub(super) fn with_spheres(spheres: &SphereSet, ray: &Ray, best: Option<Hit>) -> Option<Hit> {
    if spheres.is_empty() {
        return best;
    }
    let mut s = best.map(|h| (h.t, h.prim));
    spheres.closest(ray, &mut s);
    match s {
        Some((t, prim)) if best.is_none_or(|h| h.prim != prim) => Some(Hit {
            t,
            prim,
            u: 0.0,
            v: 0.0,
        }),
        _ => best,
    }
}
