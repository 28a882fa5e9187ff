//! Analytic spheres in Embree: an `RTC_GEOMETRY_TYPE_USER` geometry whose
//! bounds, intersect and occluded callbacks run the crate's own ray-sphere
//! routine ([`crate::accel::sphere::intersect_sphere`]), so Embree reports
//! the same `t` as the pure-Rust backends, bit for bit.
//!
//! Embree API reference: `RTC_GEOMETRY_TYPE_USER`,
//! `rtcSetGeometryUserPrimitiveCount`, `rtcSetGeometryBoundsFunction`,
//! `rtcSetGeometryIntersectFunction`, `rtcSetGeometryOccludedFunction`, and
//! the `RTCRayN`/`RTCHitN` layout (`rtcore_ray.h`): a ray packet of width `N`
//! stores each field as an array of `N` 4-byte values, in the order
//! `org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar, mask, id,
//! flags`, and the hit follows as `Ng_x, Ng_y, Ng_z, u, v, primID, geomID,
//! instID[..]`. That order is the same in Embree 3 and 4 for every field
//! used here, so the callbacks serve both bindings.
//!
//! The callbacks never panic (no unwinding may cross the FFI boundary): they
//! do plain arithmetic on the sphere array the geometry's user pointer names.

use super::sys;
use crate::accel::sphere::{intersect_sphere, sphere_bounds};
use crate::math::Vec3;
use crate::shape::Sphere;
use std::os::raw::c_void;

/// Field indices in a packet, in units of `N` 4-byte values.
const ORG_X: usize = 0;
const TNEAR: usize = 3;
const DIR_X: usize = 4;
const TFAR: usize = 8;
/// The hit starts after the ray's 12 fields.
const HIT: usize = 12;
const NG_X: usize = HIT;
const U: usize = HIT + 3;
const V: usize = HIT + 4;
const PRIM_ID: usize = HIT + 5;
const GEOM_ID: usize = HIT + 6;
const INST_ID: usize = HIT + 7;

/// The spheres a user geometry answers for; its user pointer points here.
/// The owner (the Embree `Scene`) keeps it alive and unmoved (boxed) for as
/// long as the geometry can be queried.
#[derive(Debug)]
pub(super) struct SphereData {
    pub(super) spheres: Box<[Sphere]>,
}

/// The `RTCBoundsFunction`: the padded box of sphere `primID`.
///
/// # Safety
///
/// Embree calls it with valid `args`, whose user pointer is the
/// `SphereData` registered with the geometry and whose `primID` is below the
/// primitive count set from that data.
pub(super) unsafe extern "C" fn bounds(args: *const sys::RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes a valid, readable argument struct.
    let args = unsafe { &*args };
    // SAFETY: the user pointer is the live `SphereData` (see above).
    let data = unsafe { &*(args.geometryUserPtr as *const SphereData) };
    let Some(s) = data.spheres.get(args.primID as usize) else {
        return;
    };
    let (lo, hi) = sphere_bounds(s);
    // SAFETY: `bounds_o` points to a writable `RTCBounds` for this call.
    unsafe {
        *args.bounds_o = sys::RTCBounds {
            lower_x: lo.x,
            lower_y: lo.y,
            lower_z: lo.z,
            align0: 0.0,
            upper_x: hi.x,
            upper_y: hi.y,
            upper_z: hi.z,
            align1: 0.0,
        };
    }
}

/// Read lane `i`'s origin, direction, `tnear` and `tfar` from a packet of
/// width `n` at `base`.
///
/// # Safety
///
/// `base` must point to an `RTCRayN` of width `n` with `i < n`.
unsafe fn read_ray(base: *const f32, n: usize, i: usize) -> (Vec3, Vec3, f32, f32) {
    // SAFETY: every index is `field * n + i` with `field < 12` and `i < n`,
    // inside the packet.
    unsafe {
        let at = |field: usize| *base.add(field * n + i);
        (
            Vec3::new(at(ORG_X), at(ORG_X + 1), at(ORG_X + 2)),
            Vec3::new(at(DIR_X), at(DIR_X + 1), at(DIR_X + 2)),
            at(TNEAR),
            at(TFAR),
        )
    }
}

/// The `RTCIntersectFunctionN`: for each valid lane, the nearest sphere hit
/// in `[tnear, tfar]` shortens `tfar` and fills the hit.
///
/// # Safety
///
/// Embree calls it with valid `args`: `valid` and `rayhit` point to packets
/// of width `N`, the user pointer is the registered `SphereData`, and
/// `primID` is one of its spheres.
pub(super) unsafe extern "C" fn intersect(args: *const sys::RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes a valid, readable argument struct.
    let args = unsafe { &*args };
    // SAFETY: the user pointer is the live `SphereData`.
    let data = unsafe { &*(args.geometryUserPtr as *const SphereData) };
    let Some(s) = data.spheres.get(args.primID as usize) else {
        return;
    };
    let n = args.N as usize;
    let base = args.rayhit as *mut f32;
    for i in 0..n {
        // SAFETY: `valid` holds `N` ints.
        if unsafe { *args.valid.add(i) } == 0 {
            continue;
        }
        // SAFETY: `rayhit` is an `RTCRayHitN` of width `N` and `i < N`.
        let (o, d, tnear, tfar) = unsafe { read_ray(base, n, i) };
        let Some(t) = intersect_sphere(o, d, tfar, s) else {
            continue;
        };
        if t < tnear {
            continue;
        }
        let ng = o + t * d - s.center;
        // SAFETY: the ray's `tfar` and the hit fields up to `instID[0]` lie
        // inside the packet (`field * N + i`, `field <= INST_ID`); Embree
        // hands the packet to this callback exclusively for the call.
        unsafe {
            let put = |field: usize, v: f32| *base.add(field * n + i) = v;
            let put_u32 = |field: usize, v: u32| *(base.add(field * n + i) as *mut u32) = v;
            put(TFAR, t);
            put(NG_X, ng.x);
            put(NG_X + 1, ng.y);
            put(NG_X + 2, ng.z);
            put(U, 0.0);
            put(V, 0.0);
            put_u32(PRIM_ID, args.primID);
            put_u32(GEOM_ID, args.geomID);
            put_u32(INST_ID, sys::RTC_INVALID_GEOMETRY_ID);
        }
    }
}

/// The `RTCOccludedFunctionN`: a valid lane that hits the sphere in
/// `[tnear, tfar]` gets `tfar = -inf`, Embree's mark of an occluded ray.
///
/// # Safety
///
/// As for [`intersect`], with `ray` an `RTCRayN` of width `N`.
pub(super) unsafe extern "C" fn occluded(args: *const sys::RTCOccludedFunctionNArguments) {
    // SAFETY: Embree passes a valid, readable argument struct.
    let args = unsafe { &*args };
    // SAFETY: the user pointer is the live `SphereData`.
    let data = unsafe { &*(args.geometryUserPtr as *const SphereData) };
    let Some(s) = data.spheres.get(args.primID as usize) else {
        return;
    };
    let n = args.N as usize;
    let base = args.ray as *mut f32;
    for i in 0..n {
        // SAFETY: `valid` holds `N` ints.
        if unsafe { *args.valid.add(i) } == 0 {
            continue;
        }
        // SAFETY: `ray` is an `RTCRayN` of width `N` and `i < N`.
        let (o, d, tnear, tfar) = unsafe { read_ray(base, n, i) };
        if intersect_sphere(o, d, tfar, s).is_some_and(|t| t >= tnear) {
            // SAFETY: `tfar` of lane `i` is inside the packet, which Embree
            // hands to this callback exclusively for the call.
            unsafe { *base.add(TFAR * n + i) = f32::NEG_INFINITY };
        }
    }
}

/// The user pointer for `data`: Embree only passes it back to the callbacks
/// above, which read through it.
pub(super) fn user_ptr(data: &SphereData) -> *mut c_void {
    data as *const SphereData as *mut c_void
}
