//! CS184 COLLADA scenes (`.dae`), in small files written here (the course's
//! own are not ours to ship): the up axis, node transforms, polylists and
//! triangles, CGL spheres, materials and lights, the course's camera
//! placement and field of view, warnings and errors. With
//! `EMBERTRACE_CS184_DAE` naming a folder of the course's scenes, every
//! `.dae` in it is loaded and rendered too (an ignored test, run by hand).

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::bsdf::{Bsdf, Distribution};
use embertrace::integrator::PathTracer;
use embertrace::math::{DVec3, Vec3};
use embertrace::render::{RenderSettings, render};
use embertrace::sampler::SamplerKind;
use embertrace::scene::{EmissionRole, Scene};
use embertrace::settings::{IntegratorSettings, LightCount};
use std::path::Path;

/// A scene: `up` axis, `extra` library elements, and visual-scene `nodes`.
fn dae(up: &str, library: &str, nodes: &str) -> String {
    format!(
        r##"<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><up_axis>{up}</up_axis></asset>
  <library_cameras>
    <camera id="cam"><optics><technique_common><perspective>
      <xfov>49.13434</xfov><aspect_ratio>1.333333</aspect_ratio><znear>0.1</znear>
    </perspective></technique_common></optics></camera>
  </library_cameras>
  <library_effects>
    <effect id="grey-fx"><profile_COMMON><technique sid="common"><phong>
      <diffuse><color sid="diffuse">0.6 0.5 0.4 1</color></diffuse>
    </phong></technique></profile_COMMON></effect>
    <effect id="mirror-fx"><extra><technique profile="CGL">
      <mirror><reflectance>0.9 0.9 0.9</reflectance></mirror>
    </technique></extra></effect>
    <effect id="glass-fx"><extra><technique profile="CGL">
      <glass><transmittance>1 1 1</transmittance><reflectance>1 1 1</reflectance>
      <roughness>0</roughness><ior>1.5</ior></glass>
    </technique></extra></effect>
    <effect id="gold-fx"><extra><technique profile="CGL">
      <microfacet><alpha>0.2</alpha><eta>0.2 0.4 1.4</eta><k>3.1 2.3 1.8</k></microfacet>
    </technique></extra></effect>
    <effect id="glow-fx"><extra><technique profile="CGL">
      <emission><radiance>2 3 4</radiance></emission>
    </technique></extra></effect>
  </library_effects>
  <library_materials>
    <material id="grey"><instance_effect url="#grey-fx"/></material>
    <material id="mirror"><instance_effect url="#mirror-fx"/></material>
    <material id="glass"><instance_effect url="#glass-fx"/></material>
    <material id="gold"><instance_effect url="#gold-fx"/></material>
    <material id="glow"><instance_effect url="#glow-fx"/></material>
  </library_materials>
  <library_geometries>
    <geometry id="ball"><extra><technique profile="CGL"><sphere><radius>0.5</radius></sphere></technique></extra></geometry>
    <geometry id="floor" name="floor"><mesh>
      <source id="floor-pos"><float_array id="floor-pos-array" count="12">-1 0 -1 1 0 -1 1 0 1 -1 0 1</float_array>
        <technique_common><accessor source="#floor-pos-array" count="4" stride="3"/></technique_common></source>
      <source id="floor-n"><float_array id="floor-n-array" count="3">0 1 0</float_array></source>
      <vertices id="floor-v"><input semantic="POSITION" source="#floor-pos"/></vertices>
      <polylist count="1">
        <input semantic="VERTEX" source="#floor-v" offset="0"/>
        <input semantic="NORMAL" source="#floor-n" offset="1"/>
        <vcount>4</vcount><p>0 0 3 0 2 0 1 0</p>
      </polylist>
      <triangles count="1">
        <input semantic="VERTEX" source="#floor-v" offset="0"/>
        <p>0 1 2</p>
      </triangles>
    </mesh></geometry>
    {library}
  </library_geometries>
  <library_lights>
    <light id="area"><technique_common><point><color>1 1 1</color>
      <constant_attenuation>1</constant_attenuation><linear_attenuation>0</linear_attenuation>
      <quadratic_attenuation>0</quadratic_attenuation></point></technique_common>
      <extra><technique profile="CGL"><area><color>10 10 10</color></area></technique></extra></light>
    <light id="bulb"><technique_common><point><color>5 4 3</color>
      <constant_attenuation>1</constant_attenuation><linear_attenuation>0</linear_attenuation>
      <quadratic_attenuation>0.5</quadratic_attenuation></point></technique_common></light>
    <light id="sun"><technique_common><directional><color>1 1 1</color></directional></technique_common></light>
    <light id="sky"><technique_common><ambient><color>0.2 0.2 0.2</color></ambient></technique_common></light>
    <light id="spot"><technique_common><spot><color>1 1 1</color></spot></technique_common></light>
  </library_lights>
  <library_visual_scenes><visual_scene id="Scene">
{nodes}
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#Scene"/></scene>
</COLLADA>
"##
    )
}

fn with_material(geometry: &str, material: &str) -> String {
    format!(
        r##"<instance_geometry url="#{geometry}"><bind_material><technique_common>
        <instance_material symbol="m" target="#{material}"/></technique_common></bind_material></instance_geometry>"##
    )
}

fn load(text: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.dae");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).map_err(|e| e.to_string())
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 1e-5 * b.abs().max_element().max(1.0)
}

/// The floor (a polylist quad and a triangle), a mirror ball moved by a
/// translate, a camera and an area light.
fn room(up: &str) -> String {
    let nodes = format!(
        r##"<node id="f"><matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</matrix>{}</node>
<node id="b"><translate>0 0.5 0</translate><scale>2 2 2</scale>{}</node>
<node id="c"><matrix>1 0 0 0 0 1 0 0.5 0 0 1 4 0 0 0 1</matrix><instance_camera url="#cam"/></node>
<node id="l"><matrix>0.6 0 0 0 0 0 1 2 0 -1 0 0 0 0 0 1</matrix><instance_light url="#area"/></node>"##,
        with_material("floor", "grey"),
        with_material("ball", "mirror"),
    );
    dae(up, "", &nodes)
}

#[test]
fn meshes_spheres_and_area_lights_land_where_the_course_puts_them() {
    let s = load(&room("Y_UP")).unwrap();
    // the quad fans into two triangles, plus one from <triangles>; the area
    // light is no geometry
    assert_eq!(s.triangle_count(), 3);
    assert_eq!(s.spheres.len(), 1);
    assert!(close(s.spheres[0].center, Vec3::new(0.0, 0.5, 0.0)));
    assert!((s.spheres[0].radius - 1.0).abs() < 1e-6, "scaled by 2");
    assert!(matches!(s.material(3).bsdf, Bsdf::Mirror(_)));
    assert_eq!(s.material(0).albedo(), Some(Vec3::new(0.6, 0.5, 0.4)));
    // the polylist's normals shade it
    assert!(close(s.tri_shading_normals[0][0], Vec3::Y));
    // the area light, a panel light (no geometry): the node maps -z to -y
    // (facing down), (-1, 0, 0) to x scaled 0.6, (0, 1, 0) to -z; centred
    // at y = 2
    assert!((0..3).all(|t| s.material(t).emission == Vec3::ZERO));
    assert_eq!(s.panel_lights.len(), 1);
    let panel = s.panel_lights[0];
    assert!(close(panel.facing, -Vec3::Y), "{}", panel.facing);
    assert!(
        close(panel.dim_x, Vec3::new(-0.6, 0.0, 0.0)),
        "{}",
        panel.dim_x
    );
    assert!(
        close(panel.dim_y, Vec3::new(0.0, 0.0, -1.0)),
        "{}",
        panel.dim_y
    );
    assert_eq!(panel.radiance, Vec3::splat(10.0));
    let back = |p: Vec3| p.as_dvec3() + s.world_origin;
    assert!((back(panel.center) - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-6);
    for c in panel.corners() {
        let c = back(c);
        assert!(
            (c.y - 2.0).abs() < 1e-6
                && (c.x.abs() - 0.3).abs() < 1e-6
                && (c.z.abs() - 0.5).abs() < 1e-6,
            "{c}"
        );
    }
    // one area light: `-l` is per shading point, as in the course
    assert_eq!(s.render.light_samples, 1);
    assert_eq!(s.render.light_samples_for(Some(16)), 16);
    assert_eq!(s.render.light_samples_for(None), 1);
}

#[test]
fn the_camera_looks_at_the_geometry_from_one_and_a_half_diagonals() {
    let s = load(&room("Y_UP")).unwrap();
    // geometry bounds (the light left out): the floor and the ball
    let (lo, hi) = (Vec3::new(-1.0, -0.5, -1.0), Vec3::new(1.0, 1.5, 1.0));
    let target = 0.5 * (lo + hi);
    // the course's view direction: the node's transformed point (0, 0, -1)
    let dir = Vec3::new(0.0, 0.5, 3.0).normalize();
    assert!(close(s.camera.target, target));
    assert!(close(
        s.camera.origin,
        target + 1.5 * (hi - lo).length() * dir
    ));
    // xfov 49.13 with aspect 4:3 gives vfov 37.85 in an 800 x 600 window;
    // a 360-pixel-high image keeps the focal length
    assert_eq!(s.resolution, [800, 600]);
    let f = s.focal_pixels.unwrap();
    assert!((f - 875.3).abs() < 0.5, "{f}");
    let vfov = |h: f32| 2.0 * (h / (2.0 * f)).atan().to_degrees();
    assert!((s.camera.fov_y - 37.85).abs() < 0.01, "{}", s.camera.fov_y);
    assert!((vfov(360.0) - 23.25).abs() < 0.01);
}

#[test]
fn z_up_files_are_turned_as_the_course_turns_them() {
    let s = load(&room("Z_UP")).unwrap();
    // (x, y, z) -> (-x, z, y): the floor, flat in y in the file, stands in
    // z; the ball's translate (0, 0.5, 0) moves it along +z
    assert!(close(s.spheres[0].center, Vec3::new(0.0, 0.0, 0.5)));
    let t = s.triangle(2);
    assert!(close(t[1], Vec3::new(-1.0, -1.0, 0.0)), "{t:?}");
}

#[test]
fn materials_and_point_directional_and_ambient_lights() {
    let nodes = format!(
        r##"<node id="a"><translate>-2 0 0</translate>{}</node>
<node id="b"><translate>0 0 0</translate>{}</node>
<node id="c"><translate>2 0 0</translate>{}</node>
<node id="p"><translate>0 3 0</translate><instance_light url="#bulb"/></node>
<node id="d"><instance_light url="#sun"/></node>
<node id="e"><instance_light url="#sky"/></node>"##,
        with_material("ball", "glass"),
        with_material("ball", "gold"),
        with_material("ball", "glow"),
    );
    let s = load(&dae("Y_UP", "", &nodes)).unwrap();
    let m = |i: usize| s.materials[s.sphere_material[i] as usize].clone();
    assert!(matches!(m(0).bsdf, Bsdf::Glass(g) if g.ior == 1.5));
    match m(1).bsdf {
        Bsdf::Conductor(c) => {
            assert_eq!(c.microfacet.distribution, Distribution::Beckmann);
            assert_eq!(c.microfacet.alpha, 0.2);
            assert_eq!(c.k, Vec3::new(3.1, 2.3, 1.8));
        }
        b => panic!("{b:?}"),
    }
    assert_eq!(m(2).emission, Vec3::new(2.0, 3.0, 4.0));
    assert!(m(2).two_sided);
    // the course's EmissionBSDF: seen, never sampled as a light
    assert_eq!(m(2).role, EmissionRole::SeenOnly);
    assert!(!m(2).is_light());
    // a point light with no falloff, whatever its attenuation says
    assert_eq!(s.point_lights.len(), 1);
    assert_eq!(s.point_lights[0].attenuation, [1.0, 0.0, 0.0]);
    assert!(close(s.point_lights[0].position, Vec3::new(0.0, 3.0, 0.0)));
    assert_eq!(s.point_lights[0].intensity, Vec3::new(5.0, 4.0, 3.0));
    // the sun shines along the node's -z
    assert!(close(s.directional_lights[0].direction(), -Vec3::Z));
    // ambient: the upper hemisphere only
    let env = s.environment_map.as_ref().unwrap();
    assert!(close(env.eval(Vec3::Y), Vec3::splat(0.2)));
    assert_eq!(env.eval(-Vec3::Y), Vec3::ZERO);
    assert!(s.notes.iter().any(|n| n.contains("camera")) || s.camera.fov_y > 0.0);
    // `-l 16`, as the course counts it: 16 from the ambient light, one from
    // each delta light
    let count = LightCount {
        sampled: 1,
        delta: 2,
    };
    assert_eq!(s.render.per_light, Some(count));
    assert_eq!(s.render.light_samples_for(Some(16)), 18);
    assert_eq!(s.render.light_samples, 3, "the course's default -l 1");
}

#[test]
fn unsupported_elements_are_warnings_with_their_line() {
    let nodes = r##"<node id="s"><instance_light url="#spot"/></node>"##;
    let text = dae("Y_UP", "", nodes);
    let s = load(&text).unwrap();
    let line = text.lines().position(|l| l.contains("<spot>")).unwrap() + 1;
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains(&format!("s.dae:{line}:")) && w.contains("spot")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn malformed_files_are_one_line_errors_naming_file_and_line() {
    let good = room("Y_UP");
    let cases = [
        (good.replace("<up_axis>Y_UP</up_axis>", ""), "up_axis"),
        (good.replace("<up_axis>Y_UP", "<up_axis>W_UP"), "W_UP"),
        (good.replace("<p>0 1 2</p>", "<p>0 1 7</p>"), "out of range"),
        (
            good.replace("count=\"12\">-1 0 -1", "count=\"13\">-1 0 -1"),
            "claims 13",
        ),
        (
            good.replace("target=\"#grey\"", "target=\"#nothing\""),
            "nothing",
        ),
        (
            good.replace("<vcount>4</vcount>", "<vcount>2</vcount>"),
            "corners",
        ),
        (
            good.replace("0.6 0 0 0 0 0 1 2", "0 0 0 0 0 0 0 2"),
            "flattens",
        ),
        (good.replace("<radius>0.5", "<radius>nan"), "nan"),
        (good.replace("</COLLADA>", ""), "XML"),
    ];
    for (text, what) in cases {
        let e = load(&text).unwrap_err();
        assert!(!e.contains('\n'), "{e}");
        assert!(e.contains("s.dae:") && e.contains(what), "{what}: {e}");
    }
}

/// The course's own scenes, in the folder `EMBERTRACE_CS184_DAE` names
/// (github.com/cal-cs184/p3_1-pathtracer-current, `dae/sky/`; they are not
/// ours to ship): each loads without error and renders a small image with
/// finite values. Run it with
/// `EMBERTRACE_CS184_DAE=DIR cargo test --test collada -- --ignored`.
#[test]
#[ignore = "needs the course's own .dae files, which the project does not ship: set EMBERTRACE_CS184_DAE to a folder of them"]
fn course_scenes_render() {
    let dir = std::env::var("EMBERTRACE_CS184_DAE")
        .expect("EMBERTRACE_CS184_DAE must name a folder of the course's .dae scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "dae"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no .dae files in {dir}");
    for path in files {
        let s = Scene::load(Path::new(&path)).unwrap_or_else(|e| panic!("{e}"));
        let acc = accel::build(Backend::Bvh, s.soup(), AccelOptions::default()).unwrap();
        let tracer = PathTracer::new(
            &s,
            acc.as_ref(),
            IntegratorSettings {
                max_depth: 3,
                ..IntegratorSettings::default()
            },
        );
        let rs = RenderSettings {
            total_spp: None,
            resolution: [24, 18],
            spp: 2,
            first_sample: 0,
            seed: 1,
            threads: 0,
            tile_size: 8,
            sampler: SamplerKind::Independent,
            clamp: None,
        };
        let img = render(&tracer, &s.make_camera(24, 18), &rs, &|| {})
            .unwrap()
            .film
            .to_rgb_f32();
        assert!(img.iter().all(|v| v.is_finite()), "{}", path.display());
        let lit = s.render.per_light.is_some_and(|c| c.sampled + c.delta > 0);
        let mean = img.iter().sum::<f32>() / img.len() as f32;
        assert_eq!(mean > 0.0, lit, "{}: mean {mean}", path.display());
        println!(
            "{}: {} triangles, {} spheres, {:?}",
            path.display(),
            s.triangle_count(),
            s.spheres.len(),
            s.warnings
        );
    }
}

#[test]
fn the_project_room_loads_with_its_materials_and_lights() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/collada/room.dae");
    let s = Scene::load(&path).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // shell (two quads), red wall (two triangles); the area light is a
    // panel light, no geometry
    assert_eq!(s.triangle_count(), 6);
    assert_eq!(s.panel_lights.len(), 1);
    assert_eq!(s.spheres.len(), 2);
    let albedos: Vec<_> = (0..6).filter_map(|t| s.material(t).albedo()).collect();
    assert!(
        albedos.contains(&Vec3::new(0.6, 0.1, 0.1)),
        "the CGL diffuse"
    );
    assert!(albedos.contains(&Vec3::splat(0.7)), "the lambert colour");
    let count = LightCount {
        sampled: 1,
        delta: 1,
    };
    assert_eq!(s.render.per_light, Some(count));
    // the course's 800 x 600 window fixes a focal length in pixels from
    // xfov 49.13434 and aspect 1.333333: f = 400 / tan(xfov / 2)
    let f = s.focal_pixels.unwrap();
    let want = 400.0 / (49.13434f32 / 2.0).to_radians().tan();
    assert!((f - want).abs() < 1e-3 * want, "{f} vs {want}");
    let fov_600 = 2.0 * (300.0 / f).atan().to_degrees();
    assert!((s.camera.fov_y - fov_600).abs() < 1e-4);
}

#[test]
fn a_toml_focal_length_must_be_positive() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    let scene = |f: &str| {
        format!(
            "[camera]\norigin = [0, 0, 4]\ntarget = [0, 0, 0]\nfocal_pixels = {f}\n\n\
             [film]\nresolution = [64, 48]\n"
        )
    };
    std::fs::write(&path, scene("60.0")).unwrap();
    let s = Scene::load(&path).unwrap();
    assert_eq!(s.focal_pixels, Some(60.0));
    assert!((s.camera.fov_y - 2.0 * (24.0f32 / 60.0).atan().to_degrees()).abs() < 1e-4);
    for bad in ["0.0", "-3.0", "nan"] {
        std::fs::write(&path, scene(bad)).unwrap();
        let e = Scene::load(&path).unwrap_err().to_string();
        assert!(e.contains("s.toml") && e.contains("focal_pixels"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

#[test]
fn extreme_camera_transforms_give_a_finite_camera_or_a_one_line_error() {
    // The course places the camera from the geometry's bounds (vertices
    // past the coordinate limit left out) along the node's transformed
    // point (0, 0, -1), normalised: no transform can make it non-finite.
    // The first loads; the others leave no direction (1e300 - 1e300, or
    // 1e-30 - 1e-30) and fail on the camera's line.
    let mut loaded = 0;
    for m in [
        "1e30 0 0 0 0 1e30 0 1e30 0 0 1e30 -1e30 0 0 0 1",
        "1e300 1e300 1e300 1e300 1e300 1e300 1e300 1e300 1e300 1e300 1e300 1e300 0 0 0 1",
        "1e-30 0 0 0 0 1e-30 0 0 0 0 1e-30 1e-30 0 0 0 1",
        "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1",
    ] {
        let nodes = format!(
            r##"<node id="f"><scale>1e30 1 1e-30</scale>{}</node>
<node id="c"><matrix>{m}</matrix><instance_camera url="#cam"/></node>"##,
            with_material("floor", "grey"),
        );
        match load(&dae("Y_UP", "", &nodes)) {
            Ok(s) => {
                let c = s.camera;
                assert!(
                    c.origin.is_finite() && c.target.is_finite() && c.origin != c.target,
                    "{m}: {c:?}"
                );
                assert!(c.fov_y > 0.0 && c.fov_y < 180.0, "{m}: {c:?}");
                loaded += 1;
            }
            Err(e) => assert!(
                !e.contains('\n') && e.contains("s.dae:5:") && e.contains("view direction"),
                "{m}: {e}"
            ),
        }
    }
    assert_eq!(loaded, 1);
}
