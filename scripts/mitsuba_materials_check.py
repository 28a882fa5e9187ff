#!/usr/bin/env python3
"""Render scenes/materials.toml with embertrace and the same scene with
Mitsuba 3 (analytic spheres, the same floor OBJ, checker texture and sky),
and print the mean radiance of each sphere's central square, the sky and the
floor in both, with their ratio.

    pip install mitsuba numpy
    scripts/run --help >/dev/null   # builds target/release/embertrace
    python3 scripts/mitsuba_materials_check.py [W H SPP]   # default 160 80 2048

Conventions matched: embertrace max_depth k = Mitsuba max_depth k + 1; the
camera's fov is vertical; Mitsuba's `plastic`/`roughplastic` with
`nonlinear = true`, the physically based sum over internal reflections that
embertrace's plastic implements (Mitsuba's default `nonlinear = false`
divides by `1 - F_int` instead of `1 - rho F_int`, a different model).
"""
import math
import os
import subprocess
import sys
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
S = os.path.join(ROOT, "scenes") + "/"
W, H, SPP = (int(a) for a in (sys.argv[1:4] if len(sys.argv) >= 4 else (160, 80, 2048)))
EYE, TARGET, FOV = [0, 1.6, 6.5], [0, 0.6, 0], 32.0
CENTRES = [-2.4, -1.2, 0.0, 1.2, 2.4]
NAMES = ["diffuse", "mirror", "glass", "rough gold", "rough plastic"]


def sphere(x, bsdf):
    return {"type": "sphere", "center": [x, 0.55, 0], "radius": 0.55, "bsdf": bsdf}


def rgb(v):
    return {"type": "rgb", "value": v}


scene = mi.load_dict({
    "type": "scene",
    "integrator": {"type": "path", "max_depth": 17},  # embertrace's 16
    "sensor": {
        "type": "perspective", "fov": FOV, "fov_axis": "y",
        "to_world": mi.ScalarTransform4f().look_at(origin=EYE, target=TARGET, up=[0, 1, 0]),
        "film": {"type": "hdrfilm", "width": W, "height": H, "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": SPP},
    },
    "env": {"type": "envmap", "filename": S + "sky.exr"},
    "floor": {
        "type": "obj", "filename": S + "floor.obj", "face_normals": True,
        "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {
            "type": "bitmap", "filename": S + "checker.png", "filter_type": "bilinear"}}},
    },
    "s0": sphere(CENTRES[0], {"type": "diffuse", "reflectance": rgb([0.7, 0.7, 0.7])}),
    "s1": sphere(CENTRES[1], {"type": "conductor", "material": "none"}),
    "s2": sphere(CENTRES[2], {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}),
    "s3": sphere(CENTRES[3], {"type": "roughconductor", "distribution": "ggx", "alpha": 0.2,
                              "eta": rgb([0.166, 0.431, 1.38]), "k": rgb([3.15, 2.35, 1.76])}),
    "s4": sphere(CENTRES[4], {"type": "roughplastic", "distribution": "ggx", "alpha": 0.15,
                              "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True,
                              "diffuse_reflectance": rgb([0.6, 0.08, 0.05])}),
})
ref = np.array(mi.render(scene), dtype=np.float64)

with tempfile.TemporaryDirectory() as d:
    out = os.path.join(d, "ours.exr")
    subprocess.run([os.path.join(ROOT, "target/release/embertrace"), "render",
                    S + "materials.toml", "-r", str(W), str(H), "-s", str(SPP),
                    "--seed", "3", "-o", out, "-q"], check=True)
    ours = np.array(mi.Bitmap(out), dtype=np.float64)


def project(p):
    eye, tgt = np.array(EYE, float), np.array(TARGET, float)
    f = (tgt - eye) / np.linalg.norm(tgt - eye)
    r = np.cross(f, [0, 1, 0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = np.array(p, float) - eye
    z = d @ f
    t = math.tan(math.radians(FOV / 2))
    return W / 2 + (d @ r) / z / t * H / 2, H / 2 - (d @ u) / z / t * H / 2


print(f"{W}x{H}, {SPP} spp; mean RGB over each region, embertrace / Mitsuba {mi.__version__}")
regions = []
for name, x in zip(NAMES, CENTRES):
    px, py = project([x, 0.55, 0])
    half = int(0.35 * (project([x + 0.55, 0.55, 0])[0] - px))
    regions.append((name, (int(py) - half, int(py) + half, int(px) - half, int(px) + half)))
regions += [("sky", (0, H * 3 // 16, 0, W)), ("floor", (H * 7 // 8, H, 0, W))]
for name, (y0, y1, x0, x1) in regions:
    a = ours[y0:y1, x0:x1].mean(axis=(0, 1))
    b = ref[y0:y1, x0:x1].mean(axis=(0, 1))
    print(f"{name:14s} ours {np.round(a, 4)}  mitsuba {np.round(b, 4)}  ratio {np.round(a / b, 3)}")
