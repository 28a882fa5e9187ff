#!/usr/bin/env python3
"""Writes the alpha-mask scene's files: scenes/leaf.png (64 x 64 RGBA: a
green leaf whose outline and a few holes are cut by the alpha channel),
scenes/panel.obj (a unit quad with texture coordinates) and
scenes/cut-outs.toml: the empty Cornell box with a hedge of 48 leaf cards
(instances of one masked panel, turned and tilted by a fixed sequence) and
a screen of constant opacity 0.5 in front of the back wall.

Run from any directory: python3 scenes/make_cut_outs.py
"""
import math
import os
import struct
import zlib

here = os.path.dirname(os.path.abspath(__file__))
N = 64


def leaf_alpha(x, y):
    """Opacity of texel centre (x, y) in [0, 1]^2, y up: an ellipse-like
    leaf along the diagonal with three round holes, hard-edged."""
    u, v = x - 0.5, y - 0.5
    a, b = (u + v) / math.sqrt(2), (v - u) / math.sqrt(2)
    inside = (a / 0.48) ** 2 + (b / (0.22 * (1.0 - abs(a) / 0.6))) ** 2 < 1.0
    for cx, cy in [(0.35, 0.4), (0.55, 0.6), (0.7, 0.72)]:
        if (x - cx) ** 2 + (y - cy) ** 2 < 0.045 ** 2:
            inside = False
    return 255 if inside else 0


def png_rgba(path, w, h, pixel):
    rows = b""
    for j in range(h):
        row = bytearray([0])
        for i in range(w):
            row += bytes(pixel(i, j))
        rows += bytes(row)

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    head = struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", head)
    data += chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(data)


def leaf_pixel(i, j):
    x, y = (i + 0.5) / N, 1.0 - (j + 0.5) / N
    vein = abs((x - 0.5) - (y - 0.5)) < 0.02
    g = 120 if vein else 170 + int(40 * x)
    return (60, g, 40, leaf_alpha(x, y))


png_rgba(os.path.join(here, "leaf.png"), N, N, leaf_pixel)

with open(os.path.join(here, "panel.obj"), "w") as f:
    f.write("# A unit quad in the xy plane facing +z, texture coordinates 0..1\n")
    f.write("# (scenes/make_cut_outs.py)\n")
    for x, y in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]:
        f.write(f"v {x} {y} 0\n")
    for u, v in [(0, 0), (1, 0), (1, 1), (0, 1)]:
        f.write(f"vt {u} {v}\n")
    f.write("f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")

state = 2024


def rand():
    """xorshift32 in [0, 1): the same hedge on every machine."""
    global state
    state ^= (state << 13) & 0xFFFFFFFF
    state ^= state >> 17
    state ^= (state << 5) & 0xFFFFFFFF
    return state / 2**32


out = ["""# Alpha masks: a hedge of 48 leaf cards (instances of one quad whose
# alpha comes from leaf.png's alpha channel) and a screen of constant
# opacity 0.5, in the empty Cornell box. Written by
# scenes/make_cut_outs.py; see the README's "Alpha masks".

[camera]
origin = [0.0, 1.0, 3.9]
target = [0.0, 1.0, 0.0]
up     = [0.0, 1.0, 0.0]
fov_y  = 39.3

[film]
resolution = [512, 512]

[render]
spp = 64
max_depth = 64

[[mesh]]
file = "cornell-empty.obj"

# the screen: half the rays through it pass
[[mesh]]
file = "panel.obj"
alpha = 0.5
transform = { scale = [1.2, 0.8, 1.0], translate = [0.3, 1.1, -0.7] }
material = { diffuse = [0.2, 0.3, 0.8] }

# the leaf card, stored once, placed by the instances below
[[mesh]]
file = "panel.obj"
name = "leaf"
instance_only = true
alpha = "leaf.png"
material = { texture = "leaf.png" }
"""]
for k in range(48):
    x = -0.8 + 1.6 * rand()
    y = 0.15 + 0.9 * rand()
    z = -0.3 + 0.9 * rand()
    # about an axis near y, so the cards turn and tilt
    ax, az = -0.6 + 1.2 * rand(), -0.6 + 1.2 * rand()
    angle = -70.0 + 140.0 * rand()
    s = 0.25 + 0.2 * rand()
    out.append(f"""
[[instance]]
of = "leaf"
transform = {{ scale = {s:.4f}, rotate = [{ax:.4f}, 1.0, {az:.4f}, {angle:.3f}], translate = [{x:.4f}, {y:.4f}, {z:.4f}] }}
""")
with open(os.path.join(here, "cut-outs.toml"), "w") as f:
    f.write("".join(out))
