//! [`Scene`]: a committed Embree scene holding one triangle mesh, one user
//! geometry of analytic spheres, and one instance geometry per placement of
//! a prototype (each prototype a committed child scene of its own, shared by
//! its placements), built from a [`TriangleSoup`].
//!
//! Embree API reference: `rtcNewScene`, `rtcSetSceneFlags`,
//! `rtcSetSceneBuildQuality`, `rtcNewGeometry`, `rtcSetNewGeometryBuffer`,
//! `rtcCommitGeometry`, `rtcAttachGeometry`, `rtcReleaseGeometry`,
//! `rtcCommitScene`, `rtcReleaseScene`, the `RTC_GEOMETRY_TYPE_TRIANGLE`
//! and `RTC_GEOMETRY_TYPE_INSTANCE` pages, `rtcSetGeometryInstancedScene`
//! and `rtcSetGeometryTransform`
//! (<https://github.com/RenderKit/embree/blob/v3.13.5/doc/src/api.md>).

use super::device::{Device, backend_error};
use super::sys;
use super::user::{self, SphereData};
use crate::accel::{AccelOptions, Instances, TriangleSoup};
use crate::error::Result;
use crate::shape::Sphere;
use std::ptr::NonNull;

/// Build quality of both the mesh BVH and the scene BVH. `HIGH` (spatial
/// splits) costs build time once and pays back on every ray of a path
/// tracer's many bounces.
const BUILD_QUALITY: sys::RTCBuildQuality = sys::RTCBuildQuality::HIGH;

/// A committed Embree scene (`RTCScene`).
///
/// Invariant: every `Scene` that [`Scene::build`] returns is committed and
/// never modified again, so it may be queried from many threads at once.
///
/// The scene owns the [`Device`] it was created on (one device per scene), so
/// the device cannot be dropped, moved out or released while the scene
/// exists: `Drop` releases the scene handle, and only afterwards does the
/// `device` field drop and release the device.
#[derive(Debug)]
pub(super) struct Scene {
    handle: NonNull<sys::RTCSceneTy>,
    device: Device,
    /// The spheres the user geometry's callbacks read (boxed: Embree holds
    /// a pointer to it), kept until after the scene is released.
    spheres: Option<Box<SphereData>>,
    /// The sphere geometry's ID, or `RTC_INVALID_GEOMETRY_ID` when there
    /// are no spheres.
    sphere_geom: u32,
    /// One committed child scene per prototype, released after this scene
    /// (whose instance geometries name them).
    prototypes: Vec<NonNull<sys::RTCSceneTy>>,
    /// The geometry ID of placement 0's instance; placement `k` has
    /// `instance_geom + k`.
    instance_geom: u32,
}

impl Scene {
    /// Build and commit a scene holding the triangles of `soup` (none is
    /// fine: an empty scene is committed and every ray misses it).
    pub(super) fn build(
        device: Device,
        soup: TriangleSoup<'_>,
        options: AccelOptions,
    ) -> Result<Scene> {
        validate(soup)?;
        // SAFETY: `device` is a live device (we own it).
        let raw = unsafe { sys::rtcNewScene(device.raw()) };
        let Some(handle) = NonNull::new(raw) else {
            device.check("rtcNewScene")?;
            return Err(backend_error("rtcNewScene returned NULL".into()));
        };
        // From here on `scene` owns both handles and releases them on any error.
        let mut scene = Scene {
            handle,
            device,
            spheres: None,
            sphere_geom: sys::RTC_INVALID_GEOMETRY_ID,
            prototypes: Vec::new(),
            instance_geom: sys::RTC_INVALID_GEOMETRY_ID,
        };
        scene.device.check("rtcNewScene")?;
        configure(&scene.device, scene.raw(), options)?;
        if !soup.indices.is_empty() {
            let id = attach_triangles(&scene.device, scene.raw(), soup, soup.masked)?;
            debug_assert_eq!(id, 0, "the first geometry of a fresh scene gets ID 0");
        }
        if !soup.spheres.is_empty() {
            scene.sphere_geom = scene.attach_spheres(soup.spheres)?;
        }
        if !soup.instances.is_empty() {
            scene.attach_instances(soup.instances, options, soup.masked)?;
        }
        // SAFETY: as above; after this call the scene is never modified again.
        unsafe { sys::rtcCommitScene(scene.raw()) };
        scene.device.check("rtcCommitScene")?;
        Ok(scene)
    }

    /// The device the scene lives on.
    pub(super) fn device(&self) -> &Device {
        &self.device
    }

    /// The geometry ID of the spheres (`RTC_INVALID_GEOMETRY_ID` if none).
    pub(super) fn sphere_geometry(&self) -> u32 {
        self.sphere_geom
    }

    /// The geometry ID of placement 0's instance (placement `k` has this
    /// plus `k`; `RTC_INVALID_GEOMETRY_ID` if there are none).
    pub(super) fn instance_geometry(&self) -> u32 {
        self.instance_geom
    }

    /// Build one child scene per prototype and one instance geometry per
    /// placement (its object-to-render matrix, column-major 3 x 4), attached
    /// in placement order with consecutive IDs. Only during
    /// [`Scene::build`], before the commit.
    fn attach_instances(
        &mut self,
        instances: Instances<'_>,
        options: AccelOptions,
        masked: bool,
    ) -> Result<()> {
        for p in instances.prototypes {
            let soup = TriangleSoup::triangles(&p.positions, &p.indices);
            validate(soup)?;
            // SAFETY: the device is live (we own it).
            let raw = unsafe { sys::rtcNewScene(self.device.raw()) };
            self.device.check("rtcNewScene (prototype)")?;
            let child = NonNull::new(raw)
                .ok_or_else(|| backend_error("rtcNewScene returned NULL".into()))?;
            // owned from here: released in `Drop`, also on the error paths
            self.prototypes.push(child);
            configure(&self.device, child.as_ptr(), options)?;
            if !p.indices.is_empty() {
                attach_triangles(&self.device, child.as_ptr(), soup, masked)?;
            }
            // SAFETY: `child` is live and filled; it is never modified after
            // this commit (instances only read it).
            unsafe { sys::rtcCommitScene(child.as_ptr()) };
            self.device.check("rtcCommitScene (prototype)")?;
        }
        for (k, placement) in instances.placements.iter().enumerate() {
            let child = *self
                .prototypes
                .get(placement.prototype as usize)
                .ok_or_else(|| {
                    backend_error(format!(
                        "placement {k} names prototype {} of {}",
                        placement.prototype,
                        self.prototypes.len()
                    ))
                })?;
            let device = &self.device;
            // SAFETY: `device` is live; INSTANCE is a valid geometry type.
            let raw = unsafe { sys::rtcNewGeometry(device.raw(), sys::RTCGeometryType::INSTANCE) };
            let geometry = NonNull::new(raw).map(|handle| Geometry { handle, device });
            device.check("rtcNewGeometry (instance)")?;
            let geometry =
                geometry.ok_or_else(|| backend_error("rtcNewGeometry returned NULL".into()))?;
            let matrix: [f32; 12] = placement.to_render.to_cols_array();
            // SAFETY: `geometry` is a live, uncommitted instance geometry;
            // `child` is a committed scene of the same device that outlives
            // it (released after this scene in `Drop`); Embree copies the
            // 12 floats `matrix` points to (FLOAT3X4_COLUMN_MAJOR: three
            // axis columns, then the translation) before returning.
            unsafe {
                sys::rtcSetGeometryInstancedScene(geometry.raw(), child.as_ptr());
                sys::rtcSetGeometryTransform(
                    geometry.raw(),
                    0,
                    sys::RTCFormat::FLOAT3X4_COLUMN_MAJOR,
                    matrix.as_ptr().cast(),
                );
                sys::rtcCommitGeometry(geometry.raw());
            }
            device.check("rtcCommitGeometry (instance)")?;
            // SAFETY: both handles are live and of the same device; the
            // scene keeps its own reference to the geometry.
            let id = unsafe { sys::rtcAttachGeometry(self.raw(), geometry.raw()) };
            device.check("rtcAttachGeometry (instance)")?;
            if k == 0 {
                self.instance_geom = id;
            } else if id != self.instance_geom.wrapping_add(k as u32) {
                return Err(backend_error(format!(
                    "Embree numbered instance {k} as geometry {id}, not {}",
                    self.instance_geom.wrapping_add(k as u32)
                )));
            }
        }
        Ok(())
    }

    /// Create the user geometry answering for `spheres` (one primitive per
    /// sphere, callbacks in [`super::user`]), commit it and attach it; returns
    /// its geometry ID. Only during [`Scene::build`], before the commit.
    fn attach_spheres(&mut self, spheres: &[Sphere]) -> Result<u32> {
        let count = u32::try_from(spheres.len()).map_err(|_| {
            backend_error(format!(
                "{} spheres exceed Embree's 32-bit IDs",
                spheres.len()
            ))
        })?;
        let data = Box::new(SphereData {
            spheres: spheres.into(),
        });
        let device = &self.device;
        // SAFETY: `device` is live; USER is a valid geometry type.
        let raw = unsafe { sys::rtcNewGeometry(device.raw(), sys::RTCGeometryType::USER) };
        let geometry = NonNull::new(raw).map(|handle| Geometry { handle, device });
        device.check("rtcNewGeometry")?;
        let geometry =
            geometry.ok_or_else(|| backend_error("rtcNewGeometry returned NULL".into()))?;
        // SAFETY: `geometry` is live and not yet committed or shared. The
        // user pointer names the boxed `SphereData`, whose heap address stays
        // put when the box moves into `self.spheres` below and which lives
        // until after the scene (and with it the geometry) is released; the
        // callbacks only read it, and only for primitive IDs below `count`,
        // its length.
        unsafe {
            sys::rtcSetGeometryUserPrimitiveCount(geometry.raw(), count);
            sys::rtcSetGeometryUserData(geometry.raw(), user::user_ptr(&data));
            sys::rtcSetGeometryBoundsFunction(
                geometry.raw(),
                Some(user::bounds),
                std::ptr::null_mut(),
            );
            sys::rtcSetGeometryIntersectFunction(geometry.raw(), Some(user::intersect));
            sys::rtcSetGeometryOccludedFunction(geometry.raw(), Some(user::occluded));
            sys::rtcCommitGeometry(geometry.raw());
        }
        device.check("rtcCommitGeometry (spheres)")?;
        // SAFETY: both handles are live and belong to the same device; the
        // scene retains the geometry after `geometry` drops.
        let id = unsafe { sys::rtcAttachGeometry(self.raw(), geometry.raw()) };
        device.check("rtcAttachGeometry (spheres)")?;
        self.spheres = Some(data);
        Ok(id)
    }

    /// The raw handle of this committed scene. Valid for as long as `self` is.
    pub(super) fn raw(&self) -> sys::RTCScene {
        self.handle.as_ptr()
    }
}

/// Create a triangle geometry holding copies of the soup's triangles,
/// commit it and attach it to `scene` (a live, uncommitted scene of
/// `device`, during [`Scene::build`]); returns its geometry ID. With
/// `masked`, the geometry calls [`super::filter::alpha_filter`] on every
/// candidate hit, of closest-hit and occlusion queries alike.
fn attach_triangles(
    device: &Device,
    scene: sys::RTCScene,
    soup: TriangleSoup<'_>,
    masked: bool,
) -> Result<u32> {
    // SAFETY: `device` is live; TRIANGLE is a valid geometry type.
    let raw = unsafe { sys::rtcNewGeometry(device.raw(), sys::RTCGeometryType::TRIANGLE) };
    let geometry = NonNull::new(raw).map(|handle| Geometry { handle, device });
    device.check("rtcNewGeometry")?;
    let geometry = geometry.ok_or_else(|| backend_error("rtcNewGeometry returned NULL".into()))?;
    // SAFETY: `geometry` is live and not yet committed or shared.
    unsafe { sys::rtcSetGeometryBuildQuality(geometry.raw(), BUILD_QUALITY) };

    let vertices = geometry.new_buffer::<[f32; 3]>(
        sys::RTCBufferType::VERTEX,
        sys::RTCFormat::FLOAT3,
        soup.positions.len(),
    )?;
    for (i, p) in soup.positions.iter().enumerate() {
        // SAFETY: `new_buffer` returned room for `positions.len()` aligned
        // items of `[f32; 3]`, owned by the geometry and touched by nothing
        // else until commit; `i` is in range. `write` never reads the
        // (uninitialised) old contents.
        unsafe { vertices.as_ptr().add(i).write(p.to_array()) };
    }
    let indices = geometry.new_buffer::<[u32; 3]>(
        sys::RTCBufferType::INDEX,
        sys::RTCFormat::UINT3,
        soup.indices.len(),
    )?;
    // SAFETY: as for the vertices: room for `indices.len()` aligned
    // `[u32; 3]` items that do not overlap the caller's slice.
    unsafe {
        std::ptr::copy_nonoverlapping(soup.indices.as_ptr(), indices.as_ptr(), soup.indices.len())
    };

    if masked {
        // SAFETY: `geometry` is live and uncommitted; `alpha_filter` is an
        // `extern "C"` function with the `RTCFilterFunctionN` signature that
        // lives for the whole program, and every query on a scene built with
        // `masked` passes the context it expects (`filter::Query`).
        unsafe {
            sys::rtcSetGeometryIntersectFilterFunction(
                geometry.raw(),
                Some(super::filter::alpha_filter),
            );
            sys::rtcSetGeometryOccludedFilterFunction(
                geometry.raw(),
                Some(super::filter::alpha_filter),
            );
        }
    }
    // SAFETY: `geometry` is live and its buffers are filled; every index
    // is below the vertex count (checked by `validate`).
    unsafe { sys::rtcCommitGeometry(geometry.raw()) };
    device.check("rtcCommitGeometry")?;
    // SAFETY: both handles are live and belong to the same device (the
    // caller's contract); the scene retains its own reference to the
    // geometry, so dropping `geometry` below (rtcReleaseGeometry) leaves it
    // attached.
    let id = unsafe { sys::rtcAttachGeometry(scene, geometry.raw()) };
    device.check("rtcAttachGeometry")?;
    Ok(id)
}

/// Set `scene`'s flags (robust or not) and build quality: `scene` is a live,
/// not yet committed scene of `device` that no other thread can see.
fn configure(device: &Device, scene: sys::RTCScene, options: AccelOptions) -> Result<()> {
    let flags = if options.robust {
        sys::RTCSceneFlags::ROBUST
    } else {
        sys::RTCSceneFlags::NONE
    };
    // SAFETY: `scene` is live and uncommitted, and no other thread sees it
    // (the caller's contract).
    unsafe {
        sys::rtcSetSceneFlags(scene, flags);
        sys::rtcSetSceneBuildQuality(scene, BUILD_QUALITY);
    }
    device.check("rtcSetSceneFlags/rtcSetSceneBuildQuality")
}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: `self.handle` is live and this is its last use; the device
        // it came from is still alive (`self.device` drops after this).
        unsafe { sys::rtcReleaseScene(self.raw()) };
        for child in &self.prototypes {
            // SAFETY: each child is live, owned by this scene alone, and
            // used for the last time: the instances naming it went with the
            // scene released above. The device is still alive.
            unsafe { sys::rtcReleaseScene(child.as_ptr()) };
        }
    }
}

/// A geometry handle under construction, released on drop (also on the error
/// paths). It borrows its device, so it cannot outlive it.
struct Geometry<'d> {
    handle: NonNull<sys::RTCGeometryTy>,
    device: &'d Device,
}

impl Geometry<'_> {
    fn raw(&self) -> sys::RTCGeometry {
        self.handle.as_ptr()
    }

    /// A new Embree-owned buffer of `count` items of `T` (stride
    /// `size_of::<T>()`) in slot 0 of `kind`, checked for NULL and alignment.
    fn new_buffer<T>(
        &self,
        kind: sys::RTCBufferType,
        format: sys::RTCFormat,
        count: usize,
    ) -> Result<NonNull<T>> {
        // SAFETY: `self.handle` is a live, uncommitted geometry; Embree
        // allocates the buffer (padded for its 16-byte loads) and owns it.
        let raw = unsafe {
            sys::rtcSetNewGeometryBuffer(self.raw(), kind, 0, format, size_of::<T>(), count)
        };
        self.device.check("rtcSetNewGeometryBuffer")?;
        let ptr = NonNull::new(raw.cast::<T>())
            .ok_or_else(|| backend_error("rtcSetNewGeometryBuffer returned NULL".into()))?;
        if !ptr.as_ptr().is_aligned() {
            return Err(backend_error(format!(
                "rtcSetNewGeometryBuffer returned a misaligned {kind:?} buffer"
            )));
        }
        Ok(ptr)
    }
}

impl Drop for Geometry<'_> {
    fn drop(&mut self) {
        // SAFETY: `self.handle` is live and this is our last use of it; the
        // device is alive (borrowed for `'d`).
        unsafe { sys::rtcReleaseGeometry(self.raw()) };
    }
}

/// Reject soups Embree would read out of bounds or could not number: vertex
/// indices past the vertex buffer, counts beyond Embree's 32-bit IDs.
fn validate(soup: TriangleSoup<'_>) -> Result<()> {
    let n = soup.positions.len();
    if u32::try_from(n).is_err() || u32::try_from(soup.indices.len()).is_err() {
        return Err(backend_error(format!(
            "{n} vertices / {} triangles exceed Embree's 32-bit indices",
            soup.indices.len()
        )));
    }
    for (t, tri) in soup.indices.iter().enumerate() {
        if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
            return Err(backend_error(format!(
                "triangle {t} uses vertex {i}, but there are only {n} vertices"
            )));
        }
    }
    Ok(())
}
