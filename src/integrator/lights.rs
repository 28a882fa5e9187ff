//! The lights of one scene as the estimator samples them (pbrt-v4's
//! `PowerLightSampler`, section 12.6.3): the emissive triangles, quads and
//! spheres gathered from the scene as area lights (the materials with
//! [`crate::scene::EmissionRole::Light`]), then the point, spot, panel and
//! directional lights, the uniform environment and the environment map, one
//! chosen in proportion to its power with an alias table, and a point on it
//! by the rules of [`crate::light`]; or, for scenes of many lights, one
//! chosen by the light BVH of [`super::light_bvh`] in proportion to its
//! importance at the shading point ([`crate::settings::LightSampler`]).
//! It reads the scene (its emitting
//! primitives and their surface points), so it lives on the estimator's side
//! of the scene, not with the light sources the scene holds.

use crate::light::{
    AreaLight, DirectionalLight, Emitter, EnvironmentMap, LightSample, PanelLight, PointLight,
    Quad, SpotLight, sphere_cone,
};
use crate::math::{SurfacePoint, Vec2, Vec3, luminance_f64, spawn_ray, spawn_ray_to};
use crate::sampling::{
    Discrete, square_to_uniform_sphere, square_to_uniform_sphere_pdf, square_to_uniform_triangle,
};
use crate::scene::Scene;
use crate::settings::LightSampler;
use std::f64::consts::PI as PI_F64;

use super::light_bvh::{LightBounds, LightBvh};

/// All lights of a scene with the power-proportional selection distribution.
///
/// Selection items, in order: the area lights, the point lights, the spot
/// lights, the panel lights, the directional lights, the uniform environment,
/// the environment map.
#[derive(Debug, Clone)]
pub struct Lights {
    area: Vec<AreaLight>,
    /// For each placed primitive (triangles and spheres), its index in
    /// `area`, or `u32::MAX`.
    light_of_prim: Vec<u32>,
    /// The emitting instanced triangles and their indices in `area`, in
    /// increasing primitive order (a table per instanced primitive would
    /// grow with the placements times the mesh).
    instanced_lights: Vec<(u32, u32)>,
    points: Vec<PointLight>,
    spots: Vec<SpotLight>,
    panels: Vec<PanelLight>,
    directionals: Vec<DirectionalLight>,
    environment: Option<Vec3>,
    environment_map: Option<EnvironmentMap>,
    select: Discrete,
    /// The light BVH, when the lights are chosen by it instead of `select`.
    bvh: Option<LightBvh>,
    /// Some emissive material has an emission texture (then a light
    /// sample's radiance is looked up at its point's UV; its power used the
    /// texture's mean, [`crate::scene::Material::emission`]).
    textured_emission: bool,
}

const NO_LIGHT: u32 = u32::MAX;

/// The selection table's `f32` weights for light powers computed in `f64`:
/// each divided by the largest, so none overflows, and a positive power too
/// small beside the largest for `f32` kept at the smallest normal `f32`, so
/// no light that shines is never chosen (any positive probability keeps the
/// estimate unbiased). Powers that are zero, negative or not finite weigh 0.
fn selection_weights(powers: &[f64]) -> Vec<f32> {
    let top = powers
        .iter()
        .copied()
        .filter(|p| p.is_finite())
        .fold(0.0, f64::max);
    powers
        .iter()
        .map(|&p| {
            if top > 0.0 && p.is_finite() && p > 0.0 {
                ((p / top) as f32).max(f32::MIN_POSITIVE)
            } else {
                0.0
            }
        })
        .collect()
}

impl Lights {
    /// Collect the lights of `scene`, chosen as `--light-sampler auto`
    /// would.
    pub fn new(scene: &Scene) -> Self {
        Self::with_sampler(scene, LightSampler::Auto)
    }

    /// Collect the lights of `scene`, to be chosen by `sampler`.
    pub fn with_sampler(scene: &Scene, sampler: LightSampler) -> Self {
        let mut area = Vec::new();
        let placed = scene.triangle_count() + scene.spheres.len();
        let mut light_of_prim = vec![NO_LIGHT; placed];
        let mut instanced_lights = Vec::new();
        let mut weights: Vec<f64> = Vec::new();
        let n_tris = scene.triangle_count() as u32;
        let inst = &scene.instances;
        // the emitting instanced triangles: every triangle of a placement
        // with an emitting override, or those of its prototype that emit
        let emits = |m: u32| scene.materials[m as usize].is_light();
        let mut instanced = inst.placements.iter().enumerate().flat_map(|(k, p)| {
            let n = inst.prototypes[p.prototype as usize].indices.len() as u32;
            (0..n)
                .filter(move |&t| emits(inst.material_index(k, t)))
                .map(move |t| p.first_prim + t)
        });
        let mut prim = 0;
        loop {
            if prim as usize >= placed {
                match instanced.next() {
                    Some(p) => prim = p,
                    None => break,
                }
            }
            let m = scene.material(prim);
            if !m.is_light() {
                prim += 1;
                continue;
            }
            let next = prim + 1;
            let quad = (next < n_tris
                && scene.tri_material[prim as usize] == scene.tri_material[next as usize])
                .then(|| Quad::find(scene.triangle(prim), scene.triangle(next)))
                .flatten();
            let (a, shape) = match scene.sphere(prim) {
                None if quad.is_some() => {
                    let (mut q, ..) = quad.expect("checked");
                    q.second = next;
                    light_of_prim[next as usize] = area.len() as u32;
                    (q.areas[0] + q.areas[1], Emitter::Quad(q))
                }
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
            match light_of_prim.get_mut(prim as usize) {
                Some(l) => *l = area.len() as u32,
                None => instanced_lights.push((prim, area.len() as u32)),
            }
            weights.push(luminance_f64(m.emission).max(0.0) * a as f64 * PI_F64 * sides);
            area.push(AreaLight {
                prim,
                le: m.emission,
                two_sided: m.two_sided,
                area: a,
                shape,
            });
            if (prim as usize) < placed {
                prim += if matches!(shape, Emitter::Quad(_)) {
                    2
                } else {
                    1
                };
            } else {
                // the next instanced emitter comes from the iterator
                prim = u32::MAX;
            }
        }
        let b = scene.bounds();
        let r = if b.is_empty() {
            1.0
        } else {
            (0.5 * (b.max - b.min).length()).max(1e-3)
        };
        weights.extend(scene.point_lights.iter().map(|l| l.power()));
        weights.extend(scene.spot_lights.iter().map(|l| l.power()));
        weights.extend(scene.panel_lights.iter().map(|l| l.power()));
        weights.extend(scene.directional_lights.iter().map(|l| l.power(r)));
        if let Some(env) = scene.environment {
            let r = r as f64;
            weights.push(luminance_f64(env).max(0.0) * PI_F64 * PI_F64 * r * r);
        }
        if let Some(map) = &scene.environment_map {
            weights.push(map.power(r));
        }
        let bvh = sampler
            .picks_bvh(crate::plan::finite_light_count(scene))
            .then(|| build_bvh(scene, &area, &weights));
        Lights {
            area,
            light_of_prim,
            instanced_lights,
            bvh,
            points: scene.point_lights.clone(),
            spots: scene.spot_lights.clone(),
            panels: scene.panel_lights.clone(),
            directionals: scene.directional_lights.clone(),
            environment: scene.environment,
            environment_map: scene.environment_map.clone(),
            select: Discrete::new(&selection_weights(&weights)),
            textured_emission: scene.materials.iter().any(|m| m.maps.emission.is_some()),
        }
    }

    /// Whether some emissive material has an emission texture.
    #[inline]
    pub fn has_textured_emission(&self) -> bool {
        self.textured_emission
    }

    /// The area lights.
    pub fn area_lights(&self) -> &[AreaLight] {
        &self.area
    }

    /// Whether there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        match &self.bvh {
            Some(b) => b.is_empty(),
            None => self.select.is_empty(),
        }
    }

    /// Whether [`Lights::choose`] gives the same light whatever its number
    /// (one light, or one with all the power, chosen without the BVH): the
    /// path tracer then skips drawing that number.
    #[inline]
    pub fn choice_is_certain(&self) -> bool {
        self.bvh.is_none() && self.select.is_certain()
    }

    /// Whether lights are chosen by the light BVH.
    pub fn uses_bvh(&self) -> bool {
        self.bvh.is_some()
    }

    /// Probability of choosing the light with selection index `i` from
    /// `from` (the point and normal light sampling looks from).
    #[inline]
    fn pmf(&self, from: &SurfacePoint, i: usize) -> f32 {
        match &self.bvh {
            Some(b) => b.pmf(from.p, from.n, i),
            None => self.select.pmf(i),
        }
    }

    /// Probability of choosing the light at infinity with selection index
    /// `i` (the same from every point).
    #[inline]
    fn pmf_infinite(&self, i: usize) -> f32 {
        match &self.bvh {
            Some(b) => b.pmf(Vec3::ZERO, Vec3::ZERO, i),
            None => self.select.pmf(i),
        }
    }

    /// Probability with which [`Lights::sample`] from `from` chooses each
    /// light, by selection index (area lights, point, spot and directional
    /// lights, panel lights, the environment, the map), for tests and tools.
    pub fn selection_pmfs(&self, from: &SurfacePoint) -> Vec<f32> {
        (0..self.environment_map_index() + usize::from(self.environment_map.is_some()))
            .map(|i| self.pmf(from, i))
            .collect()
    }

    /// The light [`Lights::sample`] from `from` chooses with `u_select`:
    /// its selection index and probability.
    pub fn choose(
        &self,
        from: &SurfacePoint,
        u_select: f32,
    ) -> Option<crate::sampling::DiscreteSample> {
        match &self.bvh {
            Some(b) => b.sample(from.p, from.n, u_select),
            None => self.select.sample(u_select),
        }
    }

    /// Whether some light can be found by light sampling alone
    /// ([`LightSample::unreachable`]): one with a delta distribution (point,
    /// spot, directional), or a panel light.
    pub fn has_unreachable(&self) -> bool {
        !self.points.is_empty()
            || !self.spots.is_empty()
            || !self.panels.is_empty()
            || !self.directionals.is_empty()
    }

    /// The solid-angle density of light sampling when the only light is
    /// the uniform environment (`1 / (4 pi)` everywhere); `None` for any
    /// other set of lights. (An environment map's highest density,
    /// `max L / int L dw`, was tried as a bound too; it let bounces on
    /// rough metal skip light sampling where that raised the noise, see
    /// `LIGHT_SAMPLING_PEAK_RATIO`.)
    pub fn peak_pdf(&self) -> Option<f32> {
        let only_uniform = self.area.is_empty()
            && !self.has_unreachable()
            && self.environment_map.is_none()
            && self.environment.is_some();
        only_uniform.then_some(0.25 * std::f32::consts::FRAC_1_PI)
    }

    /// The highest solid-angle density of light sampling when an
    /// environment map is the only light: `max L / int L dw` over its
    /// texels' luminance, the density the map's sampling has where it is
    /// brightest; `None` for any other set of lights. Unlike
    /// [`Lights::peak_pdf`]'s, this bound alone does not say where BSDF
    /// sampling does better (`src/integrator/light_choice.rs` measures it).
    pub fn environment_map_peak_pdf(&self) -> Option<f32> {
        let map = self.environment_map.as_ref()?;
        let only_map =
            self.area.is_empty() && !self.has_unreachable() && self.environment.is_none();
        let integral = map.luminance_integral();
        if !only_map || !(integral > 0.0) {
            return None;
        }
        let max = map
            .map()
            .texels()
            .iter()
            .map(|&t| crate::math::luminance_f64(t * map.radiance()))
            .fold(0.0f64, f64::max);
        Some((max / integral) as f32)
    }

    /// Whether an escaping ray sees any radiance.
    pub fn has_environment(&self) -> bool {
        self.environment.is_some() || self.environment_map.is_some()
    }

    /// Selection index of the uniform environment.
    fn environment_index(&self) -> usize {
        self.area.len()
            + self.points.len()
            + self.spots.len()
            + self.panels.len()
            + self.directionals.len()
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
        let chosen = self.choose(from, u_select)?;
        let mut i = chosen.index;
        if i < self.area.len() {
            return self.sample_area(scene, &self.area[i], chosen.pmf, from, u);
        }
        i -= self.area.len();
        let (n_points, n_spots) = (self.points.len(), self.spots.len());
        let n_finite = n_points + n_spots + self.panels.len();
        let delta = if i < n_points {
            self.points[i].sample_li(from)?
        } else if i < n_points + n_spots {
            self.spots[i - n_points].sample_li(from)?
        } else if i < n_finite {
            let s = self.panels[i - n_points - n_spots].sample_li(from, u)?;
            return Some(LightSample {
                wi: s.wi,
                li: s.li,
                pdf: chosen.pmf * s.pdf,
                unreachable: true,
                shadow: spawn_ray_to(from, &s.to),
            });
        } else if i < n_finite + self.directionals.len() {
            self.directionals[i - n_finite].sample_li(from)
        } else if chosen.index == self.environment_index() && self.environment.is_some() {
            let wi = square_to_uniform_sphere(u);
            return Some(LightSample {
                wi,
                li: self.environment.unwrap_or(Vec3::ZERO),
                pdf: chosen.pmf * square_to_uniform_sphere_pdf(wi),
                unreachable: false,
                shadow: spawn_ray(from, wi),
            });
        } else {
            let map = self.environment_map.as_ref()?;
            let s = map.sample(u)?;
            return Some(LightSample {
                wi: s.wi,
                li: s.li,
                pdf: chosen.pmf * s.pdf,
                unreachable: false,
                shadow: spawn_ray(from, s.wi),
            });
        };
        Some(LightSample {
            wi: delta.wi,
            li: delta.li,
            pdf: chosen.pmf * delta.pdf,
            unreachable: true,
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
        // `at`: the primitive and barycentrics of the point (for its UV)
        let (to, solid_angle_pdf, area, at) = match light.shape {
            Emitter::Triangle => {
                let b = square_to_uniform_triangle(u);
                let to = scene.surface_point(light.prim, b.x, b.y);
                (to, None, light.area, (light.prim, b.x, b.y))
            }
            Emitter::Quad(ref q) => {
                let spherical = q.spherical(from.p);
                let (s, t) = match &spherical {
                    Some(sr) => {
                        let [s, t] = sr.sample(u);
                        (s as f32, t as f32)
                    }
                    None => (u.x, u.y),
                };
                let (k, bu, bv) = q.locate(s, t);
                let prim = if k == 0 { light.prim } else { q.second };
                (
                    scene.surface_point(prim, bu, bv),
                    spherical.map(|sr| (1.0 / sr.solid_angle()) as f32),
                    2.0 * q.areas[k],
                    (prim, bu, bv),
                )
            }
            Emitter::Sphere { center, radius } => match sphere_cone(center, radius, from.p) {
                Some(cone) => {
                    let p = cone.sample(u);
                    (
                        SurfacePoint::on_sphere(center, radius, p),
                        Some(cone.pdf()),
                        light.area,
                        (light.prim, 0.0, 0.0),
                    )
                }
                None => {
                    let n = square_to_uniform_sphere(u);
                    (
                        SurfacePoint::on_sphere(center, radius, center + radius * n),
                        None,
                        light.area,
                        (light.prim, 0.0, 0.0),
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
                None => dist2 / (cos_l.abs() * area),
            };
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        let mut li = light.le;
        if self.textured_emission {
            if let Some(t) = &scene.material(light.prim).maps.emission {
                li = t.eval(scene.uv(at.0, &to, at.1, at.2));
            }
        }
        Some(LightSample {
            wi,
            li,
            pdf,
            unreachable: false,
            shadow: spawn_ray_to(from, &to),
        })
    }

    /// Solid-angle density with which [`Lights::sample`] from `from` would
    /// produce the point `to` on emissive primitive `prim`.
    pub fn pdf_area(&self, from: &SurfacePoint, prim: u32, to: &SurfacePoint) -> f32 {
        let idx = match self.light_of_prim.get(prim as usize) {
            Some(&i) => i,
            None => match self.instanced_lights.binary_search_by_key(&prim, |e| e.0) {
                Ok(k) => self.instanced_lights[k].1,
                Err(_) => NO_LIGHT,
            },
        };
        if idx == NO_LIGHT {
            return 0.0;
        }
        let light = &self.area[idx as usize];
        let pmf = self.pmf(from, idx as usize);
        let area = match light.shape {
            Emitter::Sphere { center, radius } => {
                if let Some(cone) = sphere_cone(center, radius, from.p) {
                    return pmf * cone.pdf();
                }
                light.area
            }
            Emitter::Quad(ref q) => {
                if let Some(sr) = q.spherical(from.p) {
                    return pmf * (1.0 / sr.solid_angle()) as f32;
                }
                2.0 * q.areas[usize::from(prim == q.second)]
            }
            Emitter::Triangle => light.area,
        };
        let delta = to.p - from.p;
        let dist2 = delta.length_squared();
        let cos_l = to.n.dot(delta).abs() / dist2.sqrt();
        if !(cos_l > 0.0) || !(area > 0.0) {
            return 0.0;
        }
        pmf * dist2 / (cos_l * area)
    }

    /// [`Lights::environment`] and [`Lights::pdf_environment`] of one
    /// escaping direction, the map's coordinates computed once.
    pub fn environment_and_pdf(&self, wi: Vec3) -> (Vec3, f32) {
        let mut l = self.environment.unwrap_or(Vec3::ZERO);
        let mut pdf = 0.0;
        if self.environment.is_some() {
            pdf += self.pmf_infinite(self.environment_index()) * square_to_uniform_sphere_pdf(wi);
        }
        if let Some(map) = &self.environment_map {
            let (le, p) = map.eval_and_pdf(wi);
            l += le;
            pdf += self.pmf_infinite(self.environment_map_index()) * p;
        }
        (l, pdf)
    }

    /// Solid-angle density with which [`Lights::sample`] picks direction `wi`
    /// on the environment (both kinds together).
    pub fn pdf_environment(&self, wi: Vec3) -> f32 {
        let mut pdf = 0.0;
        if self.environment.is_some() {
            pdf += self.pmf_infinite(self.environment_index()) * square_to_uniform_sphere_pdf(wi);
        }
        if let Some(map) = &self.environment_map {
            pdf += self.pmf_infinite(self.environment_map_index()) * map.pdf(wi);
        }
        pdf
    }
}

/// The light BVH over `scene`'s lights: `area` (its area lights, first in
/// the selection order) and the point, spot and panel lights in the tree, the
/// lights at infinity beside it; `powers` are every selection item's
/// powers, in order.
fn build_bvh(scene: &Scene, area: &[AreaLight], powers: &[f64]) -> LightBvh {
    let (n_area, n_points, n_spots) = (
        area.len(),
        scene.point_lights.len(),
        scene.spot_lights.len(),
    );
    // a spot light's bound is a point light's of the same intensity, its
    // cone doing the rest (pbrt-v4's `SpotLight::Bounds`)
    let mut phi: Vec<f64> = powers.to_vec();
    for (k, s) in scene.spot_lights.iter().enumerate() {
        phi[n_area + n_points + k] = 4.0 * PI_F64 * luminance_f64(s.intensity).max(0.0);
    }
    let n_finite = n_area + n_points + n_spots + scene.panel_lights.len();
    let phi = selection_weights(&phi[..n_finite]);
    let mut items: Vec<(u32, LightBounds)> = Vec::with_capacity(phi.len());
    for (k, light) in area.iter().enumerate() {
        let corners: Vec<Vec3> = match light.shape {
            Emitter::Triangle => scene.triangle(light.prim).to_vec(),
            Emitter::Quad(q) => {
                let mut c = scene.triangle(light.prim).to_vec();
                c.extend(scene.triangle(q.second));
                c
            }
            Emitter::Sphere { center, radius } => {
                vec![center - Vec3::splat(radius), center + Vec3::splat(radius)]
            }
        };
        let (min, max) = corners
            .iter()
            .fold((corners[0], corners[0]), |(lo, hi), c| {
                (lo.min(*c), hi.max(*c))
            });
        let (w, cos_theta_o) = match light.shape {
            // every normal: a sphere emits in every direction
            Emitter::Sphere { .. } => (Vec3::Z, -1.0),
            _ => (scene.surface_point(light.prim, 1.0 / 3.0, 1.0 / 3.0).n, 1.0),
        };
        items.push((
            k as u32,
            LightBounds {
                min,
                max,
                w,
                phi: phi[k],
                cos_theta_o,
                cos_theta_e: 0.0,
                two_sided: light.two_sided,
            },
        ));
    }
    for (j, l) in scene.point_lights.iter().enumerate() {
        let k = n_area + j;
        items.push((
            k as u32,
            LightBounds {
                min: l.position,
                max: l.position,
                w: Vec3::Z,
                phi: phi[k],
                cos_theta_o: -1.0,
                cos_theta_e: 0.0,
                two_sided: false,
            },
        ));
    }
    for (j, l) in scene.spot_lights.iter().enumerate() {
        let k = n_area + n_points + j;
        let (cutoff, beam) = (l.cutoff_angle().to_radians(), l.beam_width().to_radians());
        items.push((
            k as u32,
            LightBounds {
                min: l.position,
                max: l.position,
                w: l.axis(),
                phi: phi[k],
                cos_theta_o: beam.cos(),
                cos_theta_e: (cutoff - beam).cos(),
                two_sided: false,
            },
        ));
    }
    for (j, l) in scene.panel_lights.iter().enumerate() {
        let k = n_area + n_points + n_spots + j;
        let c = l.corners();
        let (min, max) = (
            c[0].min(c[1]).min(c[2].min(c[3])),
            c[0].max(c[1]).max(c[2].max(c[3])),
        );
        items.push((
            k as u32,
            LightBounds {
                min,
                max,
                w: l.facing,
                phi: phi[k],
                cos_theta_o: 1.0,
                cos_theta_e: 0.0,
                two_sided: false,
            },
        ));
    }
    let first_infinite = n_finite;
    let infinite: Vec<u32> = (first_infinite..powers.len())
        .filter(|&i| powers[i].is_finite() && powers[i] > 0.0)
        .map(|i| i as u32)
        .collect();
    LightBvh::new(&items, infinite, powers.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;

    #[test]
    fn powers_beyond_f32_are_weighed_in_f64() {
        assert_eq!(selection_weights(&[4.0, 1.0, 0.0]), [1.0, 0.25, 0.0]);
        let w = selection_weights(&[f64::MAX, 1.0, -1.0, f64::NAN, f64::INFINITY]);
        assert_eq!(w, [1.0, f32::MIN_POSITIVE, 0.0, 0.0, 0.0]);
        assert_eq!(selection_weights(&[0.0, 0.0]), [0.0, 0.0]);
    }

    /// A point light of 1e38 W/sr: its power `4 pi I` overflows `f32`,
    /// which gave it weight 0 beside a weak light (and nothing to sample
    /// alone).
    #[test]
    fn a_point_light_whose_power_overflows_f32_is_chosen_by_its_power() {
        let mut scene = SceneBuilder::new(std::path::Path::new("t.toml")).build();
        scene.point_lights = vec![
            PointLight::new(Vec3::Y, Vec3::splat(1e38)),
            PointLight::new(Vec3::Y, Vec3::ONE),
        ];
        let lights = Lights::new(&scene);
        assert_eq!(lights.select.pmf(0), 1.0);
        assert!(lights.select.pmf(1) > 0.0, "the weak light keeps a chance");
        scene.point_lights.truncate(1);
        assert!(!Lights::new(&scene).is_empty());
    }
}
