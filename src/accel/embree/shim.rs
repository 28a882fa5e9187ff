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

use super::filter::Query;
use super::scene::Scene;
use super::sys;

/// Closest hit of `rayhit.ray` in `scene`; Embree writes `rayhit.hit` and,
/// on a hit, shortens `rayhit.ray.tfar` to the hit distance.
#[cfg(not(feature = "embree4"))]
pub(super) fn intersect1(scene: &Scene, query: &mut Query<'_>, rayhit: &mut sys::RTCRayHit) {
    // SAFETY: `scene.raw()` is a live committed scene (`Scene`'s invariant),
    // which Embree allows many threads to query at once. `query` (whose
    // first field is the context) and `rayhit` are valid, exclusive for the
    // call, and aligned (`RTCRayHit` is `align(16)` as Embree requires);
    // Embree keeps no pointer to them.
    unsafe { sys::rtcIntersect1(scene.raw(), &raw mut query.context, rayhit) }
}

/// Whether anything blocks `ray` in `scene`; Embree sets `ray.tfar` to
/// `-inf` when it does.
#[cfg(not(feature = "embree4"))]
pub(super) fn occluded1(scene: &Scene, query: &mut Query<'_>, ray: &mut sys::RTCRay) {
    // SAFETY: as in `intersect1` (`RTCRay` is `align(16)` too).
    unsafe { sys::rtcOccluded1(scene.raw(), &raw mut query.context, ray) }
}

/// Embree 4's query arguments: the defaults of `rtcInitIntersectArguments`
/// (incoherent unless `query.coherent`, every feature, no argument filter)
/// with `query`'s context.
#[cfg(feature = "embree4")]
fn arguments(query: &mut Query<'_>) -> sys::RTCIntersectArguments {
    sys::RTCIntersectArguments {
        flags: if query.coherent {
            sys::RTCRayQueryFlags::COHERENT
        } else {
            sys::RTCRayQueryFlags::INCOHERENT
        },
        feature_mask: sys::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
        context: &raw mut query.context,
        filter: None,
        intersect: None,
    }
}

/// Embree 4's occlusion arguments, as [`arguments`].
#[cfg(feature = "embree4")]
fn occluded_arguments(query: &mut Query<'_>) -> sys::RTCOccludedArguments {
    let a = arguments(query);
    sys::RTCOccludedArguments {
        flags: a.flags,
        feature_mask: a.feature_mask,
        context: a.context,
        filter: None,
        occluded: None,
    }
}

/// Closest hit of `rayhit.ray` in `scene`; Embree writes `rayhit.hit` and,
/// on a hit, shortens `rayhit.ray.tfar` to the hit distance.
#[cfg(feature = "embree4")]
pub(super) fn intersect1(scene: &Scene, query: &mut Query<'_>, rayhit: &mut sys::RTCRayHit) {
    let mut args = arguments(query);
    // SAFETY: `scene.raw()` is a live committed scene (`Scene`'s invariant),
    // which Embree allows many threads to query at once. `rayhit`, `args`
    // and the context it points to are valid, exclusive for the call and
    // aligned (`RTCRayHit` is `align(16)`); Embree keeps no pointer to them.
    unsafe { sys::rtcIntersect1(scene.raw(), rayhit, &raw mut args) }
}

/// Whether anything blocks `ray` in `scene`; Embree sets `ray.tfar` to
/// `-inf` when it does.
#[cfg(feature = "embree4")]
pub(super) fn occluded1(scene: &Scene, query: &mut Query<'_>, ray: &mut sys::RTCRay) {
    let mut args = occluded_arguments(query);
    // SAFETY: as in `intersect1` (`RTCRay` is `align(16)` too).
    unsafe { sys::rtcOccluded1(scene.raw(), ray, &raw mut args) }
}

/// The lane mask of a 16-wide packet query: `-1` marks a valid lane, `0`
/// one Embree must leave alone. Embree requires it aligned like the packet.
#[repr(C, align(64))]
#[derive(Debug, Clone, Copy)]
pub(super) struct Valid16(pub(super) [i32; 16]);

/// Closest hits of the valid lanes of the packet `rayhit` in `scene`
/// (`rtcIntersect16`); `query` says whether the rays are coherent (a hint).
#[cfg(not(feature = "embree4"))]
pub(super) fn intersect16(
    scene: &Scene,
    query: &mut Query<'_>,
    valid: &Valid16,
    rayhit: &mut sys::RTCRayHit16,
) {
    // SAFETY: `scene.raw()` is a live committed scene (`Scene`'s invariant),
    // which Embree allows many threads to query at once. `query`, `valid`
    // (16 ints) and `rayhit` (a 16-wide packet) are valid, exclusive for the
    // call and aligned (`Valid16` and `RTCRayHit16` are `align(64)`), as the
    // `rtcIntersect16` page requires; Embree keeps no pointer to them.
    unsafe {
        sys::rtcIntersect16(
            valid.0.as_ptr(),
            scene.raw(),
            &raw mut query.context,
            rayhit,
        )
    }
}

/// Whether anything blocks each valid lane of `ray` (`rtcOccluded16`);
/// Embree sets an occluded lane's `tfar` to `-inf`.
#[cfg(not(feature = "embree4"))]
pub(super) fn occluded16(
    scene: &Scene,
    query: &mut Query<'_>,
    valid: &Valid16,
    ray: &mut sys::RTCRay16,
) {
    // SAFETY: as in `intersect16` (`RTCRay16` is `align(64)` too).
    unsafe { sys::rtcOccluded16(valid.0.as_ptr(), scene.raw(), &raw mut query.context, ray) }
}

/// Embree 4's `rtcIntersect16`: as above.
#[cfg(feature = "embree4")]
pub(super) fn intersect16(
    scene: &Scene,
    query: &mut Query<'_>,
    valid: &Valid16,
    rayhit: &mut sys::RTCRayHit16,
) {
    let mut args = arguments(query);
    // SAFETY: as in the Embree 3 version; `args` and its context are valid
    // for the call.
    unsafe { sys::rtcIntersect16(valid.0.as_ptr(), scene.raw(), rayhit, &raw mut args) }
}

/// Embree 4's `rtcOccluded16`: as above.
#[cfg(feature = "embree4")]
pub(super) fn occluded16(
    scene: &Scene,
    query: &mut Query<'_>,
    valid: &Valid16,
    ray: &mut sys::RTCRay16,
) {
    let mut args = occluded_arguments(query);
    // SAFETY: as in the Embree 3 version.
    unsafe { sys::rtcOccluded16(valid.0.as_ptr(), scene.raw(), ray, &raw mut args) }
}
