//! Alpha masks in Embree: the per-query context that carries the scene's
//! [`AlphaTest`] to the filter function, and the filter function itself.
//!
//! Embree calls a geometry's filter functions (`rtcSetGeometryIntersectFilterFunction`,
//! `rtcSetGeometryOccludedFilterFunction`) on every candidate hit, in no
//! particular order, and drops a hit whose `valid` entry the filter sets to
//! 0, then goes on searching. The filter gets the query's context pointer
//! back; Embree's API documents extending that context with user data (the
//! "Filter Functions" section of the Embree 3 and 4 references). [`Query`]
//! does so: the raw context first (`#[repr(C)]`, so a pointer to it is a
//! pointer to the whole), then the render-space ray of the query and the
//! mask. Every query on a scene built with `TriangleSoup::masked` passes a
//! `Query`, with no mask for the plain queries, so the filter may always
//! read one.
//!
//! The ray the filter receives from Embree is the instance's object-space
//! copy inside an instance; the [`AlphaTest`] is asked with the render-space
//! ray the caller gave instead, as the Rust backends do, and with the
//! crate's global primitive id, so every backend asks the same question.

use super::EmbreeAccel;
use super::sys;
use crate::accel::AlphaTest;
use crate::math::Ray;

/// The raw context type of the Embree version in use.
#[cfg(not(feature = "embree4"))]
pub(super) type RawContext = sys::RTCIntersectContext;
/// The raw context type of the Embree version in use.
#[cfg(feature = "embree4")]
pub(super) type RawContext = sys::RTCRayQueryContext;

/// A query's context: Embree's own, then what the filter needs.
#[repr(C)]
pub(super) struct Query<'a> {
    /// Embree's context; first, so that Embree's pointer to it is a pointer
    /// to the `Query`.
    pub(super) context: RawContext,
    /// The mask and the render-space ray it is asked with, for a masked
    /// query; `None` keeps every hit.
    mask: Option<(&'a dyn AlphaTest, &'a Ray)>,
    /// Maps Embree's IDs to the crate's primitive ids.
    accel: &'a EmbreeAccel,
    /// Whether the rays are coherent (a hint).
    pub(super) coherent: bool,
}

impl<'a> Query<'a> {
    /// A context for a query of `accel`, with `mask` (the scene's alpha test
    /// and the ray of this query) or none.
    pub(super) fn new(
        accel: &'a EmbreeAccel,
        mask: Option<(&'a dyn AlphaTest, &'a Ray)>,
        coherent: bool,
    ) -> Self {
        #[cfg(not(feature = "embree4"))]
        let context = {
            let mut c = sys::rtcInitIntersectContext();
            if coherent {
                c.flags = sys::RTCIntersectContextFlags::COHERENT;
            }
            c
        };
        #[cfg(feature = "embree4")]
        let context = sys::RTCRayQueryContext {
            instID: [sys::RTC_INVALID_GEOMETRY_ID; 1],
        };
        Query {
            context,
            mask,
            accel,
            coherent,
        }
    }
}

/// The filter function of a masked scene's triangle geometries: drops the
/// candidate hit when the query's mask ignores it.
///
/// # Safety
///
/// Embree calls it with `args` valid for the call, and the context pointer
/// inside is the one the query passed, which for a scene built with
/// `masked` is always a [`Query`] (see the module docs).
pub(super) unsafe extern "C" fn alpha_filter(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: `args` is valid for the duration of the call (Embree's filter
    // function contract).
    let args = unsafe { &*args };
    let query = args.context.cast::<Query<'_>>();
    // SAFETY: the context is the first field of a live `Query` (every query
    // on a masked scene passes one, `#[repr(C)]` puts the context at offset
    // 0). Only the `mask` and `accel` fields are read, by copy through the
    // raw pointer: Embree may be writing the context's instance stack, which
    // no reference made here covers.
    let (mask, accel) = unsafe { ((*query).mask, (*query).accel) };
    let Some((alpha, ray)) = mask else {
        return;
    };
    // masked queries are single rays (`rtcIntersect1`, `rtcOccluded1`);
    // packets never carry a mask
    if args.N != 1 {
        return;
    }
    // SAFETY: for N = 1 the hit record is one `RTCHit` (the structure of
    // arrays of width 1 has the single-hit layout, which is how Embree's
    // `RTCHitN_*` accessors read it), valid for the call.
    let hit = unsafe { &*args.hit.cast::<sys::RTCHit>() };
    let prim = accel.primitive(hit.geomID, hit.primID, hit.instID[0]);
    if alpha.ignores(ray, prim, hit.u, hit.v) {
        // SAFETY: `valid` points to N = 1 entries Embree reads back.
        unsafe { *args.valid = 0 };
    }
}
