//! Light sources and their sampling: emissive triangles and spheres (area
//! lights), point, spot, panel and directional lights, the uniform
//! environment and the environment map. One light is chosen in proportion to its power
//! (luminance of radiance x area x pi, twice that for two-sided emitters;
//! `4 pi I` for a point light; `I` times the falloff's solid angle for a
//! spot light ([`spot`]); `L A pi` for a panel light; `E pi r^2` for a directional light and
//! `pi^2 r^2 L` for the environment, `r` the scene's bounding radius;
//! pbrt-v4's `PowerLightSampler`, section 12.6.3, with an alias table), then
//! a point on it: uniform by area on a triangle, converted to solid angle by
//! `r^2 / |cos theta_l|`; on a quad (two consecutive emissive triangles
//! making a parallelogram) uniform by area with one 2D number for both
//! triangles, or for a rectangle that looks large, uniform in the solid
//! angle it subtends ([`Quad`], [`rectangle`]); uniform in the subtended
//! cone on a sphere seen from
//! outside; uniform by area on a panel light, which is no surface
//! ([`panel`]); a uniform direction for the uniform environment; the map's own
//! distribution for the environment map ([`envmap`]). Lights with zero power
//! get probability zero. Powers are computed in `f64` and scaled so that the
//! largest is 1 before they become the selection table's `f32` weights: a
//! light whose radiance is finite but whose power overflows `f32` (a point
//! light of 1e38 W/sr) is chosen like any other, never given weight zero.
//!
//! This module holds the light sources a scene stores and the sampling of
//! each shape; the choice among one scene's lights reads that scene, so it
//! is the estimator's: [`crate::integrator::Lights`].

pub mod directional;
pub mod envmap;
pub mod panel;
pub mod point;
pub mod rectangle;
pub mod spot;

pub use directional::DirectionalLight;
pub use envmap::{EnvironmentMap, EnvironmentSample};
pub use panel::PanelLight;
pub use point::PointLight;
pub use spot::{Falloff, SpotLight};

use crate::math::Ray;
use crate::math::{Frame, Vec2, Vec3};
use rectangle::{Rectangle, SphericalRectangle};
use std::f32::consts::PI;

/// The shape of an area light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Emitter {
    /// An emissive triangle, sampled uniformly by area.
    Triangle,
    /// Two emissive triangles of one material, consecutive in the scene,
    /// that make a parallelogram (a quad of an OBJ or PLY file, a Mitsuba
    /// `rectangle`): one light, sampled with one 2D number over the whole
    /// shape ([`Quad`]).
    Quad(Quad),
    /// An emissive sphere, sampled by solid angle (uniformly in the cone it
    /// subtends) from outside, uniformly by area from inside.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
}

/// Two triangles `(a, b, c)` and `(a, c, d)` (corners up to rotation)
/// making the parallelogram `a + s (b - a) + t (d - a)`, `s, t in [0, 1)`.
///
/// A sample `(s, t)` falls in the first triangle when `s >= t`, at
/// barycentrics `(1 - s, s - t, t)` of `(a, b, c)`, else in the second, at
/// `(1 - t, s, t - s)` of `(a, c, d)`: each half of the unit square maps
/// affinely onto one triangle, so the density by area on triangle `k` is
/// `1 / (2 A_k)` (`1 / A` for a true parallelogram), and one 2D number
/// stratifies the whole light, where choosing a triangle first spent a
/// separate number on the choice.
///
/// A rectangle (perpendicular edges) is sampled uniformly in the solid angle
/// it subtends ([`rectangle`], Ureña et al. 2013) from points where it
/// looks large (about [`SPHERICAL_PAYS_ABOVE`] or more) and that solid
/// angle is between [`MIN_SPHERICAL_SOLID_ANGLE`] and
/// [`MAX_SPHERICAL_SOLID_ANGLE`]; elsewhere, by area. Which one a point
/// gets depends on the point alone, so `pdf_area` reproduces it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quad {
    /// The second triangle (the first is the light's `prim`).
    pub second: u32,
    /// How far each triangle's corners are rotated from `(a, b, c)` and
    /// `(a, c, d)`: scene corner `k` of triangle `j` is canonical corner
    /// `(k + 3 - rot[j]) % 3`.
    rot: [u8; 2],
    /// The two triangles' areas.
    pub(crate) areas: [f32; 2],
    /// The rectangle, when the quad is one.
    rect: Option<Rectangle>,
    /// Its corner `a`, edges and unit normal, for the test of whether
    /// spherical sampling pays.
    corner: Vec3,
    e1: Vec3,
    e2: Vec3,
    n: Vec3,
}

/// Solid angles (steradians) outside which a rectangle is sampled by area:
/// below, the spherical construction loses precision and area sampling is
/// as good (the light is small or far); above, the point is nearly in the
/// light's plane. pbrt-v4 uses the same bounds for spherical triangles
/// (`Triangle::MinSphericalSampleArea`, `MaxSphericalSampleArea`).
pub const MIN_SPHERICAL_SOLID_ANGLE: f64 = 3e-4;
/// See [`MIN_SPHERICAL_SOLID_ANGLE`].
pub const MAX_SPHERICAL_SOLID_ANGLE: f64 = 6.22;

/// Approximate solid angle (steradians, `A cos / d^2` from the centre)
/// from which on a rectangle is sampled by solid angle. Spherical sampling
/// costs about 300 ns a sample (a setup in `f64` with four `acos`), several
/// times area sampling; it pays where the light looks large. Measured on
/// one thread at 16 to 32 spp, efficiency `1 / (MSE x time)` against area
/// sampling: a 1.8 m square ceiling light over a 2 m room, +32 % at 0.1 sr
/// (+47 % at 0.05, +17 % at 0.2); the Cornell box's small light, -1.5 % at
/// 0.1 sr, the noise of the measurement (-13 % at 0.05; always spherical,
/// -30 %).
pub const SPHERICAL_PAYS_ABOVE: f32 = 0.1;

/// Largest relative gap `|b + d - a - c| / (|b - a| + |d - a|)` for two
/// triangles to count as a parallelogram.
const PARALLELOGRAM_TOLERANCE: f32 = 1e-4;

impl Quad {
    /// The quad that triangles `t0` and `t1` make, if they make one.
    pub(crate) fn find(t0: [Vec3; 3], t1: [Vec3; 3]) -> Option<(Quad, Vec3, Vec3, Vec3)> {
        for r0 in 0..3 {
            let [a, b, c] = [t0[r0], t0[(r0 + 1) % 3], t0[(r0 + 2) % 3]];
            for r1 in 0..3 {
                let [a1, c1, d] = [t1[r1], t1[(r1 + 1) % 3], t1[(r1 + 2) % 3]];
                if a1 != a || c1 != c {
                    continue;
                }
                let (e1, e2) = (b - a, d - a);
                let gap = (b + d - a - c).length();
                if !(gap <= PARALLELOGRAM_TOLERANCE * (e1.length() + e2.length())) {
                    return None;
                }
                let area = |p: Vec3, q: Vec3, r: Vec3| {
                    (0.5 * (q - p).as_dvec3().cross((r - p).as_dvec3()).length()) as f32
                };
                let quad = Quad {
                    second: 0,
                    rot: [r0 as u8, r1 as u8],
                    areas: [area(a, b, c), area(a, c, d)],
                    rect: Rectangle::new(a, e1, e2),
                    corner: a,
                    e1,
                    e2,
                    n: e1.cross(e2).normalize_or_zero(),
                };
                return Some((quad, a, e1, e2));
            }
        }
        None
    }

    /// The triangle (0 or 1) and its scene barycentrics `(u, v)` of the
    /// point at fractions `(s, t)` of the edges.
    pub(crate) fn locate(&self, s: f32, t: f32) -> (usize, f32, f32) {
        let (k, w) = if s >= t {
            (0, [1.0 - s, s - t, t])
        } else {
            (1, [1.0 - t, s, t - s])
        };
        // scene corner j holds canonical corner (j + 3 - rot) % 3
        let r = self.rot[k] as usize;
        (k, w[(4 - r) % 3], w[(5 - r) % 3])
    }

    /// The rectangle seen from `o`, when it is one and spherical sampling
    /// applies there.
    pub(crate) fn spherical(&self, o: Vec3) -> Option<SphericalRectangle> {
        let rect = self.rect.as_ref()?;
        // the solid angle, roughly, from the centre: A |n . v| / d^3; below
        // SPHERICAL_PAYS_ABOVE area sampling is nearly as good and cheaper
        // (compared squared: no root, no division)
        let v = self.corner + 0.5 * (self.e1 + self.e2) - o;
        let d2 = v.length_squared();
        let a_cos = (self.areas[0] + self.areas[1]) * self.n.dot(v);
        let t = SPHERICAL_PAYS_ABOVE;
        if !(a_cos * a_cos >= t * t * d2 * d2 * d2) {
            return None;
        }
        rect.seen_from(o).filter(|s| {
            (MIN_SPHERICAL_SOLID_ANGLE..=MAX_SPHERICAL_SOLID_ANGLE).contains(&s.solid_angle())
        })
    }
}

/// An emissive primitive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaLight {
    /// The primitive's index in the scene.
    pub prim: u32,
    /// Emitted radiance.
    pub le: Vec3,
    /// Emits from both sides.
    pub two_sided: bool,
    /// Area.
    pub area: f32,
    /// Its shape.
    pub shape: Emitter,
}

/// A light sample as seen from a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Radiance arriving along `-wi` if unoccluded; for a delta light, what
    /// [`DeltaLightSample::li`] says.
    pub li: Vec3,
    /// Solid-angle density of `wi`, including the choice of light; for a
    /// delta light, the probability of choosing it. Always `> 0`.
    pub pdf: f32,
    /// No BSDF sample can find the light: a delta light (point, spot,
    /// directional), or a panel light, which is no surface ([`panel`]). The
    /// estimator gives the sample MIS weight 1 and takes it whatever the
    /// direct-lighting strategy.
    pub unreachable: bool,
    /// The shadow ray to test.
    pub shadow: Ray,
}

/// What a light with a delta distribution in direction (a point or a
/// directional light) sends to a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeltaLightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// What arrives along `-wi` if unoccluded: radiance times the delta's
    /// solid angle, i.e. `I / r^2` or the irradiance `E`. The estimator
    /// multiplies it by the BSDF and `|cos|`, never by a MIS weight.
    pub li: Vec3,
    /// Distance to the light (infinite for a directional light).
    pub dist: f32,
    /// Always 1: the probability of `wi` with respect to the delta (divide by
    /// the light's selection probability as for any light).
    pub pdf: f32,
    /// The shadow ray to test.
    pub shadow: Ray,
}

/// The cone of directions a sphere subtends from a point outside it
/// (pbrt-v4 section 6.2.4, "Sampling"), sampled uniformly.
pub(crate) struct SphereCone {
    center: Vec3,
    radius: f32,
    /// Unit axis from the point to the centre.
    axis: Frame,
    sin2_max: f32,
    cos_max: f32,
    /// `1 - cos_max`, from a Taylor series when the cone is narrow.
    one_minus_cos_max: f32,
}

/// The cone of sphere `(center, radius)` seen from `p`, or `None` when `p` is
/// inside the sphere or on it (then points are sampled by area).
pub(crate) fn sphere_cone(center: Vec3, radius: f32, p: Vec3) -> Option<SphereCone> {
    let d2 = (center - p).length_squared();
    let r2 = radius * radius;
    if !(d2 > r2 * 1.0001) || !d2.is_finite() {
        return None;
    }
    let sin2_max = r2 / d2;
    let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
    // below sin^2 = 0.00068523 (pbrt's threshold, about 1.5 degrees)
    // 1 - cos suffers cancellation; its series sin^2 / 2 is exact to f32
    let one_minus_cos_max = if sin2_max < 0.000_685_23 {
        0.5 * sin2_max
    } else {
        1.0 - cos_max
    };
    Some(SphereCone {
        center,
        radius,
        axis: Frame::from_normal((center - p) / d2.sqrt()),
        sin2_max,
        cos_max,
        one_minus_cos_max,
    })
}

impl SphereCone {
    /// Solid-angle density of every direction in the cone.
    pub(crate) fn pdf(&self) -> f32 {
        1.0 / (2.0 * PI * self.one_minus_cos_max)
    }

    /// The point of the sphere seen along the direction `u` picks: the cone
    /// angle `theta` with `cos theta` uniform in `[cos_max, 1]`, turned into
    /// the angle `alpha` at the centre between the axis and the point, so no
    /// ray has to be intersected (pbrt-v4's construction).
    pub(crate) fn sample(&self, u: Vec2) -> Vec3 {
        let (sin2, cos) = if self.sin2_max < 0.000_685_23 {
            let sin2 = self.sin2_max * u.x;
            (sin2, (1.0 - sin2).sqrt())
        } else {
            let cos = (self.cos_max - 1.0) * u.x + 1.0;
            ((1.0 - cos * cos).max(0.0), cos)
        };
        let sin_max = self.sin2_max.sqrt();
        let cos_alpha = sin2 / sin_max + cos * (1.0 - sin2 / self.sin2_max).max(0.0).sqrt();
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        // the normal at the point faces back towards the viewer: -axis side
        let local = Vec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha);
        let n = -self.axis.to_world(local);
        self.center + self.radius * n
    }
}
