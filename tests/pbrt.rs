//! pbrt-v4 scenes (`scene/pbrt/`): the camera's handedness (an asymmetric
//! scene renders as pbrt renders it, with and without the exporters'
//! `Scale -1 1 1`), the transform statements, the graphics state, named
//! materials, instances, shapes, lights, render options, warnings and
//! errors. The Cornell box against Mitsuba is in `tests/reference_image.rs`.

mod common;

use embertrace::bsdf::Bsdf;
use embertrace::light::Falloff;
use embertrace::math::{DVec3, Vec3};
use embertrace::scene::Scene;
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A quad in the plane z = 0 centred at (x, 0), facing +z, emitting `rgb`.
fn emitter(x: f32, rgb: &str) -> String {
    format!(
        "AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ {rgb} ]\n  Shape \"trianglemesh\" \"point3 P\" [ {a} -0.5 0  {b} -0.5 0  {b} 0.5 0  {a} 0.5 0 ] \"integer indices\" [ 0 1 2 0 2 3 ]\nAttributeEnd\n",
        a = x - 0.5,
        b = x + 0.5
    )
}

/// The mean colour of the left and right halves of a 16 x 8 render.
fn halves(path: &Path) -> (Vec3, Vec3) {
    let rgb = common::render_exr(path.parent().unwrap(), path, "h.exr", 4, [16, 8]);
    let (w, h) = (16u32, 8u32);
    let (mut l, mut r) = (Vec3::ZERO, Vec3::ZERO);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let i = 3 * (y * w as usize + x);
            let c = Vec3::new(rgb[i], rgb[i + 1], rgb[i + 2]);
            if x < w as usize / 2 {
                l += c;
            } else {
                r += c;
            }
        }
    }
    (l, r)
}

/// pbrt's `LookAt` alone puts the image's right along `up x view`: looking
/// down -z with +y up, world +x is on the image's left. The exporters'
/// `Scale -1 1 1` before it makes the view right-handed: +x on the right.
#[test]
fn the_image_is_pbrts_not_its_mirror() {
    let dir = tempfile::tempdir().unwrap();
    let world = format!(
        "WorldBegin\n{}{}",
        emitter(1.0, "1 0 0"),
        emitter(-1.0, "0 1 0")
    );
    let camera = "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 30 ]\n";
    let plain = write(dir.path(), "plain.pbrt", &format!("{camera}{world}"));
    let (l, r) = halves(&plain);
    assert!(l.x > 10.0 * l.y && r.y > 10.0 * r.x, "left {l}, right {r}");
    let exported = write(
        dir.path(),
        "exported.pbrt",
        &format!("Scale -1 1 1\n{camera}{world}"),
    );
    let (l, r) = halves(&exported);
    assert!(r.x > 10.0 * r.y && l.y > 10.0 * l.x, "left {l}, right {r}");
}

fn world_corners(scene: &Scene) -> Vec<DVec3> {
    (0..scene.triangle_count() as u32)
        .flat_map(|t| scene.triangle(t))
        .map(|p| p.as_dvec3() + scene.world_origin)
        .collect()
}

fn has(points: &[DVec3], want: DVec3) -> bool {
    points.iter().any(|p| (*p - want).length() < 1e-5)
}

/// With the exporters' `Scale -1 1 1` the world is not mirrored, so world
/// coordinates read back as written.
const EXPORTED_CAMERA: &str =
    "Scale -1 1 1\nLookAt 0 0 10  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n";

#[test]
fn transforms_and_the_graphics_state_compose_as_pbrt_does() {
    let dir = tempfile::tempdir().unwrap();
    let tri = "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0 ]\n";
    write(dir.path(), "inc.pbrt", &format!("Translate 0 0 -3\n{tri}"));
    let text = format!(
        "{EXPORTED_CAMERA}WorldBegin\n\
         AttributeBegin\n  Translate 10 0 0\n  Rotate 90 0 0 1\n  {tri}AttributeEnd\n\
         AttributeBegin\n  Transform [ 2 0 0 0  0 2 0 0  0 0 2 0  0 5 0 1 ]\n  ConcatTransform [ 1 0 0 0  0 1 0 0  0 0 1 0  1 0 0 1 ]\n  {tri}\
           CoordinateSystem \"here\"\nAttributeEnd\n\
         Scale 3 3 3\nCoordSysTransform \"here\"\nTranslate 0 0 1\n{tri}\
         Identity\nAttributeBegin\n  Include \"inc.pbrt\"\nAttributeEnd\n{tri}"
    );
    let scene = Scene::load(&write(dir.path(), "t.pbrt", &text)).unwrap();
    let c = world_corners(&scene);
    // rotate (1, 0, 0) a quarter turn about z, then move by 10 in x
    assert!(has(&c, DVec3::new(10.0, 1.0, 0.0)), "{c:?}");
    // M = T(0, 5, 0) S(2) T(1, 0, 0): (1, 0, 0) -> (4, 5, 0)
    assert!(has(&c, DVec3::new(4.0, 5.0, 0.0)), "{c:?}");
    // the named frame, then Translate 0 0 1: (1, 0, 0) -> (4, 5, 2)
    assert!(has(&c, DVec3::new(4.0, 5.0, 2.0)), "{c:?}");
    // Include reads in place, inside the attribute block
    assert!(has(&c, DVec3::new(1.0, 0.0, -3.0)), "{c:?}");
    assert!(has(&c, DVec3::new(1.0, 0.0, 0.0)), "{c:?}");
    assert_eq!(scene.triangle_count(), 5);
}

#[test]
fn materials_lights_shapes_and_options_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let mut png = Vec::new();
    {
        use image::ImageEncoder;
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(
                &[255, 0, 0, 0, 0, 255],
                2,
                1,
                image::ExtendedColorType::Rgb8,
            )
            .unwrap();
    }
    std::fs::write(dir.path().join("t.png"), png).unwrap();
    let text = format!(
        "{EXPORTED_CAMERA}Film \"rgb\" \"integer xresolution\" [ 40 ] \"integer yresolution\" [ 80 ]\n\
         Sampler \"independent\" \"integer pixelsamples\" [ 7 ]\nIntegrator \"volpath\" \"integer maxdepth\" [ 9 ]\n\
         WorldBegin\n\
         Texture \"checks\" \"spectrum\" \"imagemap\" \"string filename\" \"t.png\"\n\
         MakeNamedMaterial \"gold\" \"string type\" \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\" \"float roughness\" 0.04\n\
         MakeNamedMaterial \"glass\" \"string type\" \"dielectric\" \"float eta\" 1.33\n\
         MakeNamedMaterial \"frost\" \"string type\" \"dielectric\" \"float roughness\" 0.09\n\
         AttributeBegin\n NamedMaterial \"frost\"\n Shape \"trianglemesh\" \"point3 P\" [ 0 0 6  1 0 6  0 1 6 ]\nAttributeEnd\n\
         MakeNamedMaterial \"pane\" \"string type\" \"thindielectric\" \"float eta\" 1.6\n\
         AttributeBegin\n NamedMaterial \"pane\"\n Shape \"trianglemesh\" \"point3 P\" [ 0 0 5  1 0 5  0 1 5 ]\nAttributeEnd\n\
         MakeNamedMaterial \"coat\" \"string type\" \"coateddiffuse\" \"rgb reflectance\" [ 0.5 0.4 0.3 ] \"float roughness\" 0.01\n\
         MakeNamedMaterial \"tex\" \"string type\" \"diffuse\" \"texture reflectance\" \"checks\"\n\
         AttributeBegin\n NamedMaterial \"gold\"\n Shape \"sphere\" \"float radius\" 2\nAttributeEnd\n\
         AttributeBegin\n NamedMaterial \"glass\"\n Translate 5 0 0\n Scale 3 3 3\n Shape \"sphere\"\nAttributeEnd\n\
         AttributeBegin\n NamedMaterial \"coat\"\n Shape \"bilinearmesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0  1 1 0 ]\nAttributeEnd\n\
         AttributeBegin\n NamedMaterial \"tex\"\n Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0 ] \"point2 uv\" [ 0 0 1 0 0 1 ]\nAttributeEnd\n\
         LightSource \"point\" \"rgb I\" [ 1 2 3 ] \"point3 from\" [ 0 4 0 ] \"float scale\" 2\n\
         LightSource \"spot\" \"rgb I\" [ 5 5 5 ] \"point3 from\" [ 0 4 0 ] \"point3 to\" [ 0 0 0 ] \"float coneangle\" 40 \"float conedelta\" 10\n\
         LightSource \"distant\" \"rgb L\" [ 2 2 2 ] \"point3 from\" [ 0 1 0 ] \"point3 to\" [ 0 0 0 ]\n\
         LightSource \"infinite\" \"rgb L\" [ 0.1 0.2 0.3 ]\n"
    );
    let scene = Scene::load(&write(dir.path(), "m.pbrt", &text)).unwrap();
    assert_eq!(scene.resolution, [40, 80]);
    assert_eq!((scene.render.spp, scene.render.max_depth), (7, 9));
    // fov spans the shorter side (x): the vertical one is wider
    let want = 2.0 * ((20f64.to_radians()).tan() * 2.0).atan().to_degrees();
    assert!(
        (scene.camera.fov_y as f64 - want).abs() < 1e-3,
        "{}",
        scene.camera.fov_y
    );
    let mats: Vec<&str> = scene.materials.iter().map(|m| m.type_name()).collect();
    assert!(
        ["conductor", "glass", "plastic", "thin_glass", "rough_glass"]
            .iter()
            .all(|t| mats.contains(t)),
        "{mats:?}"
    );
    let gold = scene.materials.iter().find(|m| m.name == "gold").unwrap();
    match gold.bsdf {
        Bsdf::Conductor(c) => {
            let au = embertrace::bsdf::named_conductors::NAMED_CONDUCTORS
                .iter()
                .find(|(n, ..)| *n == "Au")
                .unwrap();
            assert_eq!(c.eta, Vec3::from(au.1));
            assert!(
                (c.microfacet.alpha - 0.2).abs() < 1e-6,
                "remapped: sqrt(0.04)"
            );
        }
        other => panic!("{other:?}"),
    }
    let tex = scene.materials.iter().find(|m| m.name == "tex").unwrap();
    assert_eq!(
        tex.texture.as_ref().unwrap().texel(0, 0),
        Vec3::new(1.0, 0.0, 0.0)
    );
    // spheres: centres and radii through the transforms
    assert_eq!(scene.spheres.len(), 2);
    let radii: Vec<f32> = scene.spheres.iter().map(|s| s.radius).collect();
    assert!(radii.contains(&2.0) && radii.contains(&3.0), "{radii:?}");
    assert_eq!(
        scene.triangle_count(),
        5,
        "a bilinear patch is two triangles, the pane and the frost one each"
    );
    assert_eq!(scene.point_lights[0].intensity, Vec3::new(2.0, 4.0, 6.0));
    let s = &scene.spot_lights[0];
    assert_eq!(s.falloff_kind(), Falloff::SmoothStep);
    assert!((s.cutoff_angle() - 40.0).abs() < 1e-4 && (s.beam_width() - 30.0).abs() < 1e-4);
    assert!((s.axis() - -Vec3::Y).length() < 1e-6);
    assert!((scene.directional_lights[0].direction() - -Vec3::Y).length() < 1e-6);
    assert_eq!(scene.environment, Some(Vec3::new(0.1, 0.2, 0.3)));
}

#[test]
fn instances_area_lights_and_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let quad = "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  1 1 0  0 1 0 ] \"integer indices\" [ 0 1 2 0 2 3 ]\n";
    let text = format!(
        "{EXPORTED_CAMERA}WorldBegin\n\
         ObjectBegin \"q\"\n  {quad}ObjectEnd\n\
         AttributeBegin\n  Translate 3 0 0\n  ObjectInstance \"q\"\nAttributeEnd\n\
         AttributeBegin\n  Translate -3 0 0\n  ObjectInstance \"q\"\nAttributeEnd\n\
         AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 4 4 4 ] \"float scale\" 2 \"bool twosided\" true\n  {quad}AttributeEnd\n\
         AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n  ReverseOrientation\n  Translate 0 0 2\n  {quad}AttributeEnd\n"
    );
    let scene = Scene::load(&write(dir.path(), "i.pbrt", &text)).unwrap();
    assert_eq!(scene.instances.triangle_count(), 4);
    let lights: Vec<_> = scene.materials.iter().filter(|m| m.is_light()).collect();
    assert_eq!(lights.len(), 2);
    assert_eq!(lights[0].emission, Vec3::splat(8.0));
    assert!(lights[0].two_sided && !lights[1].two_sided);
    // the counter-clockwise quad faces +z; reversed, -z
    let front = |m: usize| {
        let t = scene
            .tri_material
            .iter()
            .position(|&k| k as usize == m)
            .unwrap();
        scene.normals[t]
    };
    let first = scene.materials.iter().position(|m| m.is_light()).unwrap();
    let second = scene.materials.iter().rposition(|m| m.is_light()).unwrap();
    assert!((front(first) - Vec3::Z).length() < 1e-6, "{}", front(first));
    assert!(
        (front(second) + Vec3::Z).length() < 1e-6,
        "{}",
        front(second)
    );
}

#[test]
fn unread_statements_warn_once_with_their_line_and_bad_ones_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{EXPORTED_CAMERA}PixelFilter \"gaussian\"\nWorldBegin\n\
         Shape \"disk\" \"float radius\" 1\nShape \"disk\"\nMaterial \"hair\"\n\
         Shape \"sphere\" \"float radius\" 1 \"float mystery\" 2\n\
         LightSource \"point\" \"blackbody I\" [ 3000 ]\n"
    );
    let scene = Scene::load(&write(dir.path(), "w.pbrt", &text)).unwrap();
    let said = |what: &str| scene.warnings.iter().filter(|w| w.contains(what)).count();
    assert_eq!(said("disk"), 1, "{:?}", scene.warnings);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("w.pbrt:6") && w.contains("disk"))
    );
    assert_eq!(said("PixelFilter"), 1);
    assert_eq!(said("hair"), 1);
    assert_eq!(said("blackbody"), 1);
    // a parameter nothing reads is named with its statement
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("w.pbrt:9") && w.contains("`mystery` of Shape \"sphere\"")),
        "{:?}",
        scene.warnings
    );
    assert_eq!(said("radius"), 0, "read parameters are not named");
    for (text, needle) in [
        (
            "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"integer indices\" [ 0 1 5 ]\n",
            ":2",
        ),
        ("WorldBegin\n\nNamedMaterial \"nothing\"\n", ":3"),
        ("WorldBegin\nAttributeEnd\n", "without"),
        ("LookAt 0 0 0 0 0 0 0 1 0\n", ":1"),
        (
            "WorldBegin\nShape \"sphere\" \"float radius\" [ 1\n",
            "unclosed",
        ),
        ("Include \"nowhere.pbrt\"\n", "nowhere.pbrt"),
        (
            "WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"metal-Xx-eta\"\n",
            "metal-Xx-eta",
        ),
    ] {
        let path = write(dir.path(), "bad.pbrt", text);
        let e = Scene::load(&path).unwrap_err().to_string();
        assert!(e.contains("bad.pbrt") && e.contains(needle), "{text}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
    // a file that includes itself stops at the nesting limit
    let path = write(dir.path(), "self.pbrt", "Include \"self.pbrt\"\n");
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("nests"), "{e}");
}

/// The Cornell box converts to TOML and renders to the same bits.
#[test]
fn the_pbrt_box_converts_to_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.pbrt");
    let toml = dir.path().join("box.toml");
    let o = common::run(
        dir.path(),
        &["convert", src.to_str().unwrap(), toml.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let render = |scene: &Path, out: &str| common::render_exr(dir.path(), scene, out, 4, [16, 16]);
    assert_eq!(render(&src, "a.exr"), render(&toml, "b.exr"));
}

/// An image infinite light: pbrt-v4's equal-area octahedral map, whose
/// centre is the light frame's +z, turned up by the usual `Rotate -90 1 0 0`;
/// its +x (red here) lands on pbrt's world +x, mirrored or not.
#[test]
fn an_image_infinite_light_is_read_in_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    let n = 16u32;
    let mut rgb = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let centre = (6..10).contains(&x) && (6..10).contains(&y);
            // the light frame's +x: the middle of the square's right edge
            let east = x >= 13 && (6..10).contains(&y);
            rgb.extend_from_slice(&match (centre, east) {
                (true, _) => [255u8; 3],
                (_, true) => [255, 0, 0],
                _ => [0; 3],
            });
        }
    }
    {
        use image::ImageEncoder;
        let f = std::fs::File::create(dir.path().join("sky.png")).unwrap();
        image::codecs::png::PngEncoder::new(f)
            .write_image(&rgb, n, n, image::ExtendedColorType::Rgb8)
            .unwrap();
    }
    for (camera, mirrored) in [
        (EXPORTED_CAMERA, false),
        (
            "LookAt 0 0 10  0 0 0  0 1 0\nCamera \"perspective\"\n",
            true,
        ),
    ] {
        let text = format!(
            "{camera}WorldBegin\nAttributeBegin\n  Rotate -90 1 0 0\n  LightSource \"infinite\" \"string filename\" \"sky.png\" \"float scale\" 2\nAttributeEnd\n"
        );
        let scene = Scene::load(&write(dir.path(), "sky.pbrt", &text)).unwrap();
        let env = scene.environment_map.as_ref().unwrap();
        assert_eq!(
            env.eval(Vec3::Y),
            Vec3::splat(2.0),
            "mirrored world: {mirrored}"
        );
        assert_eq!(env.eval(-Vec3::Y), Vec3::ZERO);
        // pbrt's world +x is ours in the exported scene, -x in the mirrored one
        let east = if mirrored { -Vec3::X } else { Vec3::X };
        assert_eq!(
            env.eval(east),
            Vec3::new(2.0, 0.0, 0.0),
            "mirrored world: {mirrored}"
        );
        assert_eq!(env.eval(-east), Vec3::ZERO);
    }
}
