#!/usr/bin/env python3
"""Reference values for embertrace's environment map, from Mitsuba 3.

Writes a small synthetic equirectangular map (tests/data/mitsuba_envmap.exr,
16 x 8 linear RGB, values from a fixed-seed generator) and evaluates Mitsuba
3's `envmap` emitter (variant scalar_rgb, scale 1) along a fixed set of
directions: the six axis directions and 58 directions drawn once from a
fixed-seed normal distribution. tests/data/mitsuba_envmap.json holds the map's
pixels, the directions and Mitsuba's radiance for each; tests/lights.rs asserts
that embertrace's lookup gives the same values.

Run from the repository root:
    pip install mitsuba==3.9.1 numpy
    python3 scripts/mitsuba_envmap_reference.py
"""

import json
import os

import mitsuba as mi
import numpy as np

W, H = 16, 8
OUT_DIR = os.path.join("tests", "data")


def main():
    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(20240607)
    pixels = rng.uniform(0.05, 4.0, size=(H, W, 3)).astype(np.float32)
    exr_path = os.path.join(OUT_DIR, "mitsuba_envmap.exr")
    mi.Bitmap(pixels).write(exr_path)

    emitter = mi.load_dict({"type": "envmap", "filename": exr_path})

    axes = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    rand = rng.normal(size=(58, 3))
    rand /= np.linalg.norm(rand, axis=1, keepdims=True)
    dirs = np.concatenate([np.array(axes, dtype=np.float64), rand]).astype(np.float32)

    samples = []
    for d in dirs:
        si = mi.SurfaceInteraction3f()
        # eval looks along -wi: wi points from the sky back to the scene
        si.wi = mi.Vector3f(-d[0], -d[1], -d[2])
        value = emitter.eval(si)
        samples.append(
            {
                "d": [float(c) for c in d],
                "radiance": [float(value[0]), float(value[1]), float(value[2])],
            }
        )

    doc = {
        "generator": "scripts/mitsuba_envmap_reference.py",
        "mitsuba_version": mi.__version__,
        "variant": "scalar_rgb",
        "exr": "mitsuba_envmap.exr",
        "width": W,
        "height": H,
        "pixels_rgb_top_row_first": [float(v) for v in pixels.reshape(-1)],
        "samples": samples,
    }
    with open(os.path.join(OUT_DIR, "mitsuba_envmap.json"), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
