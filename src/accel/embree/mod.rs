//! The Intel Embree backend, and the only `unsafe` code in the crate.
//!
//! Embree (Wald, Woop, Benthin, Johnson, Ernst, "Embree: A Kernel Framework
//! for Efficient CPU Ray Tracing", ACM TOG 33(4), 2014) answers the two ray
//! queries of [`Accelerator`] over one triangle mesh. API reference:
//! <https://github.com/RenderKit/embree/blob/v3.13.5/doc/src/api.md> (Embree
//! 3, the default `embree` feature) and
//! <https://github.com/RenderKit/embree/blob/master/doc/src/api.md> (Embree 4,
//! the `embree4` feature).
//!
//! Layout:
//! - `sys`: raw bindings (bindgen at build time for Embree 3, `embree4-sys`
//!   for Embree 4) plus the C macros and inline functions written in Rust;
//! - `shim`: the query calls (`rtcIntersect1`, `rtcOccluded1` and their
//!   16-wide forms), whose signatures differ between Embree 3 and 4;
//! - `filter`: the query context that carries an alpha mask to Embree's
//!   filter function, and that function;
//! - `device`, `scene`: RAII owners of `RTCDevice` and `RTCScene` (handles in
//!   `NonNull`, released in `Drop`; a scene owns its device and releases its
//!   own handle first, and a geometry under construction borrows the device,
//!   so no handle outlives its device) and the conversion of Embree's error
//!   callback into [`Error::Backend`](crate::Error::Backend);
//! - [`EmbreeAccel`]: the safe, `Send + Sync` accelerator.
//!
//! Hit meaning: the crate's convention is `0 < t <= t_max`; Embree reports
//! hits with `tnear <= t <= tfar` in robust mode (the Plücker test) but
//! `tnear < t <= tfar` in fast mode (the Möller-Trumbore test). With
//! `tnear = 0`, robust mode therefore reports hits at exactly `t == 0`: a ray
//! whose origin lies on a triangle (which the offset policy of
//! [`crate::math::offset_ray_origin`] produces whenever the error bound
//! projects to zero, e.g. on the plane `z = 0`) is "occluded" by its own
//! surface. In robust mode rays therefore go in with `tnear` = the smallest
//! positive `f32` (`TNEAR_ROBUST`), for which `tnear <= t` means exactly
//! `t > 0` as long as the calling thread does not set the denormals-are-zero
//! flag (Rust never does, and Embree sets it only on its own build threads);
//! in fast mode, where `tnear < t` already means `t > 0`, with `tnear = 0`
//! (a subnormal `tnear` there costs fast mode a third of its speed:
//! 10.6 against 14.9 Mrays/s for camera rays in the Cornell box, one
//! thread, `bench --no-robust`). `tfar = ray.t_max`. Rays with
//! `t_max == 0` never reach Embree: their hit range is empty.

mod device;
mod filter;
mod scene;
mod shim;
mod sys;
mod user;

#[cfg(test)]
mod tests;

use self::device::Device;
use self::filter::Query;
use self::scene::Scene;
use super::{AccelOptions, Accelerator, AlphaTest, Coherence, Hit, TriangleSoup};
use crate::error::Result;
use crate::math::Ray;
use std::sync::atomic::{AtomicU64, Ordering};

/// The version of the Embree library this process loaded, as `"4.4.0"`
/// (asked of a fresh device: the library found at run time, which may not be
/// the one the headers described).
pub fn library_version() -> Result<String> {
    let v = Device::new("")?.version();
    Ok(format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100))
}

// Embree requires 16-byte aligned single rays; the generated structs carry
// `align(16)` from `RTC_ALIGN(16)` in the header. Checked for both bindings.
const _: () = assert!(align_of::<sys::RTCRayHit>() >= 16 && align_of::<sys::RTCRay>() >= 16);

/// Ray queries answered by Intel Embree over one triangle mesh, the
/// spheres and the instances.
///
/// Built once from a [`TriangleSoup`] (Embree keeps its own copy of the
/// vertices and indices, one per prototype), then queried from any number
/// of threads. Embree transforms a ray into an instance's object space with
/// its own inverse of the placement's matrix, so its hits on instances may
/// differ from the pure-Rust backends' by that rounding.
#[derive(Debug)]
pub struct EmbreeAccel {
    scene: Scene,
    skipped_nonfinite: AtomicU64,
    /// Triangle count: sphere `i` is primitive `triangles + i`.
    triangles: u32,
    /// Per placement, the primitive id of its prototype's triangle 0.
    first_prims: Vec<u32>,
    /// `tnear` of every ray: [`TNEAR_ROBUST`] in robust mode, else 0.
    tnear: f32,
    /// Whether incoherent batches go to Embree as 16-wide packets: only
    /// where the CPU traces them natively (AVX-512). Elsewhere Embree splits
    /// a packet into narrower ones, and packets of incoherent rays lost to
    /// single-ray queries: the Cornell box at 256 x 256, 64 spp, one thread,
    /// on a 2-core AMD EPYC with AVX2, rendered in 8.4 s with packets for
    /// every batch and 7.0 s with single-ray queries for the incoherent
    /// ones (two alternating runs each). On an AVX-512 machine incoherent
    /// packets were about 10 % faster than single rays.
    incoherent_packets: bool,
}

// SAFETY: after `new` returns, the Embree handles inside are used only for
// `rtcIntersect1`/`rtcOccluded1` on a committed, never again modified scene
// (Embree allows those queries from many threads concurrently; its
// `rtcCommitScene` page requires only that modification, commit and tracing
// never overlap, which the absence of any `&mut` method here guarantees) and
// for release in `Drop`, which owns the value. Embree handles are not tied to
// the thread that created them. The device's error state is behind a `Mutex`.
unsafe impl Send for EmbreeAccel {}
// SAFETY: see `Send`: every `&self` method only queries the committed scene.
unsafe impl Sync for EmbreeAccel {}

impl EmbreeAccel {
    /// Build the scene over `soup` on a device with Embree's default
    /// configuration.
    ///
    /// # Errors
    ///
    /// [`Error::Backend`](crate::Error::Backend) when a triangle names a
    /// vertex past the end of `soup.positions`, or when Embree reports an
    /// error (out of memory, unsupported CPU, ...).
    pub fn new(soup: TriangleSoup<'_>, options: AccelOptions) -> Result<Self> {
        Self::with_device_config(soup, options, "")
    }

    /// Build the scene over `soup` on a device created with Embree's
    /// configuration string `config` (`rtcNewDevice`): empty for the
    /// defaults, or for example `"threads=1,isa=sse4.2"` to pin the build
    /// thread count and instruction set for reproducible CI runs.
    ///
    /// # Errors
    ///
    /// As [`EmbreeAccel::new`], plus [`Error::Settings`](crate::Error::Settings)
    /// for a `config` containing a NUL byte and
    /// [`Error::Backend`](crate::Error::Backend) for one Embree rejects.
    pub fn with_device_config(
        soup: TriangleSoup<'_>,
        options: AccelOptions,
        config: &str,
    ) -> Result<Self> {
        let device = Device::new(config)?;
        let scene = Scene::build(device, soup, options)?;
        Ok(EmbreeAccel {
            incoherent_packets: scene.device().native_ray16(),
            scene,
            skipped_nonfinite: AtomicU64::new(0),
            triangles: soup.indices.len() as u32,
            first_prims: soup
                .instances
                .placements
                .iter()
                .map(|p| p.first_prim)
                .collect(),
            tnear: if options.robust { TNEAR_ROBUST } else { 0.0 },
        })
    }

    /// How many rays with a non-finite origin, direction or extent, or an
    /// origin beyond [`crate::limits::MAX_COORDINATE`], were answered with a
    /// miss instead of being sent to Embree (release builds; debug builds
    /// panic on non-finite ones instead).
    pub fn skipped_nonfinite_rays(&self) -> u64 {
        self.skipped_nonfinite.load(Ordering::Relaxed)
    }

    /// Whether `ray` should go to Embree. Non-finite rays must not cross the
    /// FFI boundary: they trip a `debug_assert!`, and in release builds are
    /// counted and answered as misses. Rays with `t_max == 0` have an empty
    /// hit range `0 < t <= 0`.
    fn accepts(&self, ray: &Ray) -> bool {
        // Embree asserts (aborts, in Debian's build) on an origin beyond its
        // range (`FLT_LARGE`, 1.844e18); scenes keep every point within
        // `MAX_COORDINATE`, so only a bug could send one: count it too
        if !ray.is_finite() || ray.o.abs().max_element() > crate::limits::MAX_COORDINATE {
            // counted first, so that tests see the count in debug builds too
            self.skipped_nonfinite.fetch_add(1, Ordering::Relaxed);
            debug_assert!(ray.is_finite(), "non-finite ray sent to Embree: {ray:?}");
            return false;
        }
        ray.t_max > 0.0
    }
}

/// `tnear` of every ray in robust mode: the smallest positive `f32` (a
/// subnormal), so that Embree's `tnear <= t` accepts exactly the hits with
/// `t > 0` (see the module header); `0.0` would let robust mode report hits
/// at `t == 0`. Fast mode's test is `tnear < t`, so it takes `0.0`.
const TNEAR_ROBUST: f32 = f32::from_bits(1);

/// Embree's single ray for `ray`: `[tnear, t_max]`, all mask bits set (a mask
/// of 0 would silently miss every geometry), time 0.
fn to_rtc_ray(ray: &Ray, tnear: f32) -> sys::RTCRay {
    sys::RTCRay {
        org_x: ray.o.x,
        org_y: ray.o.y,
        org_z: ray.o.z,
        tnear,
        dir_x: ray.d.x,
        dir_y: ray.d.y,
        dir_z: ray.d.z,
        time: 0.0,
        tfar: ray.t_max,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// A hit record holding no hit (`geomID` and instance IDs invalid).
fn no_hit() -> sys::RTCHit {
    let mut hit = sys::RTCHit {
        primID: sys::RTC_INVALID_GEOMETRY_ID,
        geomID: sys::RTC_INVALID_GEOMETRY_ID,
        ..Default::default()
    };
    hit.instID.fill(sys::RTC_INVALID_GEOMETRY_ID);
    hit
}

/// Lanes of the packets the batch queries use.
const PACKET: usize = 16;

/// Fill the ray fields of packet lane `i` from `ray` (as [`to_rtc_ray`]).
fn put_lane(p: &mut sys::RTCRay16, i: usize, ray: &Ray, tnear: f32) {
    p.org_x[i] = ray.o.x;
    p.org_y[i] = ray.o.y;
    p.org_z[i] = ray.o.z;
    p.tnear[i] = tnear;
    p.dir_x[i] = ray.d.x;
    p.dir_y[i] = ray.d.y;
    p.dir_z[i] = ray.d.z;
    p.time[i] = 0.0;
    p.tfar[i] = ray.t_max;
    p.mask[i] = u32::MAX;
    p.id[i] = 0;
    p.flags[i] = 0;
}

impl EmbreeAccel {
    /// The packet for `rays` (at most [`PACKET`]) and its lane mask: lanes
    /// past the end and rays [`EmbreeAccel::accepts`] turns away are off.
    fn packet(&self, rays: &[Ray], p: &mut sys::RTCRay16) -> shim::Valid16 {
        let mut valid = shim::Valid16([0; PACKET]);
        for (i, ray) in rays.iter().enumerate() {
            if self.accepts(ray) {
                valid.0[i] = -1;
                put_lane(p, i, ray, self.tnear);
            }
        }
        valid
    }

    /// The crate's hit for lane `i` of a packet Embree answered.
    fn lane_hit(&self, h: &sys::RTCRayHit16, i: usize) -> Option<Hit> {
        let geom = h.hit.geomID[i];
        if geom == sys::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        Some(Hit {
            t: h.ray.tfar[i],
            prim: self.primitive(geom, h.hit.primID[i], h.hit.instID[0][i]),
            u: h.hit.u[i],
            v: h.hit.v[i],
        })
    }

    /// The crate's primitive id for Embree's geometry, primitive and
    /// (top-level) instance IDs of a hit.
    #[inline]
    fn primitive(&self, geom: u32, prim: u32, inst: u32) -> u32 {
        if inst != sys::RTC_INVALID_GEOMETRY_ID {
            let k = inst.wrapping_sub(self.scene.instance_geometry()) as usize;
            self.first_prims[k] + prim
        } else if geom == self.scene.sphere_geometry() {
            self.triangles + prim
        } else {
            prim
        }
    }
}

impl Accelerator for EmbreeAccel {
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>], coherence: Coherence) {
        debug_assert_eq!(rays.len(), hits.len());
        if coherence == Coherence::Incoherent && !self.incoherent_packets {
            for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
                *hit = self.intersect(ray);
            }
            return;
        }
        let mut packet = sys::RTCRayHit16 {
            ray: sys::ray16(),
            hit: sys::no_hit16(),
        };
        for (rays, hits) in rays.chunks(PACKET).zip(hits.chunks_mut(PACKET)) {
            let valid = self.packet(rays, &mut packet.ray);
            packet.hit = sys::no_hit16();
            let mut query = Query::new(self, None, coherence == Coherence::Coherent);
            shim::intersect16(&self.scene, &mut query, &valid, &mut packet);
            for (i, hit) in hits.iter_mut().enumerate() {
                *hit = if valid.0[i] != 0 {
                    self.lane_hit(&packet, i)
                } else {
                    None
                };
            }
        }
    }

    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool], coherence: Coherence) {
        debug_assert_eq!(rays.len(), occluded.len());
        if coherence == Coherence::Incoherent && !self.incoherent_packets {
            for (ray, o) in rays.iter().zip(occluded.iter_mut()) {
                *o = self.occluded(ray);
            }
            return;
        }
        let mut packet = sys::ray16();
        for (rays, out) in rays.chunks(PACKET).zip(occluded.chunks_mut(PACKET)) {
            let valid = self.packet(rays, &mut packet);
            let mut query = Query::new(self, None, coherence == Coherence::Coherent);
            shim::occluded16(&self.scene, &mut query, &valid, &mut packet);
            for (i, o) in out.iter_mut().enumerate() {
                *o = valid.0[i] != 0 && packet.tfar[i] == f32::NEG_INFINITY;
            }
        }
    }

    fn memory_bytes(&self) -> usize {
        self.scene.device().memory_bytes()
    }

    fn name(&self) -> &'static str {
        "embree"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.closest(ray, None)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.blocked(ray, None)
    }

    fn intersect_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> Option<Hit> {
        self.closest(ray, Some(alpha))
    }

    fn occluded_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> bool {
        self.blocked(ray, Some(alpha))
    }
}

impl EmbreeAccel {
    /// `rtcIntersect1`, with `alpha` cutting holes when the scene was built
    /// masked (see `filter`).
    #[inline]
    fn closest(&self, ray: &Ray, alpha: Option<&dyn AlphaTest>) -> Option<Hit> {
        if !self.accepts(ray) {
            return None;
        }
        let mut rayhit = sys::RTCRayHit {
            ray: to_rtc_ray(ray, self.tnear),
            hit: no_hit(),
        };
        let mut query = Query::new(self, alpha.map(|a| (a, ray)), false);
        shim::intersect1(&self.scene, &mut query, &mut rayhit);
        let hit = rayhit.hit;
        if hit.geomID == sys::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        Some(Hit {
            t: rayhit.ray.tfar,
            prim: self.primitive(hit.geomID, hit.primID, hit.instID[0]),
            u: hit.u,
            v: hit.v,
        })
    }

    /// `rtcOccluded1`, with `alpha` as in [`EmbreeAccel::closest`].
    #[inline]
    fn blocked(&self, ray: &Ray, alpha: Option<&dyn AlphaTest>) -> bool {
        if !self.accepts(ray) {
            return false;
        }
        let mut rtc_ray = to_rtc_ray(ray, self.tnear);
        let mut query = Query::new(self, alpha.map(|a| (a, ray)), false);
        shim::occluded1(&self.scene, &mut query, &mut rtc_ray);
        rtc_ray.tfar == f32::NEG_INFINITY
    }
}
