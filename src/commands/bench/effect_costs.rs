//! `embertrace bench SCENE --effects`: what each effect costs per sample.
//!
//! The scene (the diffuse Cornell box, say) is rendered under its specialised
//! kernel and under `--plan general`, then with one effect added at a time: a
//! diffuse sphere (the cost of analytic spheres alone), a mirror sphere, a
//! glass sphere, a rough conductor sphere, a textured sphere, an environment
//! map, a thin lens; then the production-scene effects: a few small boxes
//! placed as instances (beside the same boxes as plain triangles), enough
//! small emissive triangles that `--light-sampler auto` picks the light BVH
//! (beside the same lights under `--light-sampler power`), a spot light, a
//! screen cut out by an alpha mask of opacity 0.5 (beside the same screen
//! opaque), and a diffuse sphere with a normal map or a bump map (beside the
//! plain diffuse sphere). Every variant renders in the same process, one after the
//! other in each repetition (so drifts in machine speed hit all rows alike),
//! and each row reports the median over the repetitions of nanoseconds per
//! sample (render seconds over pixels times spp), Mrays/s, and the ratio to
//! the first row, with the effects its plan turns on beyond the first row's.

use super::throughput::median;
use crate::accel::{self, AccelOptions, Backend, Placement, Prototype};
use crate::bsdf::{Bsdf, Conductor, Diffuse, Distribution, Glass, Microfacet, Mirror};
use crate::camera::ThinLens;
use crate::error::Result;
use crate::integrator::PathTracer;
use crate::light::{EnvironmentMap, SpotLight};
use crate::math::{DVec3, Vec2, Vec3, needle_factor, triangle_normal};
use crate::plan::{Kernel, Plan};
use crate::render::{RenderSettings, render};
use crate::sampler::SamplerKind;
use crate::scene::{
    AlphaMask, BumpMap, Maps, Material, MeshRange, NO_OVERRIDE, PrototypeShading, Scene,
    SceneInstances,
};
use crate::settings::{IntegratorSettings, LIGHT_BVH_FROM, LightSampler};
use crate::shape::Sphere;
use crate::texture::ImageTexture;
use glam::{DAffine3, DQuat};
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

/// A variant of the base scene: its name, the scene, whether to force the
/// general kernel, and the light sampler it forces (otherwise the one the
/// command line chose).
struct Variant {
    name: String,
    scene: Scene,
    general: bool,
    light_sampler: Option<LightSampler>,
}

impl Variant {
    /// The integrator settings this variant renders with.
    fn integrator(&self, integrator: IntegratorSettings) -> IntegratorSettings {
        IntegratorSettings {
            light_sampler: self.light_sampler.unwrap_or(integrator.light_sampler),
            ..integrator
        }
    }
}

/// The scene's size (its bounds' shortest side) and the centre of its
/// bounds' floor (lowest `y`).
fn size_and_floor(base: &Scene) -> (f32, Vec3) {
    let b = base.bounds();
    let size = (b.max - b.min).min_element().max(1e-3);
    let floor = Vec3::new(
        0.5 * (b.min.x + b.max.x),
        b.min.y,
        0.5 * (b.min.z + b.max.z),
    );
    (size, floor)
}

/// Move every placement's primitive ids up by `by`: instanced triangles are
/// numbered after the placed triangles and spheres, so adding either to a
/// scene with instances must renumber them.
fn shift_instances(s: &mut Scene, by: u32) {
    for p in &mut s.instances.placements {
        p.first_prim += by;
    }
}

/// The base scene with a sphere of `material` on its floor.
fn with_sphere(base: &Scene, material: Material) -> Scene {
    let mut s = base.clone();
    let (size, floor) = size_and_floor(base);
    let r = 0.17 * size;
    let centre = floor + Vec3::new(0.2 * size, r, 0.15 * size);
    s.sphere_material.push(s.materials.len() as u32);
    s.materials.push(material);
    s.spheres.push(Sphere {
        center: centre,
        radius: r,
    });
    shift_instances(&mut s, 1);
    s
}

/// A material named `name` with `bsdf`, `texture` and `maps`.
fn material(name: &str, bsdf: Bsdf, texture: Option<Arc<ImageTexture>>, maps: Maps) -> Material {
    Material {
        name: name.to_string(),
        bsdf,
        texture,
        maps,
        ..Material::default()
    }
}

/// The grey Lambertian of the added spheres and boxes.
fn grey() -> Bsdf {
    Bsdf::Diffuse(Diffuse {
        albedo: Vec3::splat(0.7),
    })
}

/// The base scene with `triangles` (render space, counter-clockwise seen
/// from the front) added as one mesh named `name` of `material`. Per-corner
/// arrays the scene keeps get zeros (no texture coordinates, flat shading,
/// no tangent frame).
fn with_triangles(base: &Scene, name: &str, material: Material, triangles: &[[Vec3; 3]]) -> Scene {
    let mut s = base.clone();
    let m = s.materials.len() as u32;
    s.materials.push(material);
    let start = s.indices.len() as u32;
    for &p in triangles {
        let Some(n) = triangle_normal(p[0], p[1], p[2]) else {
            continue;
        };
        let v = s.positions.len() as u32;
        s.positions.extend(p);
        s.indices.push([v, v + 1, v + 2]);
        s.normals.push(n);
        s.needle.push(needle_factor(p));
        s.tri_material.push(m);
        if !s.tri_uv.is_empty() {
            s.tri_uv.push([Vec2::ZERO; 3]);
        }
        if !s.tri_shading_normals.is_empty() {
            s.tri_shading_normals.push([Vec3::ZERO; 3]);
        }
        if !s.tri_dpduv.is_empty() {
            s.tri_dpduv.push([Vec3::ZERO; 2]);
        }
    }
    let end = s.indices.len() as u32;
    shift_instances(&mut s, end - start);
    s.meshes.push(MeshRange {
        name: name.to_string(),
        start,
        end,
    });
    s
}

/// A unit cube centred on the origin: 8 corners, 12 triangles wound
/// counter-clockwise seen from outside.
fn cube() -> Prototype {
    let positions: Vec<Vec3> = (0..8u32)
        .map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2 & 1) as f32) - 0.5)
        .collect();
    let mut indices = Vec::new();
    for axis in 0..3usize {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in 0..2u32 {
            let corner = |i: u32, j: u32| side << axis | i << a | j << b;
            let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
            let [p0, p1, p2] = [q[0], q[1], q[2]].map(|i| positions[i as usize]);
            let outward = if side == 1 { 1.0 } else { -1.0 };
            let q = if (p1 - p0).cross(p2 - p0)[axis] * outward > 0.0 {
                q
            } else {
                [q[0], q[3], q[2], q[1]]
            };
            indices.push([q[0], q[1], q[2]]);
            indices.push([q[0], q[2], q[3]]);
        }
    }
    Prototype { positions, indices }
}

/// Where the boxes of the instancing rows stand, in render space: four
/// cubes of edge 0.1 of the scene's size on its floor, two by two in its
/// front left quarter (clear of the Cornell box's two boxes), each turned
/// about the vertical.
fn box_placements(base: &Scene) -> Vec<DAffine3> {
    let (size, floor) = size_and_floor(base);
    let edge = 0.1 * size;
    (0..4)
        .map(|k| {
            let at = floor
                + Vec3::new(
                    (-0.4 + 0.2 * (k % 2) as f32) * size,
                    0.5 * edge,
                    (0.15 + 0.2 * (k / 2) as f32) * size,
                );
            DAffine3::from_scale_rotation_translation(
                DVec3::splat(edge as f64),
                DQuat::from_rotation_y(0.4 * k as f64),
                at.as_dvec3(),
            )
        })
        .collect()
}

/// The base scene with [`cube`] placed by each of [`box_placements`] as
/// instances of one prototype.
fn with_instanced_boxes(base: &Scene) -> Scene {
    let mut s = base.clone();
    let proto = cube();
    let m = s.materials.len() as u32;
    s.materials
        .push(material("boxes", grey(), None, Maps::default()));
    let corners: Vec<[Vec3; 3]> = (0..proto.indices.len() as u32)
        .map(|t| proto.triangle(t))
        .collect();
    let inst = &mut s.instances;
    let p = inst.prototypes.len() as u32;
    let mut first = (s.indices.len() + s.spheres.len()) as u64 + inst.triangle_count();
    inst.shading.push(PrototypeShading {
        name: "box".to_string(),
        normals: corners
            .iter()
            .map(|c| triangle_normal(c[0], c[1], c[2]).expect("a cube's faces have area"))
            .collect(),
        needle: corners.iter().map(|&c| needle_factor(c)).collect(),
        tri_material: vec![m; corners.len()],
        ..PrototypeShading::default()
    });
    inst.prototypes.push(proto);
    for m in box_placements(base) {
        let placement = Placement::new(p, m, first as u32).expect("an invertible placement");
        first += corners.len() as u64;
        push_placement(inst, placement, m, s.world_origin);
    }
    s
}

/// Add `placement` (render-space map `m`) to `inst`, with no material
/// override, in a scene whose render space starts at `world_origin`.
fn push_placement(
    inst: &mut SceneInstances,
    placement: Placement,
    m: DAffine3,
    world_origin: DVec3,
) {
    inst.placements.push(placement);
    inst.material.push(NO_OVERRIDE);
    inst.normal_matrix
        .push(m.matrix3.inverse().transpose().as_mat3());
    inst.world
        .push(DAffine3::from_translation(world_origin) * m);
}

/// The base scene with the boxes of [`with_instanced_boxes`] as plain
/// triangles: the same geometry without the two-level queries.
fn with_placed_boxes(base: &Scene) -> Scene {
    let proto = cube();
    let mut triangles = Vec::new();
    for m in box_placements(base) {
        for t in 0..proto.indices.len() as u32 {
            triangles.push(
                proto
                    .triangle(t)
                    .map(|c| m.transform_point3(c.as_dvec3()).as_vec3()),
            );
        }
    }
    with_triangles(
        base,
        "boxes",
        material("boxes", grey(), None, Maps::default()),
        &triangles,
    )
}

/// Small lights in the many-lights rows: enough for `--light-sampler auto`
/// to pick the light BVH whatever the scene had, and many enough that the
/// tree has levels to walk.
const SMALL_LIGHTS: usize = 64;
const _: () = assert!(SMALL_LIGHTS >= LIGHT_BVH_FROM);

/// The base scene with [`SMALL_LIGHTS`] small emissive triangles (a square
/// grid of them, facing down, just under the top of the scene's bounds).
fn with_many_lights(base: &Scene) -> Scene {
    let (size, floor) = size_and_floor(base);
    let top = base.bounds().max.y - 0.01 * size;
    let n = (SMALL_LIGHTS as f32).sqrt().ceil() as usize;
    let d = 0.02 * size;
    let mut triangles = Vec::new();
    for k in 0..SMALL_LIGHTS {
        let (i, j) = ((k % n) as f32, (k / n) as f32);
        let step = 0.8 * size / n as f32;
        let p = Vec3::new(
            floor.x + (i - 0.5 * (n - 1) as f32) * step,
            top,
            floor.z + (j - 0.5 * (n - 1) as f32) * step,
        );
        // (d, 0, 0) x (0, 0, d) points down
        triangles.push([p, p + Vec3::new(d, 0.0, 0.0), p + Vec3::new(0.0, 0.0, d)]);
    }
    let mut light = material("small lights", grey(), None, Maps::default());
    light.emission = Vec3::splat(10.0);
    with_triangles(base, "small lights", light, &triangles)
}

/// The base scene with a spot light under the top of its bounds, pointing
/// down (a 30 degree cone).
fn with_spot_light(base: &Scene) -> Scene {
    let mut s = base.clone();
    let (size, floor) = size_and_floor(base);
    let at = Vec3::new(floor.x, base.bounds().max.y - 0.05 * size, floor.z);
    s.spot_lights.push(
        SpotLight::new(at, Vec3::NEG_Y, Vec3::splat(3.0), 30.0, None).expect("a valid spot light"),
    );
    s
}

/// The base scene with a screen: a vertical quad across the middle of its
/// bounds (facing +z, half the scene's size on a side, its foot on the
/// floor), of opacity `alpha` (`None`: opaque, no mask at all).
fn with_screen(base: &Scene, alpha: Option<f32>) -> Scene {
    let (size, floor) = size_and_floor(base);
    let h = 0.5 * size;
    let c = |x: f32, y: f32| floor + Vec3::new(x * h, y * h, 0.0);
    let (a, b, cc, d) = (c(-0.5, 0.0), c(0.5, 0.0), c(0.5, 1.0), c(-0.5, 1.0));
    let mut m = material("screen", grey(), None, Maps::default());
    m.alpha_mask = alpha.map(AlphaMask::Constant);
    with_triangles(base, "screen", m, &[[a, b, cc], [a, cc, d]])
}

/// A 64 x 64 texture whose texel `(x, y)` (row 0 at the top) is `texel(x, y)`.
fn texture_64(texel: impl Fn(u32, u32) -> [f32; 3]) -> Arc<ImageTexture> {
    let rgb = (0..64u32)
        .flat_map(|y| (0..64u32).map(move |x| (x, y)))
        .flat_map(|(x, y)| texel(x, y))
        .collect();
    Arc::new(ImageTexture::from_linear_rgb(64, 64, rgb).expect("a valid 64 x 64 texture"))
}

/// A 64 x 64 checkerboard texture.
fn checker() -> Arc<ImageTexture> {
    texture_64(|x, y| [if (x / 8 + y / 8) % 2 == 0 { 0.7 } else { 0.2 }; 3])
}

/// Eight by eight bumps over the unit square, at texel `(x, y)` of 64: the
/// texel's coordinates and the bumps' angular frequency.
fn bump_coordinates(x: u32, y: u32) -> (f32, f32, f32) {
    (
        x as f32 / 64.0,
        y as f32 / 64.0,
        std::f32::consts::TAU * 8.0,
    )
}

/// A 64 x 64 normal map (raw, Mitsuba's encoding `(n + 1) / 2`) of eight
/// by eight bumps: normals tilted up to about 17 degrees.
fn bumps_normal_map() -> Arc<ImageTexture> {
    texture_64(|x, y| {
        let (u, v, a) = bump_coordinates(x, y);
        let n = Vec3::new(0.3 * (a * u).cos(), 0.3 * (a * v).cos(), 1.0).normalize();
        (0.5 * (n + Vec3::ONE)).to_array()
    })
}

/// A 64 x 64 height map of eight by eight bumps, heights in [0, 1].
fn bumps_height_map() -> Arc<ImageTexture> {
    texture_64(|x, y| {
        let (u, v, a) = bump_coordinates(x, y);
        [0.5 + 0.25 * ((a * u).sin() + (a * v).sin()); 3]
    })
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
    let v = |name: &str, scene, general| Variant {
        name: name.to_string(),
        scene,
        general,
        light_sampler: None,
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
    let no_maps = Maps::default;
    let lights = with_many_lights(base);
    let n_lights = SMALL_LIGHTS;
    vec![
        v("base scene", base.clone(), false),
        v("base scene, --plan general", base.clone(), true),
        v(
            "+ diffuse sphere",
            with_sphere(base, material("sphere", grey(), None, no_maps())),
            false,
        ),
        v(
            "+ mirror sphere",
            with_sphere(
                base,
                material("mirror", Bsdf::Mirror(Mirror::default()), None, no_maps()),
            ),
            false,
        ),
        v(
            "+ glass sphere",
            with_sphere(
                base,
                material("glass", Bsdf::Glass(Glass::default()), None, no_maps()),
            ),
            false,
        ),
        v(
            "+ rough conductor sphere",
            with_sphere(
                base,
                material("gold", Bsdf::Conductor(gold), None, no_maps()),
            ),
            false,
        ),
        v(
            "+ textured diffuse sphere",
            with_sphere(
                base,
                material(
                    "checker",
                    Bsdf::Diffuse(Diffuse { albedo: Vec3::ONE }),
                    Some(checker()),
                    no_maps(),
                ),
            ),
            false,
        ),
        v("+ environment map", env, false),
        v("+ thin lens", lens, false),
        v(
            "+ 4 boxes as plain triangles",
            with_placed_boxes(base),
            false,
        ),
        v(
            "+ the 4 boxes as instances",
            with_instanced_boxes(base),
            false,
        ),
        Variant {
            light_sampler: Some(LightSampler::Power),
            ..v(
                &format!("+ {n_lights} small lights, --light-sampler power"),
                lights.clone(),
                false,
            )
        },
        v(&format!("+ {n_lights} small lights"), lights, false),
        v("+ spot light", with_spot_light(base), false),
        v("+ an opaque screen", with_screen(base, None), false),
        v(
            "+ the screen cut out (alpha 0.5)",
            with_screen(base, Some(0.5)),
            false,
        ),
        v(
            "+ normal-mapped diffuse sphere",
            with_sphere(
                base,
                material(
                    "normal-mapped",
                    grey(),
                    None,
                    Maps {
                        normal: Some(bumps_normal_map()),
                        ..no_maps()
                    },
                ),
            ),
            false,
        ),
        v(
            "+ bump-mapped diffuse sphere",
            with_sphere(
                base,
                material(
                    "bump-mapped",
                    grey(),
                    None,
                    Maps {
                        bump: Some(BumpMap {
                            texture: bumps_height_map(),
                            scale: 0.02,
                        }),
                        ..no_maps()
                    },
                ),
            ),
            false,
        ),
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
            let integrator = v.integrator(integrator);
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
        let plan = Plan::new(&v.scene, &v.integrator(integrator));
        let kernel = if v.general {
            Kernel::GENERAL
        } else {
            plan.kernel
        };
        rows.push(EffectCostRow {
            variant: v.name.clone(),
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
        s += "| variant | kernel | effects on | ns/sample | Mrays/s | relative |\n|---|---|---|---:|---:|---:|\n";
        for r in &self.rows {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.0} | {:.2} | {:.2} |",
                r.variant,
                r.kernel,
                self.effects_column(r),
                r.ns_per_sample,
                r.mrays_per_second,
                r.relative
            );
        }
        s
    }

    /// The effects `row` turns on: the first row's all, every other row's
    /// as the difference from the first (`+name` on, `-name` off), or `as
    /// the base` when there is none.
    fn effects_column(&self, row: &EffectCostRow) -> String {
        let first = &self.rows[0];
        if std::ptr::eq(row, first) {
            return first.effects.join(", ");
        }
        let mut diff: Vec<String> = row
            .effects
            .iter()
            .filter(|e| !first.effects.contains(e))
            .map(|e| format!("+{e}"))
            .collect();
        diff.extend(
            first
                .effects
                .iter()
                .filter(|e| !row.effects.contains(e))
                .map(|e| format!("-{e}")),
        );
        if diff.is_empty() {
            "as the base".to_string()
        } else {
            diff.join(", ")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::{Flags, resolve};
    use std::path::Path;

    fn cornell() -> (Scene, IntegratorSettings) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let scene = Scene::load(&path).expect("the bundled Cornell box loads");
        let integrator = resolve(&scene.render, scene.resolution, &Flags::default())
            .expect("its settings resolve")
            .integrator;
        (scene, integrator)
    }

    /// The effects a variant's plan turns on.
    fn effects(v: &Variant, integrator: IntegratorSettings) -> Vec<&'static str> {
        Plan::new(&v.scene, &v.integrator(integrator)).on()
    }

    #[test]
    fn each_row_turns_on_the_effects_it_adds() {
        let (base, integrator) = cornell();
        let variants = variants(&base);
        let first = effects(&variants[0], integrator);
        assert_eq!(first, ["diffuse", "area_light", "indirect"]);
        let expected: &[(&str, &[&str])] = &[
            ("base scene", &[]),
            ("base scene, --plan general", &[]),
            ("+ diffuse sphere", &["sphere"]),
            ("+ mirror sphere", &["mirror", "sphere"]),
            ("+ glass sphere", &["glass", "sphere"]),
            ("+ rough conductor sphere", &["conductor", "sphere"]),
            ("+ textured diffuse sphere", &["texture", "sphere"]),
            ("+ environment map", &["environment_map"]),
            ("+ thin lens", &["thin_lens"]),
            ("+ 4 boxes as plain triangles", &[]),
            ("+ the 4 boxes as instances", &["instancing"]),
            ("+ 64 small lights, --light-sampler power", &[]),
            ("+ 64 small lights", &["many_lights"]),
            ("+ spot light", &["spot_light"]),
            ("+ an opaque screen", &[]),
            ("+ the screen cut out (alpha 0.5)", &["alpha_mask"]),
            ("+ normal-mapped diffuse sphere", &["sphere", "normal_map"]),
            ("+ bump-mapped diffuse sphere", &["sphere", "bump_map"]),
        ];
        let names: Vec<&str> = variants.iter().map(|v| v.name.as_str()).collect();
        let want: Vec<&str> = expected.iter().map(|(n, _)| *n).collect();
        assert_eq!(names, want);
        for (v, (_, added)) in variants.iter().zip(expected) {
            let on = effects(v, integrator);
            assert!(
                first.iter().all(|e| on.contains(e)),
                "{}: {on:?} lacks some of {first:?}",
                v.name
            );
            let new: Vec<&str> = on.into_iter().filter(|e| !first.contains(e)).collect();
            assert_eq!(new, *added, "{}", v.name);
        }
        // the many-lights rows differ by the sampler alone, the maps rows
        // from the diffuse sphere's by the map alone
        let count = |v: &Variant| crate::plan::finite_light_count(&v.scene);
        assert_eq!(count(&variants[11]), count(&variants[12]));
        assert!(count(&variants[12]) >= LIGHT_BVH_FROM);
        assert!(count(&variants[0]) < LIGHT_BVH_FROM);
        let kernel = |v: &Variant| Plan::new(&v.scene, &v.integrator(integrator)).kernel;
        assert_eq!(kernel(&variants[16]), kernel(&variants[2]));
        assert_eq!(kernel(&variants[17]), kernel(&variants[2]));
        // the cut-out screen runs the opaque one's kernel: the mask is tested
        // in the traversal
        assert_eq!(kernel(&variants[14]), kernel(&variants[15]));
        // --light-sampler power on the command line leaves the light BVH off
        let power = IntegratorSettings {
            light_sampler: LightSampler::Power,
            ..integrator
        };
        assert!(!effects(&variants[12], power).contains(&"many_lights"));
    }

    /// Camera rays through a 24 x 24 grid: the material name each hits.
    fn seen(scene: &Scene, backend: Backend) -> Vec<Option<(String, f32)>> {
        let accel = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
        let camera = scene.make_camera(24, 24);
        let mut out = Vec::new();
        for y in 0..24 {
            for x in 0..24 {
                let ray = camera.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                out.push(
                    accel
                        .intersect(&ray)
                        .map(|h| (scene.material(h.prim).name.clone(), h.t)),
                );
            }
        }
        out
    }

    #[test]
    fn instanced_boxes_are_the_placed_boxes() {
        let (base, _) = cornell();
        let placed = with_placed_boxes(&base);
        let instanced = with_instanced_boxes(&base);
        assert_eq!(instanced.instances.placements.len(), 4);
        assert_eq!(placed.triangle_count(), base.triangle_count() + 48);
        // a sphere added after the instances renumbers them
        let both = with_sphere(
            &instanced,
            material("sphere", grey(), None, Maps::default()),
        );
        for (k, p) in both.instances.placements.iter().enumerate() {
            for t in 0..12 {
                let prim = p.first_prim + t;
                assert_eq!(both.instanced(prim), Some((k, t)));
                assert!(both.sphere(prim).is_none());
                assert_eq!(both.material(prim).name, "boxes");
            }
        }
        assert_eq!(both.primitive_count(), base.triangle_count() + 1 + 48);
        for backend in Backend::available() {
            let a = seen(&placed, backend);
            let b = seen(&instanced, backend);
            let c = seen(&both, backend);
            let boxes = a
                .iter()
                .filter(|h| h.as_ref().is_some_and(|h| h.0 == "boxes"))
                .count();
            assert!(boxes > 10, "{backend:?}: {boxes} rays see the boxes");
            for (k, (a, b)) in a.iter().zip(&b).enumerate() {
                // (a ray along the edge of two walls may take either, so
                // only the boxes' names must agree)
                let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
                if a.0 == "boxes" || b.0 == "boxes" {
                    assert_eq!(a.0, b.0, "{backend:?} ray {k}");
                }
                assert!((a.1 - b.1).abs() <= 1e-4 * a.1, "{backend:?} ray {k}");
            }
            for (b, c) in b.iter().zip(&c) {
                let (b, c) = (b.as_ref().unwrap(), c.as_ref().unwrap());
                if c.0 != "sphere" && (b.0 == "boxes" || c.0 == "boxes") {
                    assert_eq!(b, c, "{backend:?}");
                }
            }
        }
    }
}
