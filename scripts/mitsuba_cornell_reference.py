#!/usr/bin/env python3
"""Mitsuba 3's image of the bundled Cornell box (scenes/cornell-box.toml with
its OBJ and MTL), 32 x 32 pixels, for tests/reference_image.rs.

Writes tests/data/cornell-32-mitsuba.exr (the mean of PASSES independent
renders), tests/data/cornell-32-mitsuba-var.exr (the variance of that mean,
per pixel and channel, from the spread of the passes) and
tests/data/cornell-32-mitsuba.json (provenance and the image's mean). The
scene is read from the repository's own files, so the reference follows
them; nothing here is tuned to embertrace's output.

    pip install mitsuba numpy
    # faster (llvm_ad_rgb): apt-get install libllvm19 and
    # DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
    python3 scripts/mitsuba_cornell_reference.py [SPP_PER_PASS [RESOLUTION]]

Conventions matched (see also scripts/mitsuba_materials_check.py):
- embertrace's max_depth k (bounces) is Mitsuba's max_depth k + 1 (segments);
  the scene's default is 64 bounces (IntegratorSettings::default()).
- embertrace's diffuse BSDF reflects on both sides: Mitsuba's `twosided`.
- emission is one-sided in both, from the side where the triangle winds
  counter-clockwise; faces are flat (`face_normals`).
- the camera's fov is vertical (`fov_axis = y`), the pixel filter a box.
"""
import json
import os
import struct
import sys
import tempfile
import tomllib

import mitsuba as mi
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = os.path.join(ROOT, "scenes")
OUT = os.path.join(ROOT, "tests", "data")
SPP = int(sys.argv[1]) if len(sys.argv) > 1 else 32768
# 32 for tests/reference_image.rs; 128 (with SPP 1024) for the denoising
# measurements of docs/guide/denoising.md and tests/denoise.rs
RES = int(sys.argv[2]) if len(sys.argv) > 2 else 32
PASSES = 8
NAME = f"cornell-{RES}-mitsuba"
MAX_DEPTH = 64  # bounces, embertrace's default

try:
    mi.set_variant("llvm_ad_rgb")
except Exception:
    mi.set_variant("scalar_rgb")


def read_mtl(path):
    """Kd and Ke of each material in an MTL file."""
    mats, cur = {}, None
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w or w[0].startswith("#"):
                continue
            if w[0] == "newmtl":
                cur = mats.setdefault(w[1], {"Kd": [0.0] * 3, "Ke": [0.0] * 3})
            elif w[0] in ("Kd", "Ke"):
                cur[w[0]] = [float(x) for x in w[1:4]]
    return mats


def read_obj(path):
    """Vertices and, per material, the triangles (0-based, as written)."""
    verts, faces, cur = [], {}, None
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0] == "v":
                verts.append([float(x) for x in w[1:4]])
            elif w[0] == "usemtl":
                cur = w[1]
            elif w[0] == "f":
                idx = [int(x.split("/")[0]) - 1 for x in w[1:]]
                for k in range(1, len(idx) - 1):  # fan: polygons as triangles
                    faces.setdefault(cur, []).append([idx[0], idx[k], idx[k + 1]])
    return verts, faces


def write_ply(path, verts, tris):
    """A binary little-endian PLY of `tris` (only the vertices they use)."""
    used = sorted({i for t in tris for i in t})
    remap = {i: k for k, i in enumerate(used)}
    head = ("ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(used)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(tris)}\n"
            "property list uchar int vertex_indices\nend_header\n")
    body = b"".join(struct.pack("<3f", *verts[i]) for i in used)
    body += b"".join(struct.pack("<B3i", 3, *(remap[i] for i in t)) for t in tris)
    with open(path, "wb") as out:
        out.write(head.encode() + body)


def scene_dict(tmp):
    with open(os.path.join(SCENES, "cornell-box.toml"), "rb") as f:
        toml = tomllib.load(f)
    cam = toml["camera"]
    assert [m["file"] for m in toml["mesh"]] == ["cornell-box.obj"], "scene changed"
    verts, faces = read_obj(os.path.join(SCENES, "cornell-box.obj"))
    mats = read_mtl(os.path.join(SCENES, "cornell-box.mtl"))
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": MAX_DEPTH + 1},
        "sensor": {
            "type": "perspective", "fov": cam["fov_y"], "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=cam["origin"], target=cam["target"], up=cam.get("up", [0, 1, 0])),
            "film": {"type": "hdrfilm", "width": RES, "height": RES,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": SPP},
        },
    }
    for name, tris in faces.items():
        path = os.path.join(tmp, f"{name}.ply")
        write_ply(path, verts, tris)
        m = mats[name]
        shape = {
            "type": "ply", "filename": path, "face_normals": True,
            "bsdf": {"type": "twosided", "bsdf": {
                "type": "diffuse", "reflectance": {"type": "rgb", "value": m["Kd"]}}},
        }
        if max(m["Ke"]) > 0:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": m["Ke"]}}
        d[name] = shape
    return d


def main():
    with tempfile.TemporaryDirectory() as tmp:
        scene = mi.load_dict(scene_dict(tmp))
        passes = []
        for k in range(PASSES):
            img = mi.render(scene, spp=SPP, seed=1000 + k)
            passes.append(np.array(img, dtype=np.float64)[:, :, :3])
            print(f"pass {k + 1}/{PASSES}", flush=True)
    stack = np.stack(passes)
    mean = stack.mean(axis=0)
    var_of_mean = stack.var(axis=0, ddof=1) / PASSES
    mi.Bitmap(mean.astype(np.float32)).write(os.path.join(OUT, f"{NAME}.exr"))
    mi.Bitmap(var_of_mean.astype(np.float32)).write(
        os.path.join(OUT, f"{NAME}-var.exr"))
    n = RES * RES
    info = {
        "generator": "scripts/mitsuba_cornell_reference.py",
        "scene": "scenes/cornell-box.toml",
        "mitsuba_version": mi.__version__, "variant": mi.variant(),
        "resolution": [RES, RES], "passes": PASSES, "spp_per_pass": SPP,
        "max_depth_mitsuba": MAX_DEPTH + 1,
        "image_mean_rgb": [float(x) for x in mean.reshape(-1, 3).mean(axis=0)],
        "image_mean_standard_error_rgb":
            [float(x) for x in np.sqrt(var_of_mean.reshape(-1, 3).sum(axis=0)) / n],
    }
    with open(os.path.join(OUT, f"{NAME}.json"), "w") as out:
        json.dump(info, out, indent=1)
        out.write("\n")
    print(json.dumps(info, indent=1))


if __name__ == "__main__":
    main()
