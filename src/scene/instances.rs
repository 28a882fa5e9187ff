//! Instanced meshes in a [`Scene`]: each prototype's triangles are stored
//! once, in the prototype's own object space, with what shading needs of
//! them (normals, needle factors, materials, texture coordinates, vertex
//! normals), and each placement adds only its transforms, a material
//! override and its first primitive id. Memory therefore grows with the
//! number of placements (about 2 KB each in a whole render, README), not
//! by the mesh.
//!
//! A hit on an instance is resolved here: the placement by a binary search
//! on the primitive id, the surface point rebuilt from the object-space
//! corners exactly as a placed triangle's is (the same triangle the backends
//! tested), then carried into render space with an error bound that also
//! covers the transform's rounding both ways (see
//! [`SceneInstances::surface_point`]).

use crate::accel::{Instances, Placement, Prototype};
use crate::math::{SurfacePoint, Vec2, Vec3, gamma};
use glam::Mat3;

/// What shading needs of a prototype's triangles, in object space, one entry
/// per triangle of [`Prototype::indices`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PrototypeShading {
    /// The prototype's name (the `[[mesh]]` `name`, the `shapegroup` id).
    pub name: String,
    /// Unit geometric normal (front side).
    pub normals: Vec<Vec3>,
    /// [`crate::math::needle_factor`] of each triangle.
    pub needle: Vec<f32>,
    /// Scene material index of each triangle.
    pub tri_material: Vec<u32>,
    /// Corner texture coordinates: empty, or one entry per triangle.
    pub tri_uv: Vec<[Vec2; 3]>,
    /// Corner vertex normals (object space, unit, zero = flat): empty, or one
    /// entry per triangle.
    pub tri_shading_normals: Vec<[Vec3; 3]>,
}

/// No material override on a placement.
pub const NO_OVERRIDE: u32 = u32::MAX;

/// The prototypes and placements of a scene.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneInstances {
    /// Prototype geometry (object space), as the backends receive it.
    pub prototypes: Vec<Prototype>,
    /// Per prototype, its shading data.
    pub shading: Vec<PrototypeShading>,
    /// Placements, in primitive order.
    pub placements: Vec<Placement>,
    /// Per placement, the material every triangle of it takes instead of
    /// its own, or [`NO_OVERRIDE`].
    pub material: Vec<u32>,
    /// Per placement, the normal matrix (inverse transpose of the linear
    /// part of `to_render`, from `f64`).
    pub normal_matrix: Vec<Mat3>,
    /// Per placement, its object-to-world map in `f64` (`to_render` is this
    /// minus the scene's world origin, rounded), which `convert` writes.
    pub world: Vec<glam::DAffine3>,
}

impl SceneInstances {
    /// Whether nothing is instanced.
    pub fn is_empty(&self) -> bool {
        self.placements.is_empty()
    }

    /// The backends' view.
    pub fn soup(&self) -> Instances<'_> {
        Instances {
            prototypes: &self.prototypes,
            placements: &self.placements,
        }
    }

    /// Triangles placed by all placements.
    pub fn triangle_count(&self) -> u64 {
        self.soup().triangle_count()
    }

    /// The placement holding instanced primitive `prim` and the prototype
    /// triangle it is.
    #[inline]
    pub fn locate(&self, prim: u32) -> (usize, u32) {
        let k = self
            .placements
            .partition_point(|p| p.first_prim <= prim)
            .saturating_sub(1);
        (k, prim - self.placements[k].first_prim)
    }

    /// The prototype of placement `k`.
    #[inline]
    fn prototype(&self, k: usize) -> usize {
        self.placements[k].prototype as usize
    }

    /// The material index of triangle `t` of placement `k`.
    #[inline]
    pub fn material_index(&self, k: usize, t: u32) -> u32 {
        match self.material[k] {
            NO_OVERRIDE => self.shading[self.prototype(k)].tri_material[t as usize],
            m => m,
        }
    }

    /// Render-space corners of triangle `t` of placement `k`.
    #[inline]
    pub fn triangle(&self, k: usize, t: u32) -> [Vec3; 3] {
        let p = &self.placements[k];
        self.prototypes[p.prototype as usize]
            .triangle(t)
            .map(|c| p.to_render.transform_point3(c))
    }

    /// The surface point at barycentrics `(u, v)` of triangle `t` of
    /// placement `k`, in render space.
    ///
    /// The point is rebuilt in object space from the prototype's corners
    /// (what the backends intersected), with its error bound `e_o`, and
    /// mapped by `M = (L, c)`. Its render-space bound adds up, per axis:
    /// `|L| e_o` (the object error carried over); `gamma(4) (|L| |p_o| +
    /// |c|)` (rounding of the map); and `|L| gamma(8) k (|L^-1| |p| +
    /// |c'|)`, the rounding of the way back, when a backend maps a ray
    /// leaving `p` into object space with `(L^-1, c')` (Embree with an
    /// inverse of its own, hence the condition number `k`, see
    /// [`Placement::condition`], kept in [`Placement::cond`]). The sum is made isotropic like every
    /// other surface point's. The normal goes through the normal matrix.
    #[inline]
    pub fn surface_point(&self, k: usize, t: u32, u: f32, v: f32) -> SurfacePoint {
        let pl = &self.placements[k];
        let proto = pl.prototype as usize;
        let shading = &self.shading[proto];
        let i = t as usize;
        let object = SurfacePoint::on_triangle_with(
            self.prototypes[proto].triangle(t),
            u,
            v,
            shading.normals[i],
            shading.needle[i],
        );
        let p = pl.to_render.transform_point3(object.p);
        let abs =
            |m: glam::Mat3A| Mat3::from_cols(m.x_axis.into(), m.y_axis.into(), m.z_axis.into());
        let l = abs(pl.to_render.matrix3.abs());
        let li = abs(pl.to_object.matrix3.abs());
        let c = Vec3::from(pl.to_render.translation).abs();
        let ci = Vec3::from(pl.to_object.translation).abs();
        let carried = l * object.p_err;
        let forward = gamma(4) * (l * object.p.abs() + c);
        let back = l * (gamma(8) * pl.cond * (li * p.abs() + ci));
        let err = (carried + forward + back).max_element();
        let n = (self.normal_matrix[k] * object.n).normalize_or_zero();
        SurfacePoint {
            p,
            p_err: Vec3::splat(err),
            n: if n == Vec3::ZERO { object.n } else { n },
        }
    }

    /// Corner texture coordinates of triangle `t` of placement `k`, if its
    /// prototype has them.
    #[inline]
    pub fn uv(&self, k: usize, t: u32) -> Option<[Vec2; 3]> {
        self.shading[self.prototype(k)]
            .tri_uv
            .get(t as usize)
            .copied()
    }

    /// Render-space vertex normals of triangle `t` of placement `k`, when
    /// all three corners have one.
    #[inline]
    pub fn corner_normals(&self, k: usize, t: u32) -> Option<[Vec3; 3]> {
        let c = self.shading[self.prototype(k)]
            .tri_shading_normals
            .get(t as usize)?;
        if c.contains(&Vec3::ZERO) {
            return None;
        }
        let m = self.normal_matrix[k];
        let w = c.map(|n| (m * n).normalize_or_zero());
        w.iter().all(|n| *n != Vec3::ZERO).then_some(w)
    }

    /// Render-space bounds of every placement, `(min, max)`.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let object: Vec<(Vec3, Vec3)> = self.prototypes.iter().map(Prototype::bounds).collect();
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for p in &self.placements {
            let (a, b) = object[p.prototype as usize];
            if a.x <= b.x {
                let (a, b) = p.render_bounds(a, b);
                lo = lo.min(a);
                hi = hi.max(b);
            }
        }
        (lo, hi)
    }
}
