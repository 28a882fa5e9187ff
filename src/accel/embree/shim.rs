//! The one place where Embree 3 and Embree 4 differ for this crate: the
//! single-ray query signatures.
//!
//! - Embree 3: `rtcIntersect1(scene, RTCIntersectContext*, RTCRayHit*)` and
//!   `rtcOccluded1(scene, RTCIntersectContext*, RTCRay*)`, with a context set
//!   up by `rtcInitIntersectContext`.
//! - Embree 4: `rtcIntersect1(scene, RTCRayHit*, RTCIntersectArguments*)` and
//!   `rtcOccluded1(scene, RTCRay*, RTCOccludedArguments*)`, where NULL
//!   arguments mean the defaults.
//!
//! See the `rtcIntersect1` and `rtcOccluded1` pages of the Embree 3 and 4 API
//! references (<https://github.com/RenderKit/embree/tree/master/doc/src>).
//! Neither call reports errors ("for performance reasons this function does
//! not do any error checks"), so there is nothing to check afterwards.

use super::scene::Scene;
use super::sys;

/// Closest hit of `rayhit.ray` in `scene`; Embree writes `rayhit.hit` and,
/// on a hit, shortens `rayhit.ray.tfar` to the hit distance.
#[cfg(not(feature = "embree4"))]
pub(super) fn intersect1(scene: &Scene, rayhit: &mut sys::RTCRayHit) {
    let mut context = sys::rtcInitIntersectContext();
    // SAFETY: `scene.raw()` is a live committed scene (`Scene`'s invariant),
    // which Embree allows many threads to query at once. `context` and
    // `rayhit` are valid, exclusive for the call, and aligned (`RTCRayHit` is
    // `align(16)` as Embree requires); Embree keeps no pointer to them.
    unsafe { sys::rtcIntersect1(scene.raw(), &raw mut context, rayhit) }
}

/// Whether anything blocks `ray` in `scene`; Embree sets `ray.tfar` to
/// `-inf` when it does.
#[cfg(not(feature = "embree4"))]
pub(super) fn occluded1(scene: &Scene, ray: &mut sys::RTCRay) {
    let mut context = sys::rtcInitIntersectContext();
    // SAFETY: as in `intersect1` (`RTCRay` is `align(16)` too).
    unsafe { sys::rtcOccluded1(scene.raw(), &raw mut context, ray) }
}

/// Closest hit of `rayhit.ray` in `scene`; Embree writes `rayhit.hit` and,
/// on a hit, shortens `rayhit.ray.tfar` to the hit distance.
#[cfg(feature = "embree4")]
pub(super) fn intersect1(scene: &Scene, rayhit: &mut sys::RTCRayHit) {
    // SAFETY: `scene.raw()` is a live committed scene (`Scene`'s invariant),
    // which Embree allows many threads to query at once. `rayhit` is valid,
    // exclusive for the call and aligned (`RTCRayHit` is `align(16)`); NULL
    // arguments are documented to mean the defaults.
    unsafe { sys::rtcIntersect1(scene.raw(), rayhit, std::ptr::null_mut()) }
}

/// Whether anything blocks `ray` in `scene`; Embree sets `ray.tfar` to
/// `-inf` when it does.
#[cfg(feature = "embree4")]
pub(super) fn occluded1(scene: &Scene, ray: &mut sys::RTCRay) {
    // SAFETY: as in `intersect1` (`RTCRay` is `align(16)` too).
    unsafe { sys::rtcOccluded1(scene.raw(), ray, std::ptr::null_mut()) }
}

/// The lane mask of a 16-wide packet query: `-1` marks a valid lane, `0`
/// one Embree must leave alone. Embree requires it aligned like the packet.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy)]
pub(super) struct Valid16(pub(super) [i32; 16]);

/// Closest hits of the valid lanes of the packet `rayhit` in `scene`
/// (`rtcIntersect16`); `coherent` tells Embree 3 the rays are coherent (a
/// hint only: Embree 4's default arguments are used there).
#[cfg(not(feature = "embree4"))]
pub(super) fn intersect16(
    scene: &Scene,
    valid: &Valid16,
    rayhit: &mut sys::RTCRayHit16,
    coherent: bool,
) {
    let mut context = sys::rtcInitIntersectContext();
    if coherent {
        context.flags = sys::RTCIntersectContextFlags::COHERENT;
    }
    // SAFETY: `scene.raw()` is a live committed scene (`Scene`'s invariant),
    // which Embree allows many threads to query at once. `valid` (16 ints)
    // and `rayhit` (a 16-wide packet) are valid, exclusive for the call and
    // 64-byte aligned (`Valid16` and `RTCRayHit16` are `align(64)`), as the
    // `rtcIntersect16` page requires; Embree keeps no pointer to them.
    unsafe { sys::rtcIntersect16(valid.0.as_ptr(), scene.raw(), &raw mut context, rayhit) }
}

/// Whether anything blocks each valid lane of `ray` (`rtcOccluded16`);
/// Embree sets an occluded lane's `tfar` to `-inf`.
#[cfg(not(feature = "embree4"))]
pub(super) fn occluded16(scene: &Scene, valid: &Valid16, ray: &mut sys::RTCRay16, coherent: bool) {
    let mut context = sys::rtcInitIntersectContext();
    if coherent {
        context.flags = sys::RTCIntersectContextFlags::COHERENT;
    }
    // SAFETY: as in `intersect16` (`RTCRay16` is `align(64)` too).
    unsafe { sys::rtcOccluded16(valid.0.as_ptr(), scene.raw(), &raw mut context, ray) }
}

/// Embree 4's `rtcIntersect16`: as above, with the default arguments.
#[cfg(feature = "embree4")]
pub(super) fn intersect16(
    scene: &Scene,
    valid: &Valid16,
    rayhit: &mut sys::RTCRayHit16,
    _coherent: bool,
) {
    // SAFETY: as in the Embree 3 version; NULL arguments are documented to
    // mean the defaults.
    unsafe { sys::rtcIntersect16(valid.0.as_ptr(), scene.raw(), rayhit, std::ptr::null_mut()) }
}

/// Embree 4's `rtcOccluded16`: as above, with the default arguments.
#[cfg(feature = "embree4")]
pub(super) fn occluded16(scene: &Scene, valid: &Valid16, ray: &mut sys::RTCRay16, _coherent: bool) {
    // SAFETY: as in the Embree 3 version.
    unsafe { sys::rtcOccluded16(valid.0.as_ptr(), scene.raw(), ray, std::ptr::null_mut()) }
}
