//! `embertrace convert`: a converted scene renders to the same image bits as
//! the original (bundled scenes, and one with point, spot, directional and
//! environment lights, a lens, textures and an emissive sphere); and bad
//! output paths are refused before anything is written.

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::commands::convert::convert;
use embertrace::integrator::PathTracer;
use embertrace::render::{RenderSettings, render};
use embertrace::sampler::SamplerKind;
use embertrace::scene::Scene;
use embertrace::settings::{IntegratorSettings, RenderDefaults};
use std::path::Path;

fn image(scene: &Scene) -> Vec<f32> {
    let acc = accel::build(Backend::Bvh, scene.soup(), AccelOptions::default()).unwrap();
    let settings = IntegratorSettings {
        max_depth: 8,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(scene, acc.as_ref(), settings);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [24, 24],
        spp: 2,
        first_sample: 0,
        seed: 11,
        threads: 0,
        tile_size: 8,
        sampler: SamplerKind::Independent,
        clamp: None,
    };
    render(&tracer, &scene.make_camera(24, 24), &rs, &|| {})
        .unwrap()
        .film
        .to_rgb_f32()
}

fn round_trip(path: &Path) {
    let scene = Scene::load(path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("converted.toml");
    let written = convert(&scene, &out).unwrap();
    assert_eq!(written.files.last(), Some(&out));
    let again = Scene::load(&out).unwrap();
    assert_eq!(again.world_origin, scene.world_origin);
    assert_eq!(again.triangle_count(), scene.triangle_count());
    let corners = |s: &Scene| {
        (0..s.triangle_count() as u32)
            .map(|t| s.triangle(t))
            .collect::<Vec<_>>()
    };
    assert!(
        corners(&again) == corners(&scene),
        "{}: triangles moved",
        path.display()
    );
    assert_eq!(again.spheres, scene.spheres);
    assert_eq!(again.sphere_uv_frames, scene.sphere_uv_frames);
    // instances stay instances, with the same object-space triangles and
    // the same maps
    // (each triangle's corners: the OBJ shares no vertex)
    let prototypes = |s: &Scene| {
        s.instances
            .prototypes
            .iter()
            .map(|p| (0..p.indices.len() as u32).map(|t| p.triangle(t)).collect())
            .collect::<Vec<Vec<_>>>()
    };
    assert!(
        prototypes(&again) == prototypes(&scene),
        "{}: prototype triangles moved",
        path.display()
    );
    assert!(
        again.instances.placements == scene.instances.placements,
        "{}: placements moved",
        path.display()
    );
    assert_eq!(again.spot_lights, scene.spot_lights);
    assert_eq!(again.camera, scene.camera);
    // a pinhole's focus distance means nothing
    if scene.lens.is_pinhole() {
        assert!(again.lens.is_pinhole());
    } else {
        assert_eq!(again.lens, scene.lens);
    }
    // TOML's `light_samples` is per shading point: a per-light count (the
    // CS184 `-l`) arrives as the total it gave
    let render = RenderDefaults {
        per_light: None,
        ..scene.render
    };
    assert_eq!(again.render, render);
    assert_eq!(again.focal_pixels, scene.focal_pixels);
    let (a, b) = (image(&scene), image(&again));
    let differ = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    assert_eq!(differ, 0, "{}: {differ} values differ", path.display());
    assert!(a.iter().any(|&v| v > 0.0));
}

#[test]
fn bundled_scenes_round_trip_to_the_same_bits() {
    for name in [
        "cornell-box.toml",
        "cornell-spheres.toml",
        "materials.toml",
        "instances.toml",
        "many-lights.toml",
        "cut-outs.toml",
    ] {
        round_trip(
            &Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("scenes")
                .join(name),
        );
    }
}

/// A scene far from the origin is rebased when loaded; converted, it is
/// written in world coordinates and reads back to the same render-space
/// bits.
#[test]
fn a_rebased_scene_round_trips_to_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let obj = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.obj");
    let path = dir.path().join("far.toml");
    std::fs::write(
        &path,
        format!(
            "[camera]\norigin = [10000.0, 10000.001, 10000.0039]\ntarget = [10000.0, 10000.001, 10000.0]\n\
             [[mesh]]\nfile = \"{obj}\"\ntransform = {{ scale = 0.001, translate = [10000, 10000, 10000] }}\n\
             [[sphere]]\ncenter = [10000.0, 10000.0005, 9999.9995]\nradius = 0.0002\n\
             [[light]]\ntype = \"point\"\nposition = [10000.0, 10000.0015, 10000.0]\nintensity = 0.000001\n"
        ),
    )
    .unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_ne!(scene.world_origin, embertrace::math::DVec3::ZERO);
    round_trip(&path);
}

#[test]
fn lights_lens_textures_and_uvs_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbImage::from_fn(8, 4, |x, y| {
        image::Rgb([(x * 30) as u8, (y * 60) as u8, 90])
    });
    img.save(dir.path().join("t.png")).unwrap();
    std::fs::write(
        dir.path().join("q.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         f 1/1 3/3 2/2\nf 1/1 4/4 3/3\n",
    )
    .unwrap();
    let path = dir.path().join("s.toml");
    std::fs::write(
        &path,
        r#"
[camera]
origin = [0.0, 2.0, 3.0]
target = [0.0, 0.0, 0.0]
aperture_radius = 0.05
focus_distance = 3.2
[render]
direct = "light"
rr = 0.8
[[mesh]]
file = "q.obj"
material = { type = "plastic", diffuse = 0.5, alpha = 0.1, texture = "t.png" }
[[sphere]]
center = [0.3, 0.4, 0.0]
radius = 0.3
material = { type = "conductor", alpha = 0.3, distribution = "beckmann", emission = 0.5, two_sided = true }
[[sphere]]
center = [-0.5, 0.3, 0.1]
radius = 0.2
material = { type = "phong", diffuse = [0.5, 0.4, 0.3], specular = 0.25, shininess = 32.5 }
[[sphere]]
center = [0.6, 0.3, -0.4]
radius = 0.2
material = { type = "phong", diffuse = 0.2, specular = [0.7, 0.6, 0.5], roughness = 0.15 }
[[light]]
type = "point"
position = [0.0, 1.5, 0.5]
intensity = [3.0, 2.0, 1.0]
[[light]]
type = "point"
position = [-0.4, 1.2, 0.2]
intensity = 0.5
attenuation = [1.0, 0.5, 0.0]
[[light]]
type = "directional"
direction = [0.0, -1.0, 0.0]
irradiance = 0.7
[[light]]
type = "spot"
position = [0.2, 1.6, 0.4]
target = [0.1, 0.0, -0.2]
intensity = [4.0, 3.0, 2.0]
cutoff_angle = 35.0
beam_width = 12.5
[[light]]
type = "spot"
position = [-0.7, 1.1, 0.3]
direction = [0.3, -1.0, 0.1]
intensity = 2.5
[[light]]
type = "environment"
radiance = 0.1
[[light]]
type = "environment"
file = "t.png"
radiance = 0.5
"#,
    )
    .unwrap();
    round_trip(&path);
}

#[test]
fn the_output_must_be_toml_in_an_existing_folder() {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"))
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let e = convert(&scene, &dir.path().join("out.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains(".toml"), "{e}");
    let e = convert(&scene, &dir.path().join("no/such/out.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("does not exist"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn mitsuba_and_ply_scenes_round_trip_to_the_same_bits() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba");
    for name in [
        "cbox.xml",
        "lights.xml",
        "envmap.xml",
        "spot.xml",
        "maps.xml",
        "meaning.xml",
        "grazing.xml",
        "floor.ply",
    ] {
        round_trip(&data.join(name));
    }
}

#[test]
fn cs184_dae_scenes_round_trip_to_the_same_bits() {
    // the course's camera: a focal length in pixels, so the 24 x 24 test
    // image sees what the course would at that size
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/collada/room.dae");
    let scene = Scene::load(&path).unwrap();
    assert!(scene.focal_pixels.is_some());
    round_trip(&path);
}

#[test]
fn cse_test_scenes_round_trip_to_the_same_bits() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cse");
    round_trip(&data.join("cornell.test"));
    // the raytracer's dialect: point and directional lights with the
    // course's attenuation, ambient as emission, an ellipsoid with smooth
    // normals, and per-vertex normals
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rt.test");
    std::fs::write(
        &path,
        "size 32 24\ncamera 0 1 4  0 0 0  0 1 0  45\nattenuation 1 0.2 0.05\npoint 1 3 2  1 0.9 0.8\n\
         directional 0 1 1  0.2 0.2 0.3\nambient 0.05 0.05 0.05\ndiffuse 0.4 0.4 0.4\n\
         specular 0.3 0.3 0.3\nshininess 40\nvertex -2 0 -2\nvertex 2 0 -2\nvertex 2 0 2\n\
         vertex -2 0 2\ntri 0 2 1\ntri 0 3 2\nvertexnormal 0 1 0  0 1 0.2\nvertexnormal 1 1 0  0.2 1 0\n\
         vertexnormal 0 1 1  0 1 0\ntrinormal 0 2 1\npushTransform\ntranslate 0 0.6 0\n\
         scale 1 0.5 1\nsphere 0 0 0 1\npopTransform\n",
    )
    .unwrap();
    round_trip(&path);
}
