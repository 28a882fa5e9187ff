//! The effects plan: which effects a scene calls for, what calls for each,
//! and which estimator kernel runs it.
//!
//! Loading a scene gives a [`Scene`]; [`Plan::new`] reads off it (and the
//! render settings) the set of effects in use, by the fixed names of
//! [`EFFECTS`], and derives the [`Kernel`] flags from that set. The path
//! tracer is generic over those flags (`src/integrator`), so a scene runs
//! code compiled without the effects it lacks: a diffuse-only box has no
//! material dispatch and no Fresnel code, a scene without delta lights or
//! delta BSDFs has no delta checks, one without an environment returns
//! black on a miss at once, a pinhole camera never draws a lens sample.
//! `--plan general` runs [`Kernel::GENERAL`] instead: same image bits,
//! possibly more time (tested on every bundled scene and backend).
//!
//! The plan decides the kernel and the integrator runs it: the integrator
//! imports this module, never the other way round.

use crate::bsdf::Bxdf;
use crate::scene::{AlphaMask, Scene};
use crate::settings::{IntegratorSettings, LIGHT_BVH_FROM, LightSampler};
use std::fmt::Write;
use std::str::FromStr;

/// The effects an estimator kernel is compiled for. Each flag switches code
/// on at compile time: a kernel whose flag is off has no branch, call or
/// table lookup for that effect. The general kernel (every flag on) checks
/// each effect per shading point instead; on a scene without the effect those
/// checks take the branch the specialised kernel compiled, with the same
/// arithmetic in the same order, so both give the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Kernel {
    /// Material dispatch (mirror, glass, conductor, plastic) and textures;
    /// off: every surface is a Lambertian with a per-material albedo.
    pub materials: bool,
    /// Delta lights, panel lights (found by light sampling alone, like
    /// delta lights) or delta BSDF lobes; off: no delta checks, every sample
    /// has a density and MIS applies to all of them.
    pub delta: bool,
    /// Environment lighting; off: an escaping ray returns black at once.
    pub environment: bool,
    /// Emissive surfaces (area lights); off: a hit is never looked up for
    /// emission and, with no environment either, no MIS weight is computed.
    pub emitters: bool,
    /// Spheres, smooth normals, normal or bump maps, or instances: a
    /// shading normal that may differ from the geometric one, with the side
    /// checks against the geometric normal that keep light from crossing
    /// the surface, and hits resolved through the instances; off: every hit
    /// is a flat-shaded triangle of the scene's own arrays.
    pub shapes: bool,
    /// A thin-lens camera; off: camera rays come from the pinhole, with no
    /// lens sample drawn.
    pub lens: bool,
}

impl Kernel {
    /// Every effect on: the fully general kernel (`--plan general`).
    pub const GENERAL: Kernel = Kernel {
        materials: true,
        delta: true,
        environment: true,
        emitters: true,
        shapes: true,
        lens: true,
    };

    /// What a kernel without each flag leaves out, for the flags that are off.
    pub fn omitted(&self) -> Vec<&'static str> {
        [
            (
                self.materials,
                "material dispatch, Fresnel and texture code",
            ),
            (self.delta, "delta-lobe and delta-light checks"),
            (self.environment, "environment lookups on escape"),
            (self.emitters, "emission lookups at hits"),
            (
                self.shapes,
                "sphere, smooth-normal, normal/bump-map and instance shading",
            ),
            (self.lens, "lens sampling"),
        ]
        .iter()
        .filter(|(on, _)| !on)
        .map(|(_, what)| *what)
        .collect()
    }

    /// The flags as a short string, e.g. `materials+delta`, or `minimal`.
    pub fn describe(&self) -> String {
        let on: Vec<&str> = [
            ("materials", self.materials),
            ("delta", self.delta),
            ("environment", self.environment),
            ("emitters", self.emitters),
            ("shapes", self.shapes),
            ("lens", self.lens),
        ]
        .iter()
        .filter(|(_, f)| *f)
        .map(|(n, _)| *n)
        .collect();
        if on.is_empty() {
            "minimal".to_string()
        } else {
            on.join("+")
        }
    }
}

/// The effect names, in the order `plan` lists them. These names are fixed:
/// scripts read them from `plan --json` and from the render report.
pub const EFFECTS: [&str; 24] = [
    "diffuse",
    "mirror",
    "glass",
    "conductor",
    "plastic",
    "texture",
    "area_light",
    "point_light",
    "directional_light",
    "environment",
    "environment_map",
    "sphere",
    "smooth_normals",
    "thin_lens",
    "indirect",
    // appended (not grouped with the materials) so that the positions of
    // the earlier names in `plan --json` stay as they were
    "phong",
    // the production-scene names, appended in their fixed order
    "instancing",
    "many_lights",
    "spot_light",
    "normal_map",
    "bump_map",
    "alpha_mask",
    "emitter_roles",
    "metallic_roughness",
];

/// Which kernel to run (`--plan`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlanMode {
    /// The kernel specialised for the scene's effects.
    #[default]
    Specialised,
    /// The fully general kernel, whatever the scene.
    General,
}

impl FromStr for PlanMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "specialised" | "specialized" | "auto" => Ok(PlanMode::Specialised),
            "general" => Ok(PlanMode::General),
            _ => Err(format!(
                "unknown plan `{s}` (expected specialised or general)"
            )),
        }
    }
}

/// One effect's entry in the plan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Effect {
    /// Its fixed name (one of [`EFFECTS`]).
    pub name: &'static str,
    /// Whether the scene calls for it.
    pub on: bool,
    /// What in the scene calls for it (materials, lights, shapes), or why
    /// it is off.
    pub because: String,
    /// The code that runs for it, or that the kernel leaves out.
    pub code: &'static str,
}

/// The effects a scene calls for and the kernel that renders it.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Every effect of [`EFFECTS`], in order.
    pub effects: Vec<Effect>,
    /// The specialised kernel's flags.
    pub kernel: Kernel,
}

/// The lights of `scene` that are not at infinity: emissive primitives
/// that light sampling picks (each triangle of an emissive quad counts;
/// [`crate::scene::Material::is_light`]), point, spot and panel lights.
/// What `--light-sampler auto` counts ([`crate::settings::LightSampler`]).
pub fn finite_light_count(scene: &Scene) -> usize {
    (0..scene.primitive_count() as u32)
        .filter(|&p| scene.material(p).is_light())
        .count()
        + scene.point_lights.len()
        + scene.spot_lights.len()
        + scene.panel_lights.len()
}

/// Up to three names, then how many more.
fn list(names: &[String]) -> String {
    let mut s = names
        .iter()
        .take(3)
        .map(|n| n.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > 3 {
        let _ = write!(s, " and {} more", names.len() - 3);
    }
    s
}

impl Plan {
    /// The plan for `scene` rendered with `settings`.
    pub fn new(scene: &Scene, settings: &IntegratorSettings) -> Self {
        // the materials some primitive uses, with what uses them
        let used_materials: Vec<_> = scene
            .used_materials()
            .into_iter()
            .map(|m| &scene.materials[m as usize])
            .collect();
        let of_type = |t: &str| -> Vec<String> {
            let mut v: Vec<String> = used_materials
                .iter()
                .filter(|m| m.type_name() == t)
                .map(|m| format!("`{}`", m.name))
                .collect();
            v.dedup();
            v
        };
        let textured: Vec<String> = used_materials
            .iter()
            .flat_map(|m| {
                m.textured()
                    .into_iter()
                    .map(|(key, _)| format!("`{}` {key}", m.name))
            })
            .collect();
        let emitters: Vec<String> = used_materials
            .iter()
            .filter(|m| m.emission.max_element() > 0.0)
            .map(|m| format!("`{}`", m.name))
            .collect();
        let smooth = scene
            .tri_shading_normals
            .iter()
            .chain(
                scene
                    .instances
                    .shading
                    .iter()
                    .flat_map(|p| &p.tri_shading_normals),
            )
            .filter(|c| c.iter().all(|n| *n != crate::math::Vec3::ZERO))
            .count();
        let delta_bsdfs: Vec<String> = used_materials
            .iter()
            .filter(|m| m.bsdf.has_delta_component())
            .map(|m| m.name.clone())
            .collect();
        let lens = scene.lens;
        let prims = scene.primitive_count();

        let mut effects = Vec::new();
        let mut add = |name: &'static str, names: Vec<String>, what: &str, code: &'static str| {
            let on = !names.is_empty();
            effects.push(Effect {
                name,
                on,
                because: if on {
                    format!("{what}: {}", list(&names))
                } else {
                    format!("no {what}")
                },
                code,
            });
        };
        add(
            "diffuse",
            of_type("diffuse"),
            "diffuse materials",
            "Lambertian eval/sample (bsdf/diffuse.rs)",
        );
        add(
            "mirror",
            of_type("mirror"),
            "mirror materials",
            "delta reflection (bsdf/mirror.rs)",
        );
        add(
            "glass",
            [
                of_type("glass"),
                of_type("thin_glass"),
                of_type("rough_glass"),
            ]
            .concat(),
            "glass materials",
            "Fresnel reflection and refraction, eta^2 roulette scale (bsdf/glass.rs)",
        );
        add(
            "conductor",
            of_type("conductor"),
            "conductor materials",
            "microfacet conductor, complex Fresnel, VNDF sampling (bsdf/conductor.rs)",
        );
        add(
            "plastic",
            of_type("plastic"),
            "plastic materials",
            "coated diffuse with dielectric Fresnel (bsdf/plastic.rs)",
        );
        add(
            "texture",
            textured,
            "textured parameters",
            "bilinear lookups of the textured parameters at the hit's UV (texture.rs, scene/maps.rs)",
        );
        add(
            "area_light",
            emitters,
            "emissive materials",
            "emission lookup at hits, area-light sampling, MIS (integrator/lights.rs, light/mod.rs)",
        );
        add(
            "point_light",
            (0..scene.point_lights.len())
                .map(|i| format!("point light {i}"))
                .collect(),
            "point lights",
            "delta light samples, MIS weight 1 (light/point.rs)",
        );
        add(
            "directional_light",
            (0..scene.directional_lights.len())
                .map(|i| format!("directional light {i}"))
                .collect(),
            "directional lights",
            "delta light samples, MIS weight 1 (light/directional.rs)",
        );
        add(
            "environment",
            scene
                .environment
                .map(|e| vec![format!("radiance {e}")])
                .unwrap_or_default(),
            "uniform environment",
            "radiance on escape, uniform sphere sampling (integrator/lights.rs)",
        );
        add(
            "environment_map",
            if scene.environment_map.is_some() {
                vec!["environment light with `file`".to_string()]
            } else {
                Vec::new()
            },
            "environment map",
            "map lookup on escape, 2D piecewise-constant sampling (light/envmap.rs)",
        );
        add(
            "sphere",
            if scene.spheres.is_empty() {
                Vec::new()
            } else {
                vec![format!("{} spheres", scene.spheres.len())]
            },
            "analytic spheres",
            "sphere hit points and UVs, cone sampling of emissive spheres (scene, light/mod.rs)",
        );
        add(
            "smooth_normals",
            if smooth > 0 {
                vec![format!("{smooth} triangles with vertex normals")]
            } else {
                Vec::new()
            },
            "vertex normals",
            "interpolated shading normals, leak checks, terminator offset (integrator)",
        );
        add(
            "thin_lens",
            if lens.is_pinhole() {
                Vec::new()
            } else {
                vec![format!(
                    "aperture_radius {} focus_distance {}",
                    lens.aperture_radius, lens.focus_distance
                )]
            },
            "camera aperture",
            "lens sample per camera ray (camera.rs)",
        );
        add(
            "indirect",
            if settings.max_depth >= 2 && prims > 0 {
                vec![format!("max_depth {}", settings.max_depth)]
            } else {
                Vec::new()
            },
            "bounces past the first (max_depth >= 2 and something to hit)",
            "recursive BSDF-sampled continuation with Russian roulette (integrator)",
        );
        add(
            "phong",
            of_type("phong"),
            "phong materials",
            "Lambertian plus a Phong or GGX-Schlick lobe, mixture sampling (bsdf/phong.rs)",
        );
        let inst = &scene.instances;
        add(
            "instancing",
            if inst.is_empty() {
                Vec::new()
            } else {
                vec![format!(
                    "{} placements of {} prototypes ({} triangles placed, {} stored)",
                    inst.placements.len(),
                    inst.prototypes.len(),
                    inst.triangle_count(),
                    inst.prototypes
                        .iter()
                        .map(|p| p.indices.len())
                        .sum::<usize>()
                )]
            },
            "instances",
            "two-level queries (object-space rays per placement), instance lookup and transform of hit points (scene/instances.rs, accel/instance.rs)",
        );
        // its `on` and `because` are set below, once `add` is done
        add(
            "many_lights",
            Vec::new(),
            "light BVH",
            "light BVH traversal by importance, pmf by bit trail (integrator/light_bvh.rs)",
        );
        add(
            "spot_light",
            (0..scene.spot_lights.len())
                .map(|i| format!("spot light {i}"))
                .collect(),
            "spot lights",
            "delta light samples with Mitsuba's falloff, MIS weight 1 (light/spot.rs)",
        );
        let mapped = |f: fn(&crate::scene::Maps) -> bool| -> Vec<String> {
            used_materials
                .iter()
                .filter(|m| f(&m.maps))
                .map(|m| format!("`{}`", m.name))
                .collect()
        };
        add(
            "normal_map",
            mapped(|m| m.normal.is_some()),
            "materials with a normal_map",
            "tangent-space normal lookup in a UV tangent frame, side checks against ng (integrator/path/mod.rs, scene/maps.rs)",
        );
        add(
            "bump_map",
            mapped(|m| m.bump.is_some()),
            "materials with a bump_map",
            "height-gradient lookup, perturbed dp/du x dp/dv normal, side checks against ng (integrator/path/mod.rs, texture.rs)",
        );
        add(
            "alpha_mask",
            used_materials
                .iter()
                .filter_map(|m| {
                    Some(match m.alpha_mask.as_ref()? {
                        AlphaMask::Constant(a) => format!("`{}` (alpha {a})", m.name),
                        AlphaMask::Texture(t) => format!(
                            "`{}` (alpha texture {})",
                            m.name,
                            t.source()
                                .map_or("in memory".into(), |p| p.display().to_string())
                        ),
                    })
                })
                .collect(),
            "surfaces with an alpha mask",
            "a stochastic opacity test on candidate hits inside the traversal (Embree filter functions, the Rust backends' filtered leaves), queries a ray at a time (scene/alpha.rs, accel)",
        );
        let mut roles: Vec<String> = (0..scene.panel_lights.len())
            .map(|i| format!("panel light {i} (sampled only, no surface)"))
            .collect();
        roles.extend(
            used_materials
                .iter()
                .filter(|m| m.is_seen_only())
                .map(|m| format!("`{}` (emission seen only)", m.name)),
        );
        add(
            "emitter_roles",
            roles,
            "emitters with a role other than an area light's",
            "panel lights sampled with MIS weight 1 and never hit (light/panel.rs); seen-only emission counted on camera rays and after delta bounces alone (integrator/path/mod.rs)",
        );
        add(
            "metallic_roughness",
            of_type("metallic_roughness"),
            "metallic-roughness materials",
            "glTF 2.0's Lambertian and GGX-Schlick lobes mixed by metalness, mixture sampling (bsdf/metallic_roughness.rs)",
        );
        let finite_lights = finite_light_count(scene);
        let bvh = settings.light_sampler.picks_bvh(finite_lights);
        if let Some(e) = effects.iter_mut().find(|e| e.name == "many_lights") {
            e.on = bvh;
            e.because = match (bvh, settings.light_sampler) {
                (true, LightSampler::Auto) => format!(
                    "light BVH: {finite_lights} lights, at least {LIGHT_BVH_FROM} (--light-sampler auto)"
                ),
                (true, _) => format!("light BVH: --light-sampler bvh ({finite_lights} lights)"),
                (false, LightSampler::Auto) => format!(
                    "no light BVH: {finite_lights} lights, under {LIGHT_BVH_FROM}: chosen by power (--light-sampler auto)"
                ),
                (false, _) => "no light BVH: --light-sampler power".to_string(),
            };
        }
        let on = |n: &str| effects.iter().any(|e| e.name == n && e.on);
        let kernel = Kernel {
            materials: [
                "mirror",
                "glass",
                "conductor",
                "plastic",
                "phong",
                "metallic_roughness",
                "texture",
            ]
            .iter()
            .any(|n| on(n)),
            delta: !delta_bsdfs.is_empty()
                || on("point_light")
                || on("spot_light")
                || on("directional_light")
                || !scene.panel_lights.is_empty(),
            environment: on("environment") || on("environment_map"),
            emitters: on("area_light"),
            shapes: on("sphere")
                || on("smooth_normals")
                || on("normal_map")
                || on("bump_map")
                || on("instancing"),
            lens: on("thin_lens"),
        };
        Plan { effects, kernel }
    }

    /// The names of the effects that are on.
    pub fn on(&self) -> Vec<&'static str> {
        self.effects
            .iter()
            .filter(|e| e.on)
            .map(|e| e.name)
            .collect()
    }

    /// The kernel `mode` runs.
    pub fn kernel_for(&self, mode: PlanMode) -> Kernel {
        match mode {
            PlanMode::Specialised => self.kernel,
            PlanMode::General => Kernel::GENERAL,
        }
    }

    /// The plan as `embertrace plan` prints it.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let width = EFFECTS.iter().map(|n| n.len()).max().unwrap_or(0);
        for e in &self.effects {
            let _ = writeln!(
                s,
                "{:<width$}  {:<3}  {}",
                e.name,
                if e.on { "on" } else { "off" },
                e.because
            );
            if e.on {
                let _ = writeln!(s, "{:<width$}       runs: {}", "", e.code);
            }
        }
        let _ = writeln!(s, "kernel: {}", self.kernel.describe());
        let out = self.kernel.omitted();
        if !out.is_empty() {
            let _ = writeln!(s, "compiled out: {}", out.join("; "));
        }
        s
    }

    /// The plan as JSON: `effects` (the names that are on), `kernel`, and
    /// `details` (every effect with `name`, `on`, `because` and `code`).
    pub fn json(&self) -> String {
        let details: Vec<serde_json::Value> = self
            .effects
            .iter()
            .map(|e| {
                serde_json::json!({
                    "name": e.name, "on": e.on, "because": e.because, "code": e.code
                })
            })
            .collect();
        let v = serde_json::json!({
            "effects": self.on(),
            "kernel": self.kernel.describe(),
            "details": details,
        });
        serde_json::to_string_pretty(&v).expect("strings and booleans serialise") + "\n"
    }
}
