#!/usr/bin/env python3
"""Write the assets of the Mitsuba XML test scenes (icosphere.obj, floor.ply,
sky.exr, checker.png, maps.xml's normals.png, roughness.png and bumps.png,
grazing.xml's steep.png,
production.xml's cutout.png and metals.xml's checker.jpg) and render each scene with Mitsuba 3
itself into
<scene>.ref.exr (the mean of PASSES independent renders) and
<scene>.var.exr (the variance of that mean, per pixel and channel, from the
spread of the passes). tests/mitsuba.rs compares embertrace's renders of the
same XML files against them, block by block.

    pip install mitsuba numpy
    # faster: apt-get install libllvm19 and
    # DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
    python3 tests/data/mitsuba/make_references.py [SPP_PER_PASS [SCENE ...]]

With scene names, only those are rendered again; references.json keeps the
other scenes' entries.

The scenes themselves are hand-written; this script only reads them.
"""
import json
import math
import os
import struct
import sys
import xml.etree.ElementTree as ET

import mitsuba as mi
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = ["cbox", "lights", "envmap", "instances", "spot", "maps", "production", "meaning",
          "grazing", "metals"]
# Scenes rendered with `volpath` instead of their XML's `path`: Mitsuba
# 3.9.1's `path` tests an emitter sample's visibility with every surface
# opaque, so its shadow rays stop at a `mask`'s holes (while its BSDF samples
# pass through them); `volpath` carries shadow rays through null interfaces,
# as embertrace's traversal does. Without media it is otherwise the same path
# tracer (measured on production.xml with the sky removed: `path` left the
# masked cards up to 49 standard errors darker than embertrace, `volpath`
# within 2.1 in every block).
VOLPATH = {"production"}
PASSES = 8
SPP = int(sys.argv[1]) if len(sys.argv) > 1 else 4096

try:
    mi.set_variant("llvm_ad_rgb")
except Exception:
    mi.set_variant("scalar_rgb")


def icosphere():
    """A level-1 subdivided icosahedron (80 faces) on the unit sphere,
    without normals or UVs: Mitsuba and embertrace compute the same
    angle-weighted vertex normals for it."""
    t = (1 + math.sqrt(5)) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9),
         (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2),
         (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    cache = {}

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in cache:
            p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
            n = math.sqrt(sum(x * x for x in p))
            v.append(tuple(x / n for x in p))
            cache[key] = len(v) - 1
        return cache[key]

    faces = []
    for a, b, c in f:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    with open(os.path.join(HERE, "icosphere.obj"), "w") as out:
        out.write("# level-1 icosphere, written by make_references.py\n")
        for p in v:
            out.write("v %.9f %.9f %.9f\n" % p)
        for a, b, c in faces:
            out.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))


def floor_ply():
    """A 6 x 6 floor at y = 0 facing +y, as binary little-endian PLY with
    UVs (two triangles: Mitsuba's PLY reader takes no quads)."""
    verts = [(-3, 0, 3, 0, 0), (3, 0, 3, 1, 0), (3, 0, -3, 1, 1), (-3, 0, -3, 0, 1)]
    head = ("ply\nformat binary_little_endian 1.0\ncomment make_references.py\n"
            "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "property float u\nproperty float v\nelement face 2\n"
            "property list uchar int vertex_indices\nend_header\n")
    body = b"".join(struct.pack("<5f", *p) for p in verts)
    body += struct.pack("<B3i", 3, 0, 1, 2) + struct.pack("<B3i", 3, 0, 2, 3)
    with open(os.path.join(HERE, "floor.ply"), "wb") as out:
        out.write(head.encode() + body)


def sky_exr():
    """A 32 x 16 sky: a blue-to-white gradient with a warm bright patch."""
    w, h = 32, 16
    img = np.zeros((h, w, 3), dtype=np.float32)
    for y in range(h):
        for x in range(w):
            t = (y + 0.5) / h
            img[y, x] = [0.3 + 0.7 * t, 0.5 + 0.5 * t, 1.0]
    img[3:5, 20:23] = [20.0, 16.0, 10.0]
    mi.Bitmap(img).write(os.path.join(HERE, "sky.exr"))


def checker_png():
    """An 8 x 8 checker whose quadrants differ in colour, so that a flipped
    or rotated lookup shows."""
    img = np.zeros((8, 8, 3), dtype=np.uint8)
    for y in range(8):
        for x in range(8):
            on = (x + y) % 2 == 0
            quad = (y >= 4) * 2 + (x >= 4)
            base = [(230, 60, 60), (60, 200, 60), (60, 60, 220), (220, 220, 220)][quad]
            img[y, x] = base if on else (30, 30, 30)
    mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(os.path.join(HERE, "checker.png"))


def checker_jpg():
    """metals.xml's floor: a 32 x 32 grey checker of flat 8 x 8 blocks.
    Grey keeps the chroma constant and a flat block is one DC coefficient,
    which JPEG stores exactly at any quality, so every decoder (Mitsuba's
    libjpeg, embertrace's image crate) reads the same bytes back."""
    levels = np.array([[40, 160, 90, 230], [230, 90, 160, 40],
                       [160, 40, 230, 90], [90, 230, 40, 160]], dtype=np.uint8)
    grey = np.kron(levels, np.ones((8, 8), dtype=np.uint8))
    img = np.repeat(grey[:, :, None], 3, axis=2)
    mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(os.path.join(HERE, "checker.jpg"))


def png(name, img):
    mi.Bitmap(img.astype(np.uint8), mi.Bitmap.PixelFormat.RGB).write(
        os.path.join(HERE, name))


def maps_pngs():
    """maps.xml's raw maps. normals.png (16 x 16): a tangent-space normal
    tilted up to about 14 degrees, varying along both axes, so a flipped
    tangent or bitangent shows; encoded (n + 1) / 2. roughness.png (8 x 8):
    GGX alpha from 0.05 to 0.5, rising along x and y. bumps.png (32 x 32):
    heights 0.5 + 0.5 sin(4 pi u) cos(2 pi v)."""
    n = np.zeros((16, 16, 3))
    for y in range(16):
        for x in range(16):
            sx = 0.2 * math.sin(2 * math.pi * (x + 0.5) / 16)
            sy = 0.15 * math.cos(2 * math.pi * (y + 0.5) / 16)
            v = np.array([sx, sy, 1.0])
            n[y, x] = np.round(255 * (v / np.linalg.norm(v) + 1) / 2)
    png("normals.png", n)
    r = np.zeros((8, 8, 3))
    for y in range(8):
        for x in range(8):
            r[y, x] = round(255 * (0.05 + 0.45 * (x + y) / 14))
    png("roughness.png", r)
    b = np.zeros((32, 32, 3))
    for y in range(32):
        for x in range(32):
            u, v = (x + 0.5) / 32, (y + 0.5) / 32
            b[y, x] = round(255 * (0.5 + 0.5 * math.sin(4 * math.pi * u) * math.cos(2 * math.pi * v)))
    png("bumps.png", b)
    # grazing.xml's steep.png (16 x 16): tilts up to 56 degrees, so a low
    # view falls below many mapped normals (flip_invalid_normals at work)
    n = np.zeros((16, 16, 3))
    for y in range(16):
        for x in range(16):
            sx = 1.2 * math.sin(2 * math.pi * (x + 0.5) / 16)
            sy = 0.9 * math.cos(2 * math.pi * (y + 0.5) / 16)
            v = np.array([sx, sy, 1.0])
            n[y, x] = np.round(255 * (v / np.linalg.norm(v) + 1) / 2)
    png("steep.png", n)


def cutout_png():
    """production.xml's mask opacity, read raw (16 x 16): solid (1) with two
    round holes (0) and a ring of opacity 0.5 around the second."""
    a = np.zeros((16, 16, 3))
    for y in range(16):
        for x in range(16):
            u, v = (x + 0.5) / 16, (y + 0.5) / 16
            d1 = math.hypot(u - 0.3, v - 0.35)
            d2 = math.hypot(u - 0.68, v - 0.62)
            if d1 < 0.16 or d2 < 0.12:
                a[y, x] = 0
            elif d2 < 0.24:
                a[y, x] = 128
            else:
                a[y, x] = 255
    png("cutout.png", a)


def render(name):
    path = os.path.join(HERE, name + ".xml")
    scene = mi.load_file(path)
    integrator = None
    if name in VOLPATH:
        depth = ET.parse(path).getroot().find("integrator/integer[@name='max_depth']")
        integrator = mi.load_dict({"type": "volpath", "max_depth": int(depth.get("value"))})
    passes = []
    for k in range(PASSES):
        img = mi.render(scene, spp=SPP, seed=1000 + k, integrator=integrator)
        passes.append(np.array(img, dtype=np.float64)[:, :, :3])
    stack = np.stack(passes)
    mean = stack.mean(axis=0)
    var_of_mean = stack.var(axis=0, ddof=1) / PASSES
    mi.Bitmap(mean.astype(np.float32)).write(os.path.join(HERE, name + ".ref.exr"))
    mi.Bitmap(var_of_mean.astype(np.float32)).write(os.path.join(HERE, name + ".var.exr"))
    return float(mean.mean())


if __name__ == "__main__":
    only = sys.argv[2:]
    unknown = [s for s in only if s not in SCENES]
    if unknown:
        sys.exit(f"unknown scenes {unknown} (expected some of {SCENES})")
    if not only:
        icosphere()
        floor_ply()
        sky_exr()
        checker_png()
    maps_pngs()
    cutout_png()
    checker_jpg()
    info = {"generator": "tests/data/mitsuba/make_references.py",
            "mitsuba_version": mi.__version__, "variant": mi.variant(),
            "passes": PASSES, "spp_per_pass": SPP, "volpath": sorted(VOLPATH), "mean": {}}
    if only:
        with open(os.path.join(HERE, "references.json")) as f:
            old = json.load(f)
        if (old["mitsuba_version"], old["passes"], old["spp_per_pass"]) != (
                info["mitsuba_version"], PASSES, SPP):
            sys.exit("references.json was made with other settings: render every scene")
        info["mean"] = old["mean"]
    for s in (only or SCENES):
        info["mean"][s] = render(s)
        print(s, info["mean"][s], flush=True)
    with open(os.path.join(HERE, "references.json"), "w") as out:
        json.dump(info, out, indent=1)
        out.write("\n")
