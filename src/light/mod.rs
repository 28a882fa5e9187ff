//! Light sources and their sampling: emissive triangles and spheres (area
//! lights), point and directional lights, the uniform environment and the
//! environment map. One light is chosen in proportion to its power
//! (luminance of radiance x area x pi, twice that for two-sided emitters;
//! `4 pi I` for a point light; `E pi r^2` for a directional light and
//! `pi^2 r^2 L` for the environment, `r` the scene's bounding radius;
//! pbrt-v4's `PowerLightSampler`, section 12.6.3), then a point on it:
//! uniform by area on a triangle, converted to solid angle by
//! `r^2 / |cos theta_l|`; uniform in the subtended cone on a sphere seen from
//! outside; a uniform direction for the uniform environment; the map's own
//! distribution for the environment map ([`envmap`]). Lights with zero power
//! get probability zero.

pub mod directional;
pub mod envmap;
pub mod point;

pub use directional::DirectionalLight;
pub use envmap::{EnvironmentMap, EnvironmentSample};
pub use point::PointLight;

use crate::math::Ray;
use crate::math::{Frame, SurfacePoint, Vec2, Vec3, luminance, spawn_ray, spawn_ray_to};
use crate::sampling::{
    Discrete, square_to_uniform_sphere, square_to_uniform_sphere_pdf, square_to_uniform_triangle,
};
use crate::scene::Scene;
use std::f32::consts::PI;

/// The shape of an area light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Emitter {
    /// An emissive triangle, sampled uniformly by area.
    Triangle,
    /// An emissive sphere, sampled by solid angle (uniformly in the cone it
    /// subtends) from outside, uniformly by area from inside.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
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
    /// The light is a point or directional light: no BSDF sample can find it,
    /// so the estimator gives the sample MIS weight 1.
    pub delta: bool,
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

/// All lights of a scene with the power-proportional selection distribution.
///
/// Selection items, in order: the area lights, the point lights, the
/// directional lights, the uniform environment, the environment map.
#[derive(Debug, Clone)]
pub struct Lights {
    area: Vec<AreaLight>,
    /// For each primitive, its index in `area`, or `u32::MAX`.
    light_of_prim: Vec<u32>,
    points: Vec<PointLight>,
    directionals: Vec<DirectionalLight>,
    environment: Option<Vec3>,
    environment_map: Option<EnvironmentMap>,
    select: Discrete,
}

const NO_LIGHT: u32 = u32::MAX;

impl Lights {
    /// Collect the lights of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let mut area = Vec::new();
        let mut light_of_prim = vec![NO_LIGHT; scene.primitive_count()];
        let mut weights = Vec::new();
        for prim in 0..scene.primitive_count() as u32 {
            let m = scene.material(prim);
            if m.emission.max_element() <= 0.0 {
                continue;
            }
            let (a, shape) = match scene.sphere(prim) {
                None => {
                    let [p0, p1, p2] = scene.triangle(prim);
                    let a = 0.5 * (p1 - p0).as_dvec3().cross((p2 - p0).as_dvec3()).length();
                    (a as f32, Emitter::Triangle)
                }
                Some(s) => {
                    let r = s.radius as f64;
                    let a = 4.0 * std::f64::consts::PI * r * r;
                    (
                        a as f32,
                        Emitter::Sphere {
                            center: s.center,
                            radius: s.radius,
                        },
                    )
                }
            };
            let sides = if m.two_sided { 2.0 } else { 1.0 };
            light_of_prim[prim as usize] = area.len() as u32;
            weights.push(luminance(m.emission).max(0.0) * a * PI * sides);
            area.push(AreaLight {
                prim,
                le: m.emission,
                two_sided: m.two_sided,
                area: a,
                shape,
            });
        }
        let b = scene.bounds();
        let r = if b.is_empty() {
            1.0
        } else {
            (0.5 * (b.max - b.min).length()).max(1e-3)
        };
        weights.extend(scene.point_lights.iter().map(|l| l.power()));
        weights.extend(scene.directional_lights.iter().map(|l| l.power(r)));
        if let Some(env) = scene.environment {
            weights.push(luminance(env).max(0.0) * PI * PI * r * r);
        }
        if let Some(map) = &scene.environment_map {
            weights.push(map.power(r));
        }
        Lights {
            area,
            light_of_prim,
            points: scene.point_lights.clone(),
            directionals: scene.directional_lights.clone(),
            environment: scene.environment,
            environment_map: scene.environment_map.clone(),
            select: Discrete::new(&weights),
        }
    }

    /// The area lights.
    pub fn area_lights(&self) -> &[AreaLight] {
        &self.area
    }

    /// Whether there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.select.is_empty()
    }

    /// Whether some light has a delta distribution (point, directional).
    pub fn has_delta(&self) -> bool {
        !self.points.is_empty() || !self.directionals.is_empty()
    }

    /// Whether an escaping ray sees any radiance.
    pub fn has_environment(&self) -> bool {
        self.environment.is_some() || self.environment_map.is_some()
    }

    /// Selection index of the uniform environment.
    fn environment_index(&self) -> usize {
        self.area.len() + self.points.len() + self.directionals.len()
    }

    /// Selection index of the environment map.
    fn environment_map_index(&self) -> usize {
        self.environment_index() + usize::from(self.environment.is_some())
    }

    /// Radiance leaving triangle `prim` towards `wo` (unit, pointing away from
    /// the surface); `n` is the triangle's front normal.
    pub fn le(&self, scene: &Scene, prim: u32, n: Vec3, wo: Vec3) -> Vec3 {
        let m = scene.material(prim);
        if m.emission.max_element() <= 0.0 || (!m.two_sided && n.dot(wo) <= 0.0) {
            Vec3::ZERO
        } else {
            m.emission
        }
    }

    /// Radiance of the environment along a ray that escaped in direction `d`.
    pub fn environment(&self, d: Vec3) -> Vec3 {
        let mut l = self.environment.unwrap_or(Vec3::ZERO);
        if let Some(map) = &self.environment_map {
            l += map.eval(d);
        }
        l
    }

    /// Sample a light as seen from `from`, with `u_select` choosing the light
    /// and `u` the point on it.
    pub fn sample(
        &self,
        scene: &Scene,
        from: &SurfacePoint,
        u_select: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let chosen = self.select.sample(u_select)?;
        let mut i = chosen.index;
        if i < self.area.len() {
            return self.sample_area(scene, &self.area[i], chosen.pmf, from, u);
        }
        i -= self.area.len();
        let delta = if i < self.points.len() {
            self.points[i].sample_li(from)?
        } else if i < self.points.len() + self.directionals.len() {
            self.directionals[i - self.points.len()].sample_li(from)
        } else if chosen.index == self.environment_index() && self.environment.is_some() {
            let wi = square_to_uniform_sphere(u);
            return Some(LightSample {
                wi,
                li: self.environment.unwrap_or(Vec3::ZERO),
                pdf: chosen.pmf * square_to_uniform_sphere_pdf(wi),
                delta: false,
                shadow: spawn_ray(from, wi),
            });
        } else {
            let map = self.environment_map.as_ref()?;
            let s = map.sample(u)?;
            return Some(LightSample {
                wi: s.wi,
                li: s.li,
                pdf: chosen.pmf * s.pdf,
                delta: false,
                shadow: spawn_ray(from, s.wi),
            });
        };
        Some(LightSample {
            wi: delta.wi,
            li: delta.li,
            pdf: chosen.pmf * delta.pdf,
            delta: true,
            shadow: delta.shadow,
        })
    }

    /// A point on area light `light`, chosen with probability `pmf`.
    fn sample_area(
        &self,
        scene: &Scene,
        light: &AreaLight,
        pmf: f32,
        from: &SurfacePoint,
        u: Vec2,
    ) -> Option<LightSample> {
        let (to, solid_angle_pdf) = match light.shape {
            Emitter::Triangle => {
                let b = square_to_uniform_triangle(u);
                (scene.surface_point(light.prim, b.x, b.y), None)
            }
            Emitter::Sphere { center, radius } => match sphere_cone(center, radius, from.p) {
                Some(cone) => {
                    let p = cone.sample(u);
                    (SurfacePoint::on_sphere(center, radius, p), Some(cone.pdf()))
                }
                None => {
                    let n = square_to_uniform_sphere(u);
                    (
                        SurfacePoint::on_sphere(center, radius, center + radius * n),
                        None,
                    )
                }
            },
        };
        let delta = to.p - from.p;
        let dist2 = delta.length_squared();
        if !(dist2 > 0.0) || !dist2.is_finite() {
            return None;
        }
        let wi = delta / dist2.sqrt();
        let cos_l = to.n.dot(-wi);
        if cos_l == 0.0 || (!light.two_sided && cos_l < 0.0) {
            return None;
        }
        let pdf = pmf
            * match solid_angle_pdf {
                Some(p) => p,
                None => dist2 / (cos_l.abs() * light.area),
            };
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        Some(LightSample {
            wi,
            li: light.le,
            pdf,
            delta: false,
            shadow: spawn_ray_to(from, &to),
        })
    }

    /// Solid-angle density with which [`Lights::sample`] from `from` would
    /// produce the point `to` on emissive primitive `prim`.
    pub fn pdf_area(&self, from: &SurfacePoint, prim: u32, to: &SurfacePoint) -> f32 {
        let idx = self.light_of_prim[prim as usize];
        if idx == NO_LIGHT {
            return 0.0;
        }
        let light = &self.area[idx as usize];
        let pmf = self.select.pmf(idx as usize);
        if let Emitter::Sphere { center, radius } = light.shape {
            if let Some(cone) = sphere_cone(center, radius, from.p) {
                return pmf * cone.pdf();
            }
        }
        let delta = to.p - from.p;
        let dist2 = delta.length_squared();
        let cos_l = to.n.dot(delta).abs() / dist2.sqrt();
        if !(cos_l > 0.0) || !(light.area > 0.0) {
            return 0.0;
        }
        pmf * dist2 / (cos_l * light.area)
    }

    /// Solid-angle density with which [`Lights::sample`] picks direction `wi`
    /// on the environment (both kinds together).
    pub fn pdf_environment(&self, wi: Vec3) -> f32 {
        let mut pdf = 0.0;
        if self.environment.is_some() {
            pdf += self.select.pmf(self.environment_index()) * square_to_uniform_sphere_pdf(wi);
        }
        if let Some(map) = &self.environment_map {
            pdf += self.select.pmf(self.environment_map_index()) * map.pdf(wi);
        }
        pdf
    }
}

/// The cone of directions a sphere subtends from a point outside it
/// (pbrt-v4 section 6.2.4, "Sampling"), sampled uniformly.
struct SphereCone {
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
fn sphere_cone(center: Vec3, radius: f32, p: Vec3) -> Option<SphereCone> {
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
    fn pdf(&self) -> f32 {
        1.0 / (2.0 * PI * self.one_minus_cos_max)
    }

    /// The point of the sphere seen along the direction `u` picks: the cone
    /// angle `theta` with `cos theta` uniform in `[cos_max, 1]`, turned into
    /// the angle `alpha` at the centre between the axis and the point, so no
    /// ray has to be intersected (pbrt-v4's construction).
    fn sample(&self, u: Vec2) -> Vec3 {
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
