//! PLY meshes: the three encodings read to the same mesh, quads are split,
//! normals and UVs reach the corners, `[[mesh]] file = "x.ply"` and bare
//! `.ply` scenes load, and hostile headers are one-line errors before any
//! allocation.

use embertrace::scene::{Scene, load_ply_mesh};
use std::path::{Path, PathBuf};

/// A unit quad (two triangles once split) with normals and UVs, and a lone
/// triangle, as the values of each vertex and face.
const VERTS: [[f32; 8]; 5] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
    [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
    [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0],
    [0.5, 0.5, 2.0, 0.0, 1.0, 0.0, 0.25, 0.75],
];
const FACES: [&[u32]; 2] = [&[0, 1, 2, 3], &[0, 1, 4]];

fn header(format: &str) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment made by tests/ply.rs\nelement vertex 5\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float u\nproperty float v\n\
         element face 2\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

fn ascii() -> Vec<u8> {
    let mut s = header("ascii");
    for v in VERTS {
        let words: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        s += &(words.join(" ") + "\n");
    }
    for f in FACES {
        let words: Vec<String> = f.iter().map(|x| x.to_string()).collect();
        s += &format!("{} {}\n", f.len(), words.join(" "));
    }
    s.into_bytes()
}

fn binary(big: bool) -> Vec<u8> {
    let name = if big {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut b = header(name).into_bytes();
    for v in VERTS {
        for x in v {
            b.extend(if big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            });
        }
    }
    for f in FACES {
        b.push(f.len() as u8);
        for &i in f {
            let i = i as i32;
            b.extend(if big {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
    }
    b
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn three_encodings_read_to_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let a = load_ply_mesh(&write(dir.path(), "a.ply", &ascii())).unwrap();
    let le = load_ply_mesh(&write(dir.path(), "le.ply", &binary(false))).unwrap();
    let be = load_ply_mesh(&write(dir.path(), "be.ply", &binary(true))).unwrap();
    assert_eq!(a.positions.len(), 5);
    // the quad fans into two triangles, the triangle stays one
    assert_eq!(a.indices, vec![[0, 1, 2], [0, 2, 3], [0, 1, 4]]);
    assert_eq!(a.normals.len(), 3);
    assert_eq!(a.uvs.len(), 3);
    assert_eq!(a.normals[2][2].y, 1.0);
    assert_eq!(a.uvs[2][2].x, 0.25);
    assert_eq!(a.uvs[2][2].y, 0.75);
    for m in [&le, &be] {
        assert_eq!(m.positions, a.positions);
        assert_eq!(m.indices, a.indices);
        assert_eq!(m.normals, a.normals);
        assert_eq!(m.uvs, a.uvs);
    }
}

#[test]
fn extra_properties_and_elements_are_read_past() {
    let dir = tempfile::tempdir().unwrap();
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty uchar red\n\
                property double y\nproperty double z\nelement face 1\nproperty uchar flags\n\
                property list uint8 uint32 vertex_index\nelement edge 1\nproperty int a\n\
                property list uchar int stuff\nend_header\n\
                0 255 0 0\n1 0 0 0\n0 7 1 0\n9 3 0 1 2\n4 2 8 9\n";
    let m = load_ply_mesh(&write(dir.path(), "x.ply", text.as_bytes())).unwrap();
    assert_eq!(m.indices, vec![[0, 1, 2]]);
    assert_eq!(m.positions[2].y, 1.0);
    assert!(m.normals.is_empty() && m.uvs.is_empty());
}

fn error(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let p = write(dir, name, bytes);
    let e = load_ply_mesh(&p).unwrap_err().to_string();
    assert!(!e.contains('\n'), "not one line: {e}");
    assert!(e.contains(name), "does not name the file: {e}");
    e
}

#[test]
fn hostile_headers_are_refused_before_allocation() {
    let dir = tempfile::tempdir().unwrap();
    // four billion vertices claimed in a file of a few hundred bytes
    let huge = header("binary_little_endian").replace("vertex 5", "vertex 4000000000");
    let e = error(dir.path(), "huge.ply", huge.as_bytes());
    assert!(e.contains(":4:"), "{e}");
    // a count within the scene limits but beyond the file's bytes
    let mut b = header("binary_little_endian").replace("vertex 5", "vertex 50000");
    b += "\0\0\0\0";
    let e = error(dir.path(), "big.ply", b.as_bytes());
    assert!(e.contains("more than the file"), "{e}");
    // ASCII claims are bounded too
    let a = String::from_utf8(ascii())
        .unwrap()
        .replace("face 2", "face 2000");
    let e = error(dir.path(), "a.ply", a.as_bytes());
    assert!(e.contains("face"), "{e}");
}

#[test]
fn bad_data_names_where() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = binary(false);
    b.truncate(b.len() - 3);
    let e = error(dir.path(), "cut.ply", &b);
    assert!(e.contains("ends early"), "{e}");
    let a = String::from_utf8(ascii())
        .unwrap()
        .replace("3 0 1 4", "3 0 1 9");
    let e = error(dir.path(), "index.ply", a.as_bytes());
    assert!(e.contains("vertex index 9"), "{e}");
    // ASCII data errors give the line: the bad face is on line 22
    assert!(e.contains(":22:"), "{e}");
    let a = String::from_utf8(ascii())
        .unwrap()
        .replace("4 0 1 2 3", "2 0 1");
    let e = error(dir.path(), "two.ply", a.as_bytes());
    assert!(e.contains("2 corners"), "{e}");
    let e = error(dir.path(), "notply.ply", b"solid cube\nfacet\n");
    assert!(e.contains("not a PLY file"), "{e}");
    let e = error(
        dir.path(),
        "nohead.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\n",
    );
    assert!(e.contains("end_header"), "{e}");
    let nan =
        String::from_utf8(ascii())
            .unwrap()
            .replacen("0 0 0 0 0 1 0 0", "nan 0 0 0 0 1 0 0", 1);
    let e = error(dir.path(), "nan.ply", nan.as_bytes());
    assert!(e.contains("not finite"), "{e}");
}

#[test]
fn ply_meshes_load_from_scenes_and_bare() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "quad.ply", &binary(true));
    let toml = "[camera]\norigin = [0.5, 0.5, 5]\ntarget = [0.5, 0.5, 0]\nfov_y = 40\n\n\
                [[mesh]]\nfile = \"quad.ply\"\nmaterial = { emission = 1 }\n";
    let p = write(dir.path(), "s.toml", toml.as_bytes());
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.triangle_count(), 3);
    assert!(s.has_emitters());
    let bare = Scene::load(&dir.path().join("quad.ply")).unwrap();
    assert_eq!(bare.triangle_count(), 3);
    assert_eq!(bare.environment, Some(embertrace::math::Vec3::ONE));
}
