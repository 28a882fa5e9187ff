//! Light sources and their sampling: emissive triangles (area lights) and the
//! uniform environment. One light is chosen in proportion to its power
//! (luminance of radiance x area x pi, twice that for two-sided emitters;
//! pbrt-v4's `PowerLightSampler`, section 12.6.3), then a point on it:
//! uniform by area on a triangle, converted to solid angle by
//! `r^2 / |cos theta_l|`, or a uniform direction for the environment.
//! Emitters with zero area or zero radiance get probability zero.

pub mod directional;
pub mod envmap;
pub mod point;

pub use directional::DirectionalLight;
pub use envmap::{EnvironmentMap, EnvironmentSample};
pub use point::PointLight;

use crate::math::Ray;
use crate::math::{SurfacePoint, Vec2, Vec3, luminance, spawn_ray, spawn_ray_to};
use crate::sampling::{
    Discrete, square_to_uniform_sphere, square_to_uniform_sphere_pdf, square_to_uniform_triangle,
};
use crate::scene::Scene;
use std::f32::consts::PI;

/// An emissive triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaLight {
    /// The triangle's index in the scene.
    pub prim: u32,
    /// Emitted radiance.
    pub le: Vec3,
    /// Emits from both sides.
    pub two_sided: bool,
    /// Area.
    pub area: f32,
}

/// A light sample as seen from a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Radiance arriving along `-wi` if unoccluded.
    pub li: Vec3,
    /// Solid-angle density of `wi`, including the choice of light; `> 0`.
    pub pdf: f32,
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
#[derive(Debug, Clone)]
pub struct Lights {
    area: Vec<AreaLight>,
    /// For each triangle, its index in `area`, or `u32::MAX`.
    light_of_prim: Vec<u32>,
    environment: Option<Vec3>,
    /// Items `0..area.len()` are area lights; item `area.len()` is the environment.
    select: Discrete,
}

const NO_LIGHT: u32 = u32::MAX;

impl Lights {
    /// Collect the lights of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let mut area = Vec::new();
        let mut light_of_prim = vec![NO_LIGHT; scene.triangle_count()];
        let mut weights = Vec::new();
        for prim in 0..scene.triangle_count() as u32 {
            let m = scene.material(prim);
            if m.emission.max_element() <= 0.0 {
                continue;
            }
            let [p0, p1, p2] = scene.triangle(prim);
            let a = 0.5 * (p1 - p0).as_dvec3().cross((p2 - p0).as_dvec3()).length() as f32;
            let sides = if m.two_sided { 2.0 } else { 1.0 };
            light_of_prim[prim as usize] = area.len() as u32;
            weights.push(luminance(m.emission).max(0.0) * a * PI * sides);
            area.push(AreaLight {
                prim,
                le: m.emission,
                two_sided: m.two_sided,
                area: a,
            });
        }
        if let Some(env) = scene.environment {
            let b = scene.bounds();
            let r = if b.is_empty() {
                1.0
            } else {
                (0.5 * (b.max - b.min).length()).max(1e-3)
            };
            weights.push(luminance(env).max(0.0) * PI * PI * r * r);
        }
        Lights {
            area,
            light_of_prim,
            environment: scene.environment,
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

    /// Probability of choosing the environment.
    fn environment_pmf(&self) -> f32 {
        if self.environment.is_some() {
            self.select.pmf(self.area.len())
        } else {
            0.0
        }
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

    /// Radiance of the environment along a ray that escaped.
    pub fn environment(&self) -> Vec3 {
        self.environment.unwrap_or(Vec3::ZERO)
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
        if chosen.index == self.area.len() {
            let env = self.environment?;
            let wi = square_to_uniform_sphere(u);
            return Some(LightSample {
                wi,
                li: env,
                pdf: chosen.pmf * square_to_uniform_sphere_pdf(wi),
                shadow: spawn_ray(from, wi),
            });
        }
        let light = &self.area[chosen.index];
        let tri = scene.triangle(light.prim);
        let b = square_to_uniform_triangle(u);
        let to = SurfacePoint::on_triangle(tri, b.x, b.y, scene.normals[light.prim as usize]);
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
        let pdf = chosen.pmf * dist2 / (cos_l.abs() * light.area);
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        Some(LightSample {
            wi,
            li: light.le,
            pdf,
            shadow: spawn_ray_to(from, &to),
        })
    }

    /// Solid-angle density with which [`Lights::sample`] from `from` would
    /// produce the point `to` on emissive triangle `prim`.
    pub fn pdf_area(&self, from: &SurfacePoint, prim: u32, to: &SurfacePoint) -> f32 {
        let idx = self.light_of_prim[prim as usize];
        if idx == NO_LIGHT {
            return 0.0;
        }
        let light = &self.area[idx as usize];
        let delta = to.p - from.p;
        let dist2 = delta.length_squared();
        let cos_l = to.n.dot(delta).abs() / dist2.sqrt();
        if !(cos_l > 0.0) || !(light.area > 0.0) {
            return 0.0;
        }
        self.select.pmf(idx as usize) * dist2 / (cos_l * light.area)
    }

    /// Solid-angle density with which [`Lights::sample`] picks direction `wi`
    /// on the environment.
    pub fn pdf_environment(&self) -> f32 {
        self.environment_pmf() * square_to_uniform_sphere_pdf(Vec3::Z)
    }
}
