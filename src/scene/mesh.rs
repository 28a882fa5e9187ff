//! A mesh as a loader reads it ([`MeshData`]) and the placement a scene file
//! gives it ([`Transform`]), both in f64: nothing becomes f32 until
//! [`super::SceneBuilder`] has rebased the scene.

use super::Material;
use crate::math::{DVec3, Vec2, Vec3};
use glam::DAffine3;
use std::path::PathBuf;

/// An affine placement: scale, then rotate about an axis, then translate,
/// composed in f64 (a large translation keeps its precision until the scene
/// is rebased).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Per-axis scale.
    pub scale: DVec3,
    /// Rotation axis (any length but zero) and angle in degrees.
    pub rotate: Option<(DVec3, f64)>,
    /// Translation.
    pub translate: DVec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            scale: DVec3::ONE,
            rotate: None,
            translate: DVec3::ZERO,
        }
    }
}

impl Transform {
    /// The matrix `T * R * S`.
    pub fn matrix(&self) -> DAffine3 {
        let r = match self.rotate {
            Some((axis, deg)) => glam::DQuat::from_axis_angle(axis.normalize(), deg.to_radians()),
            None => glam::DQuat::IDENTITY,
        };
        DAffine3::from_scale_rotation_translation(self.scale, r, self.translate)
    }
}

/// A mesh as a loader reads it, before placement: positions, triangles and a
/// material index per triangle into `materials`.
#[derive(Debug, Clone, Default)]
pub struct MeshData {
    /// Name for messages.
    pub name: String,
    /// Vertex positions, in f64 so that coordinates far from the origin
    /// keep their precision until the scene is rebased.
    pub positions: Vec<DVec3>,
    /// Triangles.
    pub indices: Vec<[u32; 3]>,
    /// Material per triangle, indexing `materials`.
    pub tri_material: Vec<u32>,
    /// The mesh's materials.
    pub materials: Vec<Material>,
    /// Texture coordinates of each triangle's corners: empty, or one entry
    /// per triangle.
    pub uvs: Vec<[Vec2; 3]>,
    /// Vertex normals of each triangle's corners (any length; zero = none):
    /// empty, or one entry per triangle.
    pub normals: Vec<[Vec3; 3]>,
    /// Things in the file the loader read past, one line each, with the
    /// file and line: the scene's warnings once the mesh is placed.
    pub warnings: Vec<String>,
    /// The files it was read from (the mesh file, its material libraries):
    /// the scene's [`Scene::mesh_files`] once placed.
    pub files: Vec<PathBuf>,
}

impl MeshData {
    /// Move the mesh by `m` (f64): positions through `m`, vertex normals
    /// through its inverse transpose (a unit normal that stays unit to a few
    /// ulps is kept as it is, so a scene written out with its normals reads
    /// back to the same bits; a zero, non-finite or degenerate one shades
    /// flat), and the winding (with the per-corner attributes) reversed by
    /// a mirror, so each triangle's front stays where its normal says.
    pub fn transform_by(&mut self, m: &DAffine3) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let normal_matrix = m.matrix3.inverse().transpose();
        for corners in &mut self.normals {
            *corners = corners.map(|n| {
                let w = (normal_matrix * n.as_dvec3()).as_vec3();
                let w = if (w.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
                    w
                } else {
                    w.normalize_or_zero()
                };
                if w.is_finite() { w } else { Vec3::ZERO }
            });
        }
        if m.matrix3.determinant() < 0.0 {
            for t in &mut self.indices {
                t.swap(1, 2);
            }
            for uv in &mut self.uvs {
                uv.swap(1, 2);
            }
            for ns in &mut self.normals {
                ns.swap(1, 2);
            }
        }
    }

    /// Append `other`'s triangles, materials and per-corner attributes (a
    /// mesh with none gets zeros where the other has some).
    pub fn append(&mut self, mut other: MeshData) {
        let (n_self, n_other) = (self.indices.len(), other.indices.len());
        let base_vertex = self.positions.len() as u32;
        let base_material = self.materials.len() as u32;
        if !self.uvs.is_empty() || !other.uvs.is_empty() {
            self.uvs.resize(n_self, [Vec2::ZERO; 3]);
            other.uvs.resize(n_other, [Vec2::ZERO; 3]);
            self.uvs.append(&mut other.uvs);
        }
        if !self.normals.is_empty() || !other.normals.is_empty() {
            self.normals.resize(n_self, [Vec3::ZERO; 3]);
            other.normals.resize(n_other, [Vec3::ZERO; 3]);
            self.normals.append(&mut other.normals);
        }
        self.positions.append(&mut other.positions);
        self.indices
            .extend(other.indices.iter().map(|t| t.map(|i| i + base_vertex)));
        self.tri_material
            .extend(other.tri_material.iter().map(|m| m + base_material));
        self.materials.append(&mut other.materials);
        self.warnings.append(&mut other.warnings);
        for f in other.files {
            if !self.files.contains(&f) {
                self.files.push(f);
            }
        }
    }

    /// Smooth vertex normals, per triangle corner: at each vertex the sum
    /// of its triangles' unit normals weighted by the triangle's angle at
    /// that vertex (Thürmer and Wüthrich 1998, the weighting Mitsuba uses
    /// when a mesh has none), normalised. Degenerate triangles add nothing;
    /// a vertex left with a zero sum gets a zero normal (shaded flat).
    pub fn vertex_normals(&self) -> Vec<[Vec3; 3]> {
        let mut sum = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            // relative to the first corner, so a far-away mesh loses nothing
            let p =
                t.map(|i| (self.positions[i as usize] - self.positions[t[0] as usize]).as_vec3());
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            if !n.is_finite() || n == Vec3::ZERO {
                continue;
            }
            for k in 0..3 {
                let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                if angle.is_finite() {
                    sum[t[k] as usize] += n * angle;
                }
            }
        }
        let unit: Vec<Vec3> = sum.iter().map(|n| n.normalize_or_zero()).collect();
        self.indices
            .iter()
            .map(|t| t.map(|i| unit[i as usize]))
            .collect()
    }
}
