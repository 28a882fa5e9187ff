#!/usr/bin/env python3
"""Writes scenes/many-lights.obj and .mtl: 2048 small emissive triangles
(a jittered 32 x 64 grid over a 16 x 32 m floor, 0.25 to 1.2 m above it,
facing down, 0.12 m across) in eight materials of powers spread over 30:1,
and a few grey boxes standing on the floor. scenes/many-lights.toml places
it. The triangles are grouped by material, so that `convert` writes one
mesh per material. Deterministic: a fixed seed.

    python3 scenes/make_many_lights.py [NX NZ DIR]

With arguments, a grid of NX x NZ lights (the same floor, boxes and
powers) goes to DIR/many-lights.obj and .mtl instead: the scenes the
light sampler's `auto` threshold was measured on (README, "Many lights").
"""
import math
import os
import random

import sys

HERE = os.path.dirname(os.path.abspath(__file__))
NX, NZ = 32, 64
if len(sys.argv) == 4:
    NX, NZ, HERE = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
SIZE = 0.12
rng = random.Random(2018)

# eight light materials: warm to cold, emission 0.5 to 15
LIGHTS = []
for k in range(8):
    t = k / 7
    level = 0.5 * (30.0 ** t)
    rgb = (level * (1.0 - 0.4 * t), level * 0.9, level * (0.6 + 0.4 * t))
    LIGHTS.append(("light%d" % k, rgb))

tris = {name: [] for name, _ in LIGHTS}
for i in range(NX):
    for j in range(NZ):
        x = -8.0 + (i + 0.5 + rng.uniform(-0.3, 0.3)) * 16.0 / NX
        z = -16.0 + (j + 0.5 + rng.uniform(-0.3, 0.3)) * 32.0 / NZ
        y = rng.uniform(0.25, 1.2)
        a = rng.uniform(0.0, 2.0 * math.pi)
        corners = [(x + SIZE * math.cos(a + q * 2.0 * math.pi / 3.0), y,
                    z + SIZE * math.sin(a + q * 2.0 * math.pi / 3.0)) for q in range(3)]
        tris[LIGHTS[rng.randrange(8)][0]].append(corners)


def box(lo, hi):
    """The six faces of an axis-aligned box, wound to face out."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    p = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    quads = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 4, 7, 3), (1, 2, 6, 5), (3, 7, 6, 2), (0, 1, 5, 4)]
    out = []
    for a, b, c, d in quads:
        out += [(p[a], p[b], p[c]), (p[a], p[c], p[d])]
    return out


with open(os.path.join(HERE, "many-lights.obj"), "w") as f:
    f.write("# written by make_many_lights.py\nmtllib many-lights.mtl\n")
    n = 0

    def emit(faces, mat):
        global n
        f.write("usemtl %s\n" % mat)
        for t in faces:
            for v in t:
                f.write("v %.4f %.4f %.4f\n" % v)
            f.write("f %d %d %d\n" % (n + 1, n + 2, n + 3))
            n += 3

    # a floor of two triangles facing up
    emit([((-9, 0, -17), (9, 0, 17), (9, 0, -17)), ((-9, 0, -17), (-9, 0, 17), (9, 0, 17))], "floor")
    blocks = []
    for k in range(12):
        x, z = rng.uniform(-7, 7), rng.uniform(-15, 15)
        w, h = rng.uniform(0.2, 0.6), rng.uniform(0.2, 1.5)
        blocks += box((x - w, 0, z - w), (x + w, h, z + w))
    emit(blocks, "grey")
    for name, _ in LIGHTS:
        # corners at increasing angles from +x towards +z: the normal
        # (b - a) x (c - a) points down
        emit(tris[name], name)

with open(os.path.join(HERE, "many-lights.mtl"), "w") as f:
    f.write("# written by make_many_lights.py\n")
    f.write("\nnewmtl floor\nKd 0.6 0.6 0.6\n")
    f.write("\nnewmtl grey\nKd 0.4 0.45 0.5\n")
    for name, rgb in LIGHTS:
        f.write("\nnewmtl %s\nKd 0 0 0\nKe %.3f %.3f %.3f\n" % ((name,) + rgb))
