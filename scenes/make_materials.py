#!/usr/bin/env python3
"""Writes the assets of scenes/materials.toml:

- sky.exr: a 128 x 64 equirectangular sky in Mitsuba 3's convention (+y up,
  row 0 at the zenith, u = atan2(d.x, -d.z) / 2pi): a blue gradient above the
  horizon, a dim brown ground below, and a sun of angular radius 4 degrees,
  35 degrees above the horizon, with radiance 40 (linear RGB);
- checker.png: a 64 x 64 grey checkerboard (8 x 8 squares, sRGB);
- floor.obj: a 12 x 12 ground quad at y = 0 with texture coordinates that
  repeat the checker 6 times.

Needs numpy and mitsuba (pip install mitsuba) for the EXR; run it from any
directory. The outputs are committed, so rendering the scene needs neither.
"""
import math
import os
import struct
import zlib

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))

# --- sky.exr ---
W, H = 128, 64
sun_elev, sun_azim, sun_radius = math.radians(35.0), math.radians(-60.0), math.radians(4.0)
sun = np.array([
    math.sin(sun_azim) * math.cos(sun_elev),
    math.sin(sun_elev),
    -math.cos(sun_azim) * math.cos(sun_elev),
])
sky = np.zeros((H, W, 3), dtype=np.float32)
for y in range(H):
    theta = math.pi * y / (H - 1)  # Mitsuba's rows sit at v = y / (h - 1)
    for x in range(W):
        phi = 2.0 * math.pi * (x + 0.5) / W
        d = np.array([math.sin(phi) * math.sin(theta), math.cos(theta),
                      -math.cos(phi) * math.sin(theta)])
        if d[1] >= 0.0:
            t = math.sqrt(d[1])
            c = (1 - t) * np.array([0.95, 0.97, 1.0]) + t * np.array([0.25, 0.45, 0.95])
        else:
            c = np.array([0.22, 0.18, 0.14])
        if math.acos(max(-1.0, min(1.0, float(d @ sun)))) < sun_radius:
            c = np.array([40.0, 36.0, 30.0])
        sky[y, x] = c

import mitsuba as mi  # noqa: E402

mi.set_variant("scalar_rgb")
mi.Bitmap(sky, pixel_format=mi.Bitmap.PixelFormat.RGB).write(os.path.join(here, "sky.exr"))


# --- checker.png (8-bit sRGB, written with zlib) ---
def png(path, w, h, rows):
    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


N = 64
rows = []
for y in range(N):
    row = []
    for x in range(N):
        v = 200 if ((x // 8) + (y // 8)) % 2 == 0 else 90
        row += [v, v, v]
    rows.append(row)
png(os.path.join(here, "checker.png"), N, N, rows)

# --- floor.obj ---
with open(os.path.join(here, "floor.obj"), "w") as f:
    f.write("# A 12 x 12 ground quad, written by scenes/make_materials.py\n")
    for x, z in [(-6, 6), (6, 6), (6, -6), (-6, -6)]:
        f.write("v %d 0 %d\n" % (x, z))
    for u, v in [(0, 0), (6, 0), (6, 6), (0, 6)]:
        f.write("vt %d %d\n" % (u, v))
    f.write("f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")
