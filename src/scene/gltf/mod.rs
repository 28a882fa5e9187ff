//! glTF 2.0 scenes: `.gltf` (JSON, with external or `data:` buffers and
//! images) and `.glb` (binary), read with the `gltf` crate.
//!
//! What is read:
//!
//! - **Nodes**: the default scene's (else the first scene's) node tree,
//!   each node's TRS or matrix composed in f64. A mesh that several nodes
//!   place becomes one prototype with an instance per node; a mesh placed
//!   once is placed as it is. Primitives in `TRIANGLES`, `TRIANGLE_STRIP`
//!   and `TRIANGLE_FAN` modes; positions, normals (smooth shading) and
//!   the texture coordinates their material reads. glTF's texture space
//!   has `v` pointing down the image; the renderer's points up, so `v`
//!   becomes `1 - v` (after `KHR_texture_transform`).
//! - **Materials**: see `materials.rs`.
//! - **Cameras**: the first perspective camera in node order, or the one
//!   `--camera NAME` names: the node's `-z` is the view, its `+y` up,
//!   `yfov` the vertical field of view, `aspectRatio` the image's shape
//!   (512 pixels high). No camera: framed from the bounds, as a bare OBJ.
//! - **`KHR_lights_punctual`**: point, spot (the specification's smooth
//!   falloff between the inner and outer cones) and directional lights.
//!   The specification's units are photometric (candela for point and spot,
//!   lux for directional); they become radiometric at 683 lm/W, the
//!   luminous efficacy at 555 nm, as Blender's importer does by default,
//!   and emissive materials give radiance as they are.
//! - A scene with no light at all (no emissive material, no punctual
//!   light) is lit by a white environment, with a note, as a bare mesh is.
//!
//! What is not: animation, skins and morph targets (the rest pose is
//! rendered), orthographic cameras, `range` on lights, `COLOR_0` vertex
//! colours (a warning), `TANGENT` (a note: tangents come from the texture
//! coordinates), and extensions
//! other than those above: each gets one warning naming it. An extension
//! the file lists as required and the renderer cannot read (Draco, meshopt,
//! Basis textures) is an error naming it.

mod buffers;
mod materials;

use super::{LoadOptions, MeshData, Scene, SceneBuilder, WorldCamera};
use crate::error::{Error, Result};
use crate::light::{DirectionalLight, PointLight, SpotLight};
use crate::limits::MAX_SCENE_FILE_BYTES;
use crate::math::{DVec3, Vec2, Vec3};
use glam::{DAffine3, DMat4, DQuat};
use materials::{Built, Materials};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Lumens per watt at 555 nm: photometric to radiometric units.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// The extensions this loader reads.
const SUPPORTED: [&str; 6] = [
    "KHR_lights_punctual",
    "KHR_texture_transform",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_ior",
    "KHR_materials_transmission",
];

/// Warnings and notes, each said once.
#[derive(Default)]
pub(super) struct Once {
    seen: HashSet<String>,
    warnings: Vec<String>,
    notes: Vec<String>,
}

impl Once {
    fn warn(&mut self, key: &str, message: String) {
        if self.seen.insert(key.to_string()) {
            self.warnings.push(message);
        }
    }

    fn note(&mut self, key: &str, message: String) {
        if self.seen.insert(key.to_string()) {
            self.notes.push(message);
        }
    }
}

/// Load a `.gltf` or `.glb` scene.
pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let bytes = super::read_bounded(path, MAX_SCENE_FILE_BYTES, super::Content::Magic(b"", ""))?;
    glb_header_check(&bytes)
        .map_err(|m| Error::input(path, None, format!("not a valid GLB file: {m}")))?;
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| parse_error(path, &bytes, e))?;
    let root = document.into_json();
    precheck(&root)
        .map_err(|m| Error::input(path, None, format!("not a valid glTF 2.0 file: {m}")))?;
    let document = gltf::Document::from_json(root).map_err(|e| parse_error(path, &bytes, e))?;
    let doc = &document;
    let mut once = Once::default();
    for ext in doc.extensions_required() {
        if !SUPPORTED.contains(&ext) {
            return Err(Error::input(
                path,
                None,
                format!(
                    "requires the extension {} (unsupported: re-export without it)",
                    crate::error::one_line(ext)
                ),
            ));
        }
    }
    for ext in doc.extensions_used() {
        if !SUPPORTED.contains(&ext) {
            once.warn(
                ext,
                format!("extension {} ignored", crate::error::one_line(ext)),
            );
        }
    }
    let mut files = Vec::new();
    let buffers = buffers::load_buffers(path, doc, blob, &mut files)?;
    let mut b = SceneBuilder::new(path);
    let mut materials = Materials::new(path, &buffers);

    // every node of the scene with its world matrix, in order
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| Error::input(path, None, "has no scene"))?;
    let mut placed: Vec<(gltf::Node, DAffine3)> = Vec::new();
    let mut visited = HashSet::new();
    let mut stack: Vec<(gltf::Node, DAffine3)> =
        scene.nodes().map(|n| (n, DAffine3::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        if !visited.insert(node.index()) {
            return Err(Error::input(
                path,
                None,
                format!(
                    "node {} is reached twice: the node hierarchy must be a tree",
                    node.index()
                ),
            ));
        }
        let m = parent * local_matrix(&node);
        let children: Vec<_> = node.children().map(|c| (c, m)).collect();
        stack.extend(children.into_iter().rev());
        if node.skin().is_some() || node.weights().is_some() {
            once.warn(
                "skin",
                "skins and morph targets ignored: the rest pose is rendered".into(),
            );
        }
        placed.push((node, m));
    }
    if doc.animations().next().is_some() {
        once.warn("animation", "animations ignored".into());
    }

    // meshes: once each, instanced where several nodes place them
    let mut uses: HashMap<usize, Vec<DAffine3>> = HashMap::new();
    let mut order = Vec::new();
    for (node, m) in &placed {
        if let Some(mesh) = node.mesh() {
            let v = uses.entry(mesh.index()).or_default();
            if v.is_empty() {
                order.push(mesh);
            }
            v.push(*m);
        }
    }
    for mesh in order {
        let data = read_mesh(path, &mesh, &buffers, &mut materials, &mut once)?;
        if data.indices.is_empty() {
            continue;
        }
        let matrices = &uses[&mesh.index()];
        if let [m] = matrices.as_slice() {
            b.add_mesh_matrix(data, *m, None)?;
            continue;
        }
        let name = data.name.clone();
        let proto = b.add_prototype(data, None)?;
        for m in matrices {
            let det = m.matrix3.determinant();
            if !(det.is_finite() && det != 0.0 && m.translation.is_finite()) {
                once.warn(
                    "singular-instance",
                    format!(
                        "a node placing mesh `{name}` has a singular transform (scale 0): skipped"
                    ),
                );
                continue;
            }
            b.add_instance(proto, *m, None, None)?;
        }
    }

    // cameras
    let cameras: Vec<_> = placed
        .iter()
        .filter_map(|(n, m)| n.camera().map(|c| (c, *m)))
        .collect();
    let chosen = match &options.camera {
        Some(want) => {
            let found = cameras
                .iter()
                .find(|(c, _)| c.name() == Some(want.as_str()));
            match found {
                Some(c) => Some(c),
                None => {
                    let names: Vec<String> = cameras
                        .iter()
                        .map(|(c, _)| {
                            format!(
                                "`{}`",
                                crate::error::one_line(c.name().unwrap_or("(unnamed)"))
                            )
                        })
                        .collect();
                    return Err(Error::input(
                        path,
                        None,
                        format!(
                            "no camera named `{}` (the file has {})",
                            crate::error::one_line(want),
                            if names.is_empty() {
                                "none".to_string()
                            } else {
                                names.join(", ")
                            }
                        ),
                    ));
                }
            }
        }
        None => cameras
            .iter()
            .find(|(c, _)| matches!(c.projection(), gltf::camera::Projection::Perspective(_))),
    };
    if cameras
        .iter()
        .any(|(c, _)| matches!(c.projection(), gltf::camera::Projection::Orthographic(_)))
    {
        once.warn("orthographic", "orthographic cameras ignored".into());
    }
    if let Some((camera, m)) = chosen {
        let gltf::camera::Projection::Perspective(p) = camera.projection() else {
            return Err(Error::input(
                path,
                None,
                "the camera --camera names is orthographic: only perspective cameras are rendered",
            ));
        };
        let fov_y = p.yfov().to_degrees();
        if !(fov_y > 0.0 && fov_y < 180.0) {
            return Err(Error::input(
                path,
                None,
                format!("camera yfov {} is not in (0, pi)", p.yfov()),
            ));
        }
        let origin = m.transform_point3(DVec3::ZERO);
        let forward = m.transform_vector3(-DVec3::Z);
        let up = m.transform_vector3(DVec3::Y);
        let target = origin + forward / forward.length();
        let up = WorldCamera::usable_up(origin, target, up)
            .ok_or_else(|| Error::input(path, None, "the camera's node transform is singular"))?;
        b.set_camera(WorldCamera {
            origin,
            target,
            up,
            fov_y,
        });
        if let Some(a) = p.aspect_ratio() {
            let w = (512.0 * a as f64).round();
            if !(w >= 1.0 && w <= crate::limits::MAX_RESOLUTION as f64) {
                return Err(Error::input(
                    path,
                    None,
                    format!("camera aspectRatio {a} makes an image {w} pixels wide"),
                ));
            }
            b.scene_mut().resolution = [w as u32, 512];
        }
    }

    // lights
    for (node, m) in &placed {
        let Some(light) = node.light() else { continue };
        let colour = Vec3::from(light.color()) * (light.intensity() / LUMENS_PER_WATT);
        if !(colour.is_finite() && colour.min_element() >= 0.0) {
            return Err(Error::input(
                path,
                None,
                format!(
                    "light {}: colour times intensity must be finite and >= 0",
                    light.index()
                ),
            ));
        }
        if light.range().is_some() {
            once.warn(
                "range",
                "a punctual light's range ignored: light falls off with the inverse square alone"
                    .into(),
            );
        }
        let position = m.transform_point3(DVec3::ZERO);
        let axis = m.transform_vector3(-DVec3::Z).as_vec3();
        match light.kind() {
            gltf::khr_lights_punctual::Kind::Point => {
                b.add_point_light(position, PointLight::new(Vec3::ZERO, colour));
            }
            gltf::khr_lights_punctual::Kind::Directional => {
                let l = DirectionalLight::new(axis, colour).ok_or_else(|| {
                    Error::input(
                        path,
                        None,
                        format!("light {}: its node's transform is singular", light.index()),
                    )
                })?;
                b.scene_mut().directional_lights.push(l);
            }
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let l =
                    SpotLight::smooth(Vec3::ZERO, axis, colour, inner_cone_angle, outer_cone_angle)
                        .map_err(|e| {
                            Error::input(path, None, format!("light {}: {e}", light.index()))
                        })?;
                b.add_spot_light(position, l);
            }
        }
    }
    // a scene with no punctual light and no emitter is lit as a bare mesh
    b.light_if_dark = true;

    files.append(&mut materials.files);
    let s = b.scene_mut();
    s.warnings.extend(
        once.warnings
            .into_iter()
            .map(|w| format!("{}: {w}", path.display())),
    );
    s.notes.extend(once.notes);
    s.mesh_files.extend(files);
    Ok(b.build())
}

/// What the `gltf` crate (1.4.1) assumes and its validation does not check,
/// found by fuzzing: its validation indexes a primitive's attribute
/// accessors without a bounds check (gltf-json's `mesh.rs`), and its
/// accessors unwrap an image's `uri` or `bufferView` (and a view's
/// `mimeType`) and a camera's object of its `type`.
/// A GLB's 12-byte header must give a total length of at least itself:
/// the `gltf` crate (1.4.1) subtracts the header's size from that length
/// unchecked, and panics on a smaller one (found by `tests/fuzz_loaders.rs`,
/// seed 5562362430153967861).
fn glb_header_check(bytes: &[u8]) -> std::result::Result<(), String> {
    if !bytes.starts_with(b"glTF") || bytes.len() < 12 {
        return Ok(());
    }
    let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if length < 12 {
        return Err(format!(
            "the header gives a length of {length} bytes, less than the header's 12"
        ));
    }
    Ok(())
}

fn precheck(root: &gltf::json::Root) -> std::result::Result<(), String> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for prim in &mesh.primitives {
            for index in prim.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "mesh {m} names accessor {} of {}",
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    for (i, image) in root.images.iter().enumerate() {
        match (&image.uri, &image.buffer_view, &image.mime_type) {
            (Some(_), None, _) | (None, Some(_), Some(_)) => {}
            (None, Some(_), None) => {
                return Err(format!("image {i}: a bufferView needs a mimeType"));
            }
            _ => return Err(format!("image {i} needs exactly one of uri and bufferView")),
        }
    }
    for (i, camera) in root.cameras.iter().enumerate() {
        use gltf::json::camera::Type;
        use gltf::json::validation::Checked;
        let ok = match camera.type_ {
            Checked::Valid(Type::Perspective) => camera.perspective.is_some(),
            Checked::Valid(Type::Orthographic) => camera.orthographic.is_some(),
            Checked::Invalid => true,
        };
        if !ok {
            return Err(format!("camera {i} lacks the object its type names"));
        }
    }
    Ok(())
}

/// A parse error: the JSON's line where serde names one.
fn parse_error(path: &Path, bytes: &[u8], e: gltf::Error) -> Error {
    let glb = bytes.starts_with(b"glTF");
    match e {
        gltf::Error::Deserialize(j) if !glb && j.line() > 0 => {
            Error::input(path, Some(j.line()), format!("not a glTF 2.0 file: {j}"))
        }
        gltf::Error::Validation(v) => {
            let first = v
                .first()
                .map(|(p, e)| format!("{p}: {e}"))
                .unwrap_or_default();
            Error::input(
                path,
                None,
                format!(
                    "not a valid glTF 2.0 file ({} problems; first: {first})",
                    v.len()
                ),
            )
        }
        other => Error::input(path, None, format!("not a glTF 2.0 file: {other}")),
    }
}

/// A node's own transform, in f64.
fn local_matrix(node: &gltf::Node) -> DAffine3 {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let cols = matrix.map(|c| c.map(|x| x as f64));
            DAffine3::from_mat4(DMat4::from_cols_array_2d(&cols))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let [x, y, z, w] = rotation.map(|x| x as f64);
            let q = DQuat::from_xyzw(x, y, z, w);
            let q = if q.length() > 0.0 {
                q.normalize()
            } else {
                DQuat::IDENTITY
            };
            DAffine3::from_scale_rotation_translation(
                DVec3::from(scale.map(|x| x as f64)),
                q,
                DVec3::from(translation.map(|x| x as f64)),
            )
        }
    }
}

/// Triangles of a primitive's vertex sequence in `mode`.
fn triangles(mode: gltf::mesh::Mode, idx: &[u32]) -> Option<Vec<[u32; 3]>> {
    use gltf::mesh::Mode;
    Some(match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                // every other triangle flips to keep the winding
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => return None,
    })
}

/// A mesh's primitives as one [`MeshData`] in object space, a material per
/// primitive.
fn read_mesh(
    path: &Path,
    mesh: &gltf::Mesh,
    buffers: &[Vec<u8>],
    materials: &mut Materials,
    once: &mut Once,
) -> Result<MeshData> {
    let name = match mesh.name() {
        Some(n) => crate::error::one_line(n).into_owned(),
        None => format!("mesh {}", mesh.index()),
    };
    let mut out = MeshData {
        name: name.clone(),
        ..MeshData::default()
    };
    let mut local: HashMap<Option<usize>, u32> = HashMap::new();
    let (mut any_uv, mut any_normal) = (false, false);
    let mut uvs: Vec<[Vec2; 3]> = Vec::new();
    let mut normals: Vec<[Vec3; 3]> = Vec::new();
    for prim in mesh.primitives() {
        if prim.get(&gltf::Semantic::Colors(0)).is_some() {
            once.warn(
                "colors",
                format!("mesh `{name}`: COLOR_0 vertex colours ignored"),
            );
        }
        if prim.get(&gltf::Semantic::Tangents).is_some() {
            once.note(
                "tangents",
                "TANGENT ignored: normal maps take their tangents from the texture coordinates"
                    .to_string(),
            );
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
        let Some(positions) = reader.read_positions() else {
            once.warn(
                "no-positions",
                format!("mesh `{name}`: a primitive without POSITION skipped"),
            );
            continue;
        };
        let positions: Vec<[f32; 3]> = positions.collect();
        let idx: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        let Some(tris) = triangles(prim.mode(), &idx) else {
            once.warn(
                "mode",
                format!("mesh `{name}`: points and lines are not rendered"),
            );
            continue;
        };
        let n = positions.len() as u32;
        if tris.iter().flatten().any(|&i| i >= n) {
            return Err(Error::input(
                path,
                None,
                format!("mesh `{name}`: an index is past the primitive's {n} vertices"),
            ));
        }
        let Built {
            material,
            uv_set,
            uv_transform,
        } = materials.get(&prim.material(), once)?;
        let mi = *local.entry(prim.material().index()).or_insert_with(|| {
            out.materials.push(material);
            out.materials.len() as u32 - 1
        });
        let tex: Option<Vec<Vec2>> = reader.read_tex_coords(uv_set).map(|t| {
            t.into_f32()
                .map(|uv| {
                    let [u, v] = uv_transform.map_or(uv, |t| t.apply(uv));
                    Vec2::new(u, 1.0 - v)
                })
                .collect()
        });
        let nrm: Option<Vec<Vec3>> = reader.read_normals().map(|r| r.map(Vec3::from).collect());
        let base = out.positions.len() as u32;
        out.positions
            .extend(positions.iter().map(|p| DVec3::from(p.map(|x| x as f64))));
        let short = |v: usize| v < positions.len();
        let tex = tex.filter(|t| !short(t.len()));
        let nrm = nrm.filter(|t| !short(t.len()));
        // pad the per-triangle corner arrays of earlier primitives
        let before = out.indices.len();
        if tex.is_some() && !any_uv {
            any_uv = true;
            uvs.resize(before, [Vec2::ZERO; 3]);
        }
        if nrm.is_some() && !any_normal {
            any_normal = true;
            normals.resize(before, [Vec3::ZERO; 3]);
        }
        for t in &tris {
            out.indices.push(t.map(|i| base + i));
            out.tri_material.push(mi);
            if any_uv {
                uvs.push(match &tex {
                    Some(tc) => t.map(|i| tc[i as usize]),
                    None => [Vec2::ZERO; 3],
                });
            }
            if any_normal {
                normals.push(match &nrm {
                    Some(nv) => t.map(|i| nv[i as usize]),
                    None => [Vec3::ZERO; 3],
                });
            }
        }
    }
    out.uvs = uvs;
    out.normals = normals;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::glb_header_check;

    #[test]
    fn a_glb_header_shorter_than_itself_is_refused_before_the_crate_sees_it() {
        let mut bytes = b"glTF\x02\x00\x00\x00\x02\x00\x00\x00".to_vec();
        bytes.extend_from_slice(b"\x0c\x09\x00\x00JSON{}");
        let err = glb_header_check(&bytes).unwrap_err();
        assert!(err.contains("length of 2 bytes"), "{err}");
        bytes[8] = 12;
        assert!(glb_header_check(&bytes).is_ok());
        assert!(glb_header_check(b"{\"asset\":{}}").is_ok());
    }
}
