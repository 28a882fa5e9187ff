#!/usr/bin/env python3
"""Writes scenes/instances.toml: a field of 1000 rocks, each an instance of
one procedural rock of about 20,000 triangles (stored once), turned, scaled
and tilted by a fixed pseudo-random sequence, on a procedural terrain, under
a sky and a sun. It is the instancing benchmark: 20 million triangles
placed, 20 thousand stored.

Run from any directory: python3 scenes/make_instances.py
"""
import math
import os

here = os.path.dirname(os.path.abspath(__file__))
N_X, N_Z = 40, 25
SPACING = 0.5

state = 12345


def rand():
    """xorshift32 in [0, 1): the same field on every machine."""
    global state
    state ^= (state << 13) & 0xFFFFFFFF
    state ^= state >> 17
    state ^= (state << 5) & 0xFFFFFFFF
    return state / 2**32


out = ["""# 1000 instances of one procedural rock (about 20k triangles, stored
# once) on a terrain: 20 million triangles placed. Written by
# scenes/make_instances.py; edit that, not this.

[camera]
origin = [0.0, 3.2, 9.5]
target = [0.0, 0.0, 0.0]
fov_y  = 45.0

[film]
resolution = [512, 384]

[render]
spp = 16
max_depth = 8

[[light]]
type = "environment"
radiance = [0.35, 0.45, 0.6]

[[light]]
type = "directional"
direction = [-0.5, -0.8, -0.3]
irradiance = [2.5, 2.3, 2.0]

[[procedural]]
type = "terrain"
triangles = 20_000
displacement = 0.02
seed = 7
transform = { scale = [14.0, 1.0, 14.0] }
material = { diffuse = [0.45, 0.42, 0.38] }

[[procedural]]
name = "rock"
instance_only = true
type = "sphere"
triangles = 20_000
displacement = 0.3
seed = 11
material = { diffuse = [0.6, 0.55, 0.5] }
"""]
for i in range(N_X):
    for j in range(N_Z):
        x = (i - (N_X - 1) / 2) * SPACING + (rand() - 0.5) * 0.3
        z = (j - (N_Z - 1) / 2) * SPACING + (rand() - 0.5) * 0.3
        s = 0.08 + 0.12 * rand()
        sy = s * (0.6 + 0.6 * rand())
        yaw = 360.0 * rand()
        tilt = 20.0 * (rand() - 0.5)
        # row-major: R_y(yaw) * R_x(tilt) * S, then translate
        cy, sy_ = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
        cx, sx_ = math.cos(math.radians(tilt)), math.sin(math.radians(tilt))
        r = [[cy, sy_ * sx_, sy_ * cx],
             [0.0, cx, -sx_],
             [-sy_, cy * sx_, cy * cx]]
        scale = [s, sy, s]
        m = [[r[a][b] * scale[b] for b in range(3)] for a in range(3)]
        t = [x, 0.6 * sy, z]
        rows = [m[0] + [t[0]], m[1] + [t[1]], m[2] + [t[2]], [0.0, 0.0, 0.0, 1.0]]
        nums = ", ".join(f"{v:.6g}" for row in rows for v in row)
        out.append(f'\n[[instance]]\nof = "rock"\nmatrix = [{nums}]\n')
with open(os.path.join(here, "instances.toml"), "w") as f:
    f.write("".join(out))
