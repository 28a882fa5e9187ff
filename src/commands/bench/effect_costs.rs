//! `embertrace bench SCENE --effects`: what each effect costs per sample.
//!
//! The scene (the diffuse Cornell box, say) is rendered under its specialised
//! kernel and under `--plan general`, then with one effect added at a time: a
//! diffuse sphere (the cost of analytic spheres alone), a mirror sphere, a
//! glass sphere, a rough conductor sphere, a textured sphere, an environment
//! map, a thin lens. Every variant renders in the same process, one after the
//! other in each repetition (so drifts in machine speed hit all rows alike),
//! and each row reports the median over the repetitions of nanoseconds per
//! sample (render seconds over pixels times spp), Mrays/s, and the ratio to
//! the first row.

use super::throughput::median;
use crate::accel::{self, AccelOptions, Backend};
use crate::bsdf::{Bsdf, Conductor, Diffuse, Distribution, Glass, Microfacet, Mirror};
use crate::camera::ThinLens;
use crate::error::Result;
use crate::integrator::PathTracer;
use crate::light::EnvironmentMap;
use crate::math::Vec3;
use crate::plan::{Kernel, Plan};
use crate::render::{RenderSettings, render};
use crate::sampler::SamplerKind;
use crate::scene::{Material, Scene};
use crate::settings::IntegratorSettings;
use crate::shape::Sphere;
use crate::texture::ImageTexture;
use serde::Serialize;
use std::fmt::Write;
use std::sync::Arc;

/// Settings of the effects benchmark.
#[derive(Debug, Clone)]
pub struct EffectCostSettings {
    /// Backend for every row.
    pub backend: Backend,
    /// Image width and height.
    pub resolution: [u32; 2],
    /// Samples per pixel per render.
    pub spp: u32,
    /// Repetitions (the median is reported).
    pub reps: usize,
    /// Render threads; 0 = all cores.
    pub threads: usize,
    /// How backends are built.
    pub options: AccelOptions,
}

/// One variant's figures.
#[derive(Debug, Clone, Serialize)]
pub struct EffectCostRow {
    /// What was added.
    pub variant: String,
    /// The kernel that ran.
    pub kernel: String,
    /// The effects its plan turns on.
    pub effects: Vec<String>,
    /// Median nanoseconds per sample.
    pub ns_per_sample: f64,
    /// Median Mrays/s.
    pub mrays_per_second: f64,
    /// `ns_per_sample` over the first row's.
    pub relative: f64,
}

/// The whole table.
#[derive(Debug, Clone, Serialize)]
pub struct EffectCostReport {
    /// Scene file.
    pub scene: String,
    /// Backend.
    pub backend: String,
    /// Resolution.
    pub resolution: [u32; 2],
    /// Samples per pixel.
    pub spp: u32,
    /// Repetitions per figure.
    pub reps: usize,
    /// Rows.
    pub rows: Vec<EffectCostRow>,
}

/// A variant of the base scene: its name, the scene and whether to force the
/// general kernel.
struct Variant {
    name: &'static str,
    scene: Scene,
    general: bool,
}

/// The base scene with a sphere of `material` on its floor.
fn with_sphere(base: &Scene, name: &str, bsdf: Bsdf, texture: Option<Arc<ImageTexture>>) -> Scene {
    let mut s = base.clone();
    let b = base.bounds();
    let size = (b.max - b.min).min_element().max(1e-3);
    let r = 0.17 * size;
    let centre = Vec3::new(
        0.5 * (b.min.x + b.max.x) + 0.2 * size,
        b.min.y + r,
        0.5 * (b.min.z + b.max.z) + 0.15 * size,
    );
    s.sphere_material.push(s.materials.len() as u32);
    s.materials.push(Material {
        name: name.to_string(),
        bsdf,
        texture,
        ..Material::default()
    });
    s.spheres.push(Sphere {
        center: centre,
        radius: r,
    });
    s
}

/// A 64 x 64 checkerboard texture.
fn checker() -> Arc<ImageTexture> {
    let mut rgb = Vec::with_capacity(64 * 64 * 3);
    for y in 0..64 {
        for x in 0..64 {
            let v = if (x / 8 + y / 8) % 2 == 0 { 0.7 } else { 0.2 };
            rgb.extend([v, v, v]);
        }
    }
    Arc::new(ImageTexture::from_linear_rgb(64, 64, rgb).expect("a valid texture"))
}

/// A 64 x 32 sky: a blue gradient and a bright spot.
fn sky() -> EnvironmentMap {
    let mut rgb = Vec::with_capacity(64 * 32 * 3);
    for y in 0..32 {
        for x in 0..64 {
            let v = y as f32 / 31.0;
            let spot = if (10..14).contains(&x) && (8..11).contains(&y) {
                20.0
            } else {
                0.0
            };
            rgb.extend([0.3 + spot, 0.5 * (1.0 - v) + spot, 1.0 - 0.6 * v + spot]);
        }
    }
    let map = ImageTexture::from_linear_rgb(64, 32, rgb).expect("a valid map");
    EnvironmentMap::new(map, Vec3::ONE).expect("a valid environment")
}

fn variants(base: &Scene) -> Vec<Variant> {
    let v = |name, scene, general| Variant {
        name,
        scene,
        general,
    };
    let mut lens = base.clone();
    lens.lens = ThinLens {
        aperture_radius: 0.05 * (base.camera.target - base.camera.origin).length(),
        focus_distance: (base.camera.target - base.camera.origin).length(),
    };
    let mut env = base.clone();
    env.environment_map = Some(sky());
    let gold = Conductor {
        eta: Vec3::new(0.166, 0.431, 1.38),
        k: Vec3::new(3.15, 2.35, 1.76),
        microfacet: Microfacet::new(Distribution::Ggx, 0.2),
    };
    vec![
        v("base scene", base.clone(), false),
        v("base scene, --plan general", base.clone(), true),
        v(
            "+ diffuse sphere",
            with_sphere(
                base,
                "sphere",
                Bsdf::Diffuse(Diffuse {
                    albedo: Vec3::splat(0.7),
                }),
                None,
            ),
            false,
        ),
        v(
            "+ mirror sphere",
            with_sphere(base, "mirror", Bsdf::Mirror(Mirror::default()), None),
            false,
        ),
        v(
            "+ glass sphere",
            with_sphere(base, "glass", Bsdf::Glass(Glass::default()), None),
            false,
        ),
        v(
            "+ rough conductor sphere",
            with_sphere(base, "gold", Bsdf::Conductor(gold), None),
            false,
        ),
        v(
            "+ textured diffuse sphere",
            with_sphere(
                base,
                "checker",
                Bsdf::Diffuse(Diffuse { albedo: Vec3::ONE }),
                Some(checker()),
            ),
            false,
        ),
        v("+ environment map", env, false),
        v("+ thin lens", lens, false),
    ]
}

/// Run the benchmark on `base`; `progress` gets a line per repetition.
pub fn run(
    base: &Scene,
    settings: &EffectCostSettings,
    integrator: IntegratorSettings,
    progress: &dyn Fn(&str),
) -> Result<EffectCostReport> {
    let variants = variants(base);
    let mut accels = Vec::new();
    for v in &variants {
        accels.push(accel::build(
            settings.backend,
            v.scene.soup(),
            settings.options,
        )?);
    }
    let [w, h] = settings.resolution;
    let samples = w as f64 * h as f64 * settings.spp as f64;
    let mut times: Vec<Vec<(f64, f64)>> = vec![Vec::new(); variants.len()];
    for rep in 0..settings.reps.max(1) {
        for (k, v) in variants.iter().enumerate() {
            let kernel = if v.general {
                Kernel::GENERAL
            } else {
                Plan::new(&v.scene, &integrator).kernel
            };
            let tracer = PathTracer::with_kernel(&v.scene, accels[k].as_ref(), integrator, kernel);
            let rs = RenderSettings {
                total_spp: None,
                resolution: settings.resolution,
                spp: settings.spp,
                first_sample: 0,
                seed: 0,
                threads: settings.threads,
                tile_size: 16,
                sampler: SamplerKind::Independent,
                clamp: None,
            };
            let out = render(&tracer, &v.scene.make_camera(w, h), &rs, &|| {})?;
            times[k].push((
                out.seconds * 1e9 / samples,
                out.rays.total() as f64 / out.seconds / 1e6,
            ));
        }
        progress(&format!(
            "repetition {} of {} done",
            rep + 1,
            settings.reps.max(1)
        ));
    }
    let mut rows = Vec::new();
    for (k, v) in variants.iter().enumerate() {
        let ns = median(times[k].iter().map(|t| t.0).collect());
        let mrays = median(times[k].iter().map(|t| t.1).collect());
        let plan = Plan::new(&v.scene, &integrator);
        let kernel = if v.general {
            Kernel::GENERAL
        } else {
            plan.kernel
        };
        rows.push(EffectCostRow {
            variant: v.name.to_string(),
            kernel: kernel.describe(),
            effects: plan.on().iter().map(|s| s.to_string()).collect(),
            ns_per_sample: ns,
            mrays_per_second: mrays,
            relative: 0.0,
        });
    }
    let first = rows[0].ns_per_sample;
    for r in &mut rows {
        r.relative = r.ns_per_sample / first;
    }
    Ok(EffectCostReport {
        scene: base.source.display().to_string(),
        backend: settings.backend.name().to_string(),
        resolution: settings.resolution,
        spp: settings.spp,
        reps: settings.reps.max(1),
        rows,
    })
}

impl EffectCostReport {
    /// The table as Markdown.
    pub fn table(&self) -> String {
        let mut s = format!(
            "effect costs: {} ({}), {}x{}, {} spp, median of {} repetitions\n\n",
            self.scene, self.backend, self.resolution[0], self.resolution[1], self.spp, self.reps
        );
        s += "| variant | kernel | ns/sample | Mrays/s | relative |\n|---|---|---:|---:|---:|\n";
        for r in &self.rows {
            let _ = writeln!(
                s,
                "| {} | {} | {:.0} | {:.2} | {:.2} |",
                r.variant, r.kernel, r.ns_per_sample, r.mrays_per_second, r.relative
            );
        }
        s
    }
}
