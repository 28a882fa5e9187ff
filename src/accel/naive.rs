//! The brute-force backend: every ray is tested against every triangle with
//! the watertight routine of [`super::triangle`], four at a time in index
//! order, exactly as the BVH runs it in its leaves. Quadratic and slow; it is
//! the oracle the other backends are checked against.

use super::instance::{InstanceSet, PrototypeQuery};
use super::sphere::SphereSet;
use super::triangle::{Tri4, WatertightRay};
use super::{Accelerator, AlphaTest, Hit, HitFilter, Masks, Opaque, TriangleSoup};
use crate::math::{Ray, Vec3};

/// Brute force over a copy of the triangles, in blocks of four, then over
/// the spheres (which a small tree holds: it answers exactly as a scan, see
/// [`SphereSet`]'s tests), then over every placement of every instanced
/// prototype, in order, each prototype brute-forced in object space.
pub struct Naive {
    blocks: Vec<Tri4>,
    /// Triangles in the last block (1 to 4).
    last: usize,
    spheres: SphereSet,
    instances: InstanceSet<Naive>,
}

impl Naive {
    /// Copy the triangles of `soup`.
    pub fn new(soup: TriangleSoup<'_>) -> Self {
        let tris: Vec<(u32, [Vec3; 3])> = soup
            .indices
            .iter()
            .enumerate()
            .map(|(i, t)| (i as u32, t.map(|k| soup.positions[k as usize])))
            .collect();
        let blocks = tris.chunks(4).map(Tri4::new).collect();
        let last = tris.len().saturating_sub(1) % 4 + 1;
        let instances = InstanceSet::new(soup.instances, false, |p| {
            Ok::<_, std::convert::Infallible>(Naive::new(TriangleSoup::triangles(
                &p.positions,
                &p.indices,
            )))
        });
        Naive {
            blocks,
            last,
            spheres: SphereSet::new(soup.spheres, soup.indices.len() as u32),
            instances: match instances {
                Ok(set) => set,
                Err(never) => match never {},
            },
        }
    }

    /// Each block with its lane mask.
    fn blocks(&self) -> impl Iterator<Item = (&Tri4, u32)> {
        let n = self.blocks.len();
        self.blocks.iter().enumerate().map(move |(i, b)| {
            let count = if i + 1 == n { self.last } else { 4 };
            (b, (1 << count) - 1)
        })
    }
}

impl Accelerator for Naive {
    fn name(&self) -> &'static str {
        "naive"
    }

    fn memory_bytes(&self) -> usize {
        self.blocks.capacity() * std::mem::size_of::<Tri4>()
            + self.spheres.memory_bytes()
            + self.instances.memory_bytes()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_finite() {
            return None;
        }
        let best = self.closest_triangle(ray, &Opaque);
        let best = with_spheres(&self.spheres, ray, best);
        self.instances.closest(ray, best, None)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_finite() {
            return false;
        }
        self.any_triangle(ray, &Opaque) || self.spheres.any(ray) || self.instances.any(ray, None)
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
        let best = self.closest_triangle(ray, &masks);
        let best = with_spheres(&self.spheres, ray, best);
        self.instances.closest(ray, best, Some(alpha))
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
        let wr = WatertightRay::new(ray);
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        for (block, lanes) in self.blocks() {
            wr.intersect4(block, lanes, t_max)
                .fold_closest(block, &mut best, &mut t_max, filter);
        }
        best
    }

    fn any_triangle<F: HitFilter>(&self, ray: &Ray, filter: &F) -> bool {
        if !ray.is_finite() {
            return false;
        }
        let wr = WatertightRay::new(ray);
        self.blocks().any(|(block, lanes)| {
            wr.intersect4(block, lanes, ray.t_max)
                .any_kept(block, filter)
        })
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
