//! glTF 2.0 scenes (`scene/gltf/`): each test writes a small file with the
//! feature it checks (the node tree, instances, cameras, materials and
//! their extensions, punctual lights, cut-outs, bad input) and reads what
//! the loader made of it. The Cornell box as .gltf and .glb against
//! Mitsuba is in `tests/reference_image.rs`.

mod common;

use base64::Engine;
use embertrace::bsdf::Bsdf;
use embertrace::light::Falloff;
use embertrace::math::{DVec3, Vec2, Vec3};
use embertrace::scene::{AlphaMask, LoadOptions, Scene};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// A glTF document under construction, its binary data in one buffer.
struct Asset {
    json: Value,
    bin: Vec<u8>,
}

impl Asset {
    fn new() -> Self {
        Asset {
            json: json!({
                "asset": {"version": "2.0"},
                "scene": 0,
                "scenes": [{"nodes": []}],
                "nodes": [], "meshes": [], "materials": [], "accessors": [],
                "bufferViews": [], "buffers": [], "images": [], "textures": [],
                "cameras": [],
            }),
            bin: Vec::new(),
        }
    }

    fn push(&mut self, key: &str, v: Value) -> usize {
        let a = self.json[key].as_array_mut().unwrap();
        a.push(v);
        a.len() - 1
    }

    fn view(&mut self, bytes: &[u8]) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.push(
            "bufferViews",
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}),
        )
    }

    fn floats(&mut self, v: &[f32], ty: &str) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let per = match ty {
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 1,
        };
        let mut acc =
            json!({"bufferView": view, "componentType": 5126, "count": v.len() / per, "type": ty});
        if ty == "VEC3" {
            let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
            for p in v.chunks(3) {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.push("accessors", acc)
    }

    fn indices(&mut self, v: &[u32]) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": 5125, "count": v.len(), "type": "SCALAR"}),
        )
    }

    /// A unit quad in the xz plane facing +y, with normals and texture
    /// coordinates (glTF's: `v` down), drawn with `material`.
    fn quad_mesh(&mut self, material: Option<usize>) -> usize {
        let p = self.floats(
            &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, -1.0],
            "VEC3",
        );
        let n = self.floats(&[0.0, 1.0, 0.0].repeat(4), "VEC3");
        let t = self.floats(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0], "VEC2");
        let i = self.indices(&[0, 1, 2, 0, 2, 3]);
        let mut prim =
            json!({"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": t}, "indices": i});
        if let Some(m) = material {
            prim["material"] = json!(m);
        }
        self.push("meshes", json!({"primitives": [prim]}))
    }

    /// A node, added to the scene's roots when `root`.
    fn node(&mut self, v: Value, root: bool) -> usize {
        let n = self.push("nodes", v);
        if root {
            self.json["scenes"][0]["nodes"]
                .as_array_mut()
                .unwrap()
                .push(json!(n));
        }
        n
    }

    /// An 8-bit RGBA PNG image as a data: URI texture.
    fn texture(&mut self, w: u32, h: u32, rgba: &[u8]) -> usize {
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(rgba, w, h, image::ExtendedColorType::Rgba8)
            .unwrap();
        let uri = format!(
            "data:image/png;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&png)
        );
        let img = self.push("images", json!({ "uri": uri }));
        self.push("textures", json!({ "source": img }))
    }

    fn write(mut self, dir: &Path, name: &str) -> PathBuf {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.bin)
        );
        self.json["buffers"] = json!([{"byteLength": self.bin.len(), "uri": uri}]);
        let path = dir.join(name);
        std::fs::write(&path, serde_json::to_string_pretty(&self.json).unwrap()).unwrap();
        path
    }
}

use image::ImageEncoder;

/// The world positions of the scene's placed triangles' corners.
fn world_corners(scene: &Scene) -> Vec<DVec3> {
    (0..scene.triangle_count() as u32)
        .flat_map(|t| scene.triangle(t))
        .map(|p| p.as_dvec3() + scene.world_origin)
        .collect()
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn node_transforms_compose_down_the_tree() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Asset::new();
    let mesh = a.quad_mesh(None);
    // grandchild: a matrix translating by (0, 0, 5), column-major
    let grandchild = a.node(
        json!({"mesh": mesh, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,5,1]}),
        false,
    );
    // child: a quarter turn about +y (x -> -z) and scale 2
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let child = a.node(
        json!({"rotation": [0.0, s, 0.0, s], "scale": [2.0, 2.0, 2.0], "children": [grandchild]}),
        false,
    );
    a.node(
        json!({"translation": [1.0, 2.0, 3.0], "children": [child]}),
        true,
    );
    let scene = Scene::load(&a.write(dir.path(), "t.gltf")).unwrap();
    let corners = world_corners(&scene);
    // corner (1, 0, 0): +5 z, then turned to (5, 0, -1), doubled, moved
    let want = DVec3::new(1.0, 2.0, 3.0) + 2.0 * DVec3::new(5.0, 0.0, -1.0);
    assert!(
        corners.iter().any(|&c| close(c, want)),
        "{corners:?} lacks {want}"
    );
    let origin = DVec3::new(1.0, 2.0, 3.0) + 2.0 * DVec3::new(5.0, 0.0, 0.0);
    assert!(corners.iter().any(|&c| close(c, origin)), "{corners:?}");
    // smooth normals turned with the mesh (+y stays +y)
    assert!(!scene.tri_shading_normals.is_empty());
    assert!((scene.tri_shading_normals[0][0] - Vec3::Y).length() < 1e-5);
}

#[test]
fn a_mesh_placed_by_two_nodes_becomes_instances() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Asset::new();
    let mesh = a.quad_mesh(None);
    a.node(json!({"mesh": mesh}), true);
    a.node(json!({"mesh": mesh, "translation": [3.0, 0.0, 0.0]}), true);
    let other = a.quad_mesh(None);
    a.node(json!({"mesh": other, "translation": [0.0, 0.0, 4.0]}), true);
    let scene = Scene::load(&a.write(dir.path(), "i.gltf")).unwrap();
    assert_eq!(scene.triangle_count(), 2, "the mesh placed once is placed");
    assert_eq!(scene.instances.triangle_count(), 4, "two instances of two");
}

#[test]
fn the_first_perspective_camera_is_used_unless_one_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Asset::new();
    let mesh = a.quad_mesh(None);
    a.node(json!({"mesh": mesh}), true);
    let ortho = a.push(
        "cameras",
        json!({"name": "flat", "type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10}}),
    );
    let first = a.push(
        "cameras",
        json!({"name": "first", "type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 1.5, "znear": 0.1}}),
    );
    let second = a.push(
        "cameras",
        json!({"name": "second", "type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}),
    );
    a.node(json!({"camera": ortho, "translation": [0, 5, 0]}), true);
    a.node(
        json!({"camera": first, "translation": [0.5, 1.0, 4.0]}),
        true,
    );
    // looking down: a quarter turn about +x takes -z to -y
    let s = std::f64::consts::FRAC_1_SQRT_2;
    a.node(
        json!({"camera": second, "translation": [0.5, 6.0, -0.5], "rotation": [-s, 0.0, 0.0, s]}),
        true,
    );
    let path = a.write(dir.path(), "c.gltf");
    let scene = Scene::load(&path).unwrap();
    let origin = scene.camera.origin.as_dvec3() + scene.world_origin;
    assert!(close(origin, DVec3::new(0.5, 1.0, 4.0)), "{origin}");
    let view = (scene.camera.target - scene.camera.origin).normalize();
    assert!((view - -Vec3::Z).length() < 1e-6, "{view}");
    assert!((scene.camera.fov_y - 0.5f32.to_degrees()).abs() < 1e-4);
    assert_eq!(scene.resolution, [768, 512], "aspectRatio 1.5");
    assert!(
        scene.warnings.iter().any(|w| w.contains("orthographic")),
        "{:?}",
        scene.warnings
    );

    let named = Scene::load_with(
        &path,
        &LoadOptions {
            camera: Some("second".into()),
        },
    )
    .unwrap();
    let view = (named.camera.target - named.camera.origin).normalize();
    assert!((view - -Vec3::Y).length() < 1e-6, "{view}");
    assert!((named.camera.fov_y - 1f32.to_degrees()).abs() < 1e-4);

    let e = Scene::load_with(
        &path,
        &LoadOptions {
            camera: Some("third".into()),
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("no camera named `third`") && e.contains("`second`"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1);
    // other formats have one camera
    let e = Scene::load_with(
        Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenes/cornell-box.toml"
        )),
        &LoadOptions {
            camera: Some("x".into()),
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("--camera"), "{e}");
}

#[test]
fn an_unlit_camera_less_asset_is_framed_and_lit_white() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Asset::new();
    let mesh = a.quad_mesh(None);
    a.node(json!({"mesh": mesh}), true);
    let scene = Scene::load(&a.write(dir.path(), "bare.gltf")).unwrap();
    assert!(
        scene.notes.iter().any(|n| n.contains("framed")),
        "{:?}",
        scene.notes
    );
    assert_eq!(scene.environment, Some(Vec3::ONE));
    // no material: glTF's default, a white rough metal
    match &scene.materials[0].bsdf {
        Bsdf::MetallicRoughness(m) => {
            assert_eq!(
                (m.base_color, m.metallic, m.roughness),
                (Vec3::ONE, 1.0, 1.0)
            );
        }
        other => panic!("{other:?}"),
    }
}

/// sRGB 8-bit to linear, as the texture loader decodes it.
fn srgb(v: u8) -> f32 {
    embertrace::image::srgb_to_linear(v as f64 / 255.0) as f32
}

#[test]
fn materials_read_factors_textures_and_extensions() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Asset::new();
    // 2 x 1 texels: opaque orange, then half-transparent blue
    let colour = a.texture(2, 1, &[255, 128, 0, 255, 0, 64, 255, 100]);
    // green = roughness, blue = metalness
    let mr = a.texture(1, 1, &[0, 128, 255, 255]);
    let emissive = a.texture(1, 1, &[255, 255, 255, 255]);
    let textured = a.push(
        "materials",
        json!({
            "name": "textured",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.5, 1.0, 1.0, 1.0],
                "baseColorTexture": {"index": colour, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [2.0, 1.0]}}},
                "metallicFactor": 0.5, "roughnessFactor": 0.8,
                "metallicRoughnessTexture": {"index": mr}
            },
            "alphaMode": "MASK", "alphaCutoff": 0.3,
            "extensions": {
                "KHR_materials_specular": {"specularFactor": 0.7, "specularColorFactor": [1.0, 0.5, 0.5]},
                "KHR_materials_ior": {"ior": 1.8}
            }
        }),
    );
    let glowing = a.push(
        "materials",
        json!({
            "name": "glowing", "doubleSided": true,
            "emissiveFactor": [1.0, 0.5, 0.25], "emissiveTexture": {"index": emissive},
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}}
        }),
    );
    let glass = a.push(
        "materials",
        json!({
            "name": "glass",
            "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.7, 1.0], "roughnessFactor": 0.0},
            "alphaMode": "BLEND",
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.33}}
        }),
    );
    let frosted = a.push(
        "materials",
        json!({
            "name": "frosted",
            "pbrMetallicRoughness": {"roughnessFactor": 0.5},
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}
        }),
    );
    for (k, m) in [textured, glowing, glass, frosted].into_iter().enumerate() {
        let mesh = a.quad_mesh(Some(m));
        a.node(
            json!({"mesh": mesh, "translation": [2.0 * k as f32, 0.0, 0.0]}),
            true,
        );
    }
    a.json["extensionsUsed"] = json!([
        "KHR_texture_transform",
        "KHR_materials_specular",
        "KHR_materials_ior",
        "KHR_materials_emissive_strength",
        "KHR_materials_transmission"
    ]);
    let scene = Scene::load(&a.write(dir.path(), "m.gltf")).unwrap();
    let by_name = |n: &str| scene.materials.iter().find(|m| m.name == n).unwrap();

    let t = by_name("textured");
    let Bsdf::MetallicRoughness(b) = t.bsdf else {
        panic!("{:?}", t.bsdf)
    };
    assert_eq!(
        (b.metallic, b.roughness, b.specular, b.ior),
        (0.5, 0.8, 0.7, 1.8)
    );
    assert_eq!(b.specular_color, Vec3::new(1.0, 0.5, 0.5));
    let tex = t.texture.as_ref().unwrap();
    let want = Vec3::new(0.5 * srgb(255), srgb(128), srgb(0));
    assert!(
        (tex.texel(0, 0) - want).length() < 1e-6,
        "{}",
        tex.texel(0, 0)
    );
    let mrt = t.maps.metallic_roughness.as_ref().unwrap();
    let want = Vec3::new(0.0, 0.8 * 128.0 / 255.0, 0.5);
    assert!(
        (mrt.texel(0, 0) - want).length() < 1e-6,
        "{}",
        mrt.texel(0, 0)
    );
    // the mask: 100/255 = 0.39 >= 0.3 keeps the blue texel
    match &t.alpha_mask {
        Some(AlphaMask::Texture(m)) => {
            assert_eq!(m.texel(0, 0), Vec3::ONE);
            assert_eq!(m.texel(1, 0), Vec3::ONE);
        }
        other => panic!("{other:?}"),
    }
    // texture coordinates: transformed, then v flipped; corner (1, 0)
    // becomes (2 + 0.5, 0) and then (2.5, 1)
    let tm = scene
        .materials
        .iter()
        .position(|m| m.name == "textured")
        .unwrap() as u32;
    let tri = scene.tri_material.iter().position(|&m| m == tm).unwrap();
    assert_eq!(scene.tri_uv[tri][1], Vec2::new(2.5, 1.0));

    let g = by_name("glowing");
    assert!(g.two_sided);
    let want = Vec3::new(8.0, 4.0, 2.0);
    assert!((g.emission - want).length() < 1e-5, "{}", g.emission);
    assert!(g.maps.emission.is_some());

    let gl = by_name("glass");
    match gl.bsdf {
        Bsdf::Glass(b) => {
            assert_eq!(b.ior, 1.33);
            assert_eq!(b.transmittance, Vec3::new(0.9, 0.8, 0.7));
        }
        other => panic!("{other:?}"),
    }
    match by_name("frosted").bsdf {
        Bsdf::RoughGlass(b) => assert_eq!((b.alpha, b.ior), (0.25, 1.5)),
        other => panic!("{other:?}"),
    }
    assert!(
        scene.warnings.iter().any(|w| w.contains("BLEND")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn punctual_lights_arrive_in_photometric_units() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Asset::new();
    let mesh = a.quad_mesh(None);
    a.node(json!({"mesh": mesh}), true);
    a.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    a.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 683.0},
        {"type": "directional", "intensity": 1366.0},
        {"type": "spot", "intensity": 68.3, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}
    ]}});
    a.node(
        json!({"translation": [0, 3, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}}),
        true,
    );
    let s = std::f64::consts::FRAC_1_SQRT_2;
    // pointing down: -z turned to -y
    a.node(
        json!({"rotation": [-s, 0.0, 0.0, s], "extensions": {"KHR_lights_punctual": {"light": 1}}}),
        true,
    );
    a.node(
        json!({"translation": [0, 2, 0], "rotation": [-s, 0.0, 0.0, s], "extensions": {"KHR_lights_punctual": {"light": 2}}}),
        true,
    );
    let scene = Scene::load(&a.write(dir.path(), "l.gltf")).unwrap();
    assert_eq!(scene.environment, None, "lit by its lights");
    let p = &scene.point_lights[0];
    assert!((p.intensity - Vec3::new(1.0, 0.5, 0.25)).length() < 1e-6);
    assert!(close(
        p.position.as_dvec3() + scene.world_origin,
        DVec3::new(0.0, 3.0, 0.0)
    ));
    let d = &scene.directional_lights[0];
    assert!((d.irradiance() - Vec3::splat(2.0)).length() < 1e-6);
    assert!(
        (d.direction() - -Vec3::Y).length() < 1e-6,
        "{}",
        d.direction()
    );
    let sp = &scene.spot_lights[0];
    assert_eq!(sp.falloff_kind(), Falloff::Smooth);
    assert!((sp.intensity - Vec3::splat(0.1)).length() < 1e-6);
    assert!((sp.axis() - -Vec3::Y).length() < 1e-6);
    assert!((sp.cutoff_angle() - 0.6f32.to_degrees()).abs() < 1e-4);
    assert!((sp.beam_width() - 0.2f32.to_degrees()).abs() < 1e-4);
    // halfway between the cones' cosines: a quarter of the intensity
    let c = 0.5 * (0.2f32.cos() + 0.6f32.cos());
    assert!((sp.falloff(c) - 0.25).abs() < 1e-4);
}

#[test]
fn unsupported_extensions_warn_once_and_required_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut a = Asset::new();
    let mesh = a.quad_mesh(None);
    a.node(json!({"mesh": mesh}), true);
    let colours = a.floats(&[1.0; 12], "VEC3");
    a.json["meshes"][mesh]["primitives"][0]["attributes"]["COLOR_0"] = json!(colours);
    a.json["extensionsUsed"] = json!(["KHR_materials_clearcoat", "KHR_materials_sheen"]);
    let path = a.write(dir.path(), "e.gltf");
    let scene = Scene::load(&path).unwrap();
    let said = |name: &str| scene.warnings.iter().filter(|w| w.contains(name)).count();
    assert_eq!(said("KHR_materials_clearcoat"), 1, "{:?}", scene.warnings);
    assert_eq!(said("KHR_materials_sheen"), 1);
    assert_eq!(said("COLOR_0"), 1, "{:?}", scene.warnings);

    let mut a = Asset::new();
    let mesh = a.quad_mesh(None);
    a.node(json!({"mesh": mesh}), true);
    a.json["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    a.json["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    let e = Scene::load(&a.write(dir.path(), "r.gltf"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("KHR_draco_mesh_compression"), "{e}");
    assert_eq!(e.lines().count(), 1);
}

#[test]
fn bad_files_get_one_line_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "syntax.gltf",
            "{\n  \"asset\": {\"version\": \"2.0\"},\n  \"nodes\": [,]\n}\n".into(),
            ":3",
        ),
        ("empty.glb", String::new(), "glTF"),
        (
            "buffer.gltf",
            json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 64, "uri": "missing.bin"}]})
                .to_string(),
            "missing.bin",
        ),
        (
            "short.gltf",
            json!({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 64, "uri": "data:application/octet-stream;base64,AAAA"}]})
                .to_string(),
            "byteLength",
        ),
    ];
    for (name, text, needle) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let e = Scene::load(&path).unwrap_err().to_string();
        assert!(e.contains(name), "{name}: {e}");
        assert!(e.contains(needle), "{name}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
    // an index past the vertices
    let mut a = Asset::new();
    let p = a.floats(&[0.0; 9], "VEC3");
    let i = a.indices(&[0, 1, 7]);
    let mesh = a.push(
        "meshes",
        json!({"primitives": [{"attributes": {"POSITION": p}, "indices": i}]}),
    );
    a.node(json!({"mesh": mesh}), true);
    let e = Scene::load(&a.write(dir.path(), "index.gltf"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("index"), "{e}");
}

/// A textured quad (a 2 x 2 colour checker and a normal map) under a spot
/// light, seen by a camera tilted down.
fn textured_asset() -> Asset {
    let mut a = Asset::new();
    let checker = a.texture(
        2,
        2,
        &[
            230, 40, 40, 255, 40, 40, 230, 255, 40, 230, 40, 255, 230, 230, 40, 255,
        ],
    );
    let normal = a.texture(1, 1, &[150, 128, 240, 255]);
    let m = a.push(
        "materials",
        json!({
            "name": "checker",
            "pbrMetallicRoughness": {"baseColorTexture": {"index": checker}, "metallicFactor": 0.0, "roughnessFactor": 0.5},
            "normalTexture": {"index": normal, "scale": 0.5}
        }),
    );
    let mesh = a.quad_mesh(Some(m));
    a.node(
        json!({"mesh": mesh, "scale": [4.0, 1.0, 4.0], "translation": [-2.0, 0.0, 2.0]}),
        true,
    );
    let cam = a.push(
        "cameras",
        json!({"name": "tilted", "type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}),
    );
    let s = (std::f64::consts::PI / 8.0).sin();
    let c = (std::f64::consts::PI / 8.0).cos();
    // tilted down by 45 degrees
    a.node(
        json!({"camera": cam, "translation": [0.0, 3.0, 3.0], "rotation": [-s, 0.0, 0.0, c]}),
        true,
    );
    a.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    a.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "spot", "intensity": 30000.0, "spot": {"outerConeAngle": 0.9}}
    ]}});
    a.node(
        json!({"translation": [0, 3, 0], "rotation": [-std::f64::consts::FRAC_1_SQRT_2, 0.0, 0.0, std::f64::consts::FRAC_1_SQRT_2],
               "extensions": {"KHR_lights_punctual": {"light": 0}}}),
        true,
    );
    a
}

#[test]
fn a_textured_asset_renders_and_converts_to_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let a = textured_asset();
    let path = a.write(dir.path(), "asset.gltf");
    let scene = Scene::load(&path).unwrap();
    assert!(scene.materials[0].texture.is_some());
    assert!(scene.materials[0].maps.normal.is_some());
    let rgb = common::render_exr(dir.path(), &path, "asset.exr", 16, [32, 32]);
    // the image is not mirrored or flipped: glTF's texture origin is the
    // image's top left, so the corner at the quad's first vertex (near
    // left in the view) is red, near right blue, far left green
    let mean = |rows: std::ops::Range<usize>, cols: std::ops::Range<usize>| {
        let mut m = Vec3::ZERO;
        for y in rows.clone() {
            for x in cols.clone() {
                let i = 3 * (y * 32 + x);
                m += Vec3::new(rgb[i], rgb[i + 1], rgb[i + 2]);
            }
        }
        m / (rows.len() * cols.len()) as f32
    };
    let (near_left, near_right, far_left) = (
        mean(25..28, 6..12),
        mean(25..28, 20..26),
        mean(9..12, 6..12),
    );
    assert!(
        near_left.x > near_left.z && near_left.x > near_left.y,
        "near left {near_left}"
    );
    assert!(
        near_right.z > near_right.x && near_right.z > near_right.y,
        "near right {near_right}"
    );
    assert!(
        far_left.y > far_left.x && far_left.y > far_left.z,
        "far left {far_left}"
    );
    // converted to TOML, it renders to the same bits
    let toml = dir.path().join("asset.toml");
    let o = common::run(
        dir.path(),
        &["convert", path.to_str().unwrap(), toml.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again = common::render_exr(dir.path(), &toml, "toml.exr", 16, [32, 32]);
    assert_eq!(rgb, again);
}

/// Writes `tests/data/gltf/textured.gltf`, the fuzzer's second glTF seed
/// (`tests/fuzz_loaders.rs`): run by hand when [`textured_asset`] changes.
#[test]
#[ignore = "writes a seed file of the fuzzer; run by hand"]
fn write_fuzz_seed() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gltf");
    std::fs::create_dir_all(&dir).unwrap();
    textured_asset().write(&dir, "textured.gltf");
}

/// `render --camera NAME` reaches the loader: a name the file lacks is a
/// one-line error, a non-zero exit and no image.
#[test]
fn render_camera_flag_picks_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = textured_asset().write(dir.path(), "asset.gltf");
    let out = dir.path().join("x.png");
    let args = |name: &'static str| {
        vec![
            "render".to_string(),
            path.to_str().unwrap().to_string(),
            "-o".into(),
            out.to_str().unwrap().into(),
            "--spp".into(),
            "1".into(),
            "-r".into(),
            "8".into(),
            "8".into(),
            "--camera".into(),
            name.into(),
        ]
    };
    let run = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        common::run(dir.path(), &a)
    };
    let o = run(args("nowhere"));
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no camera named `nowhere`"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!out.exists());
    let o = run(args("tilted"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.exists());
}
