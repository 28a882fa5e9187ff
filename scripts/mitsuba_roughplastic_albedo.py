#!/usr/bin/env python3
"""Directional albedo of Mitsuba 3's `roughplastic` (its default linear
model, `nonlinear = false`), the reference for tests/rough_plastic.rs.

For each case (distribution, alpha, diffuse reflectance, incident angle) it
estimates the albedo, the integral of f cos over the hemisphere, as the mean
of Mitsuba's own importance-sampled weights `bsdf.sample(...)[1]` over N
uniform sample pairs, and prints one line per case:

    distribution alpha diffuse theta_deg albedo std_err

int_ior 1.49 and ext_ior 1.000277 (Mitsuba's defaults), specular
reflectance 1, sample_visible true. Run:

    pip install mitsuba numpy
    python3 scripts/mitsuba_roughplastic_albedo.py > tests/data/mitsuba/roughplastic_albedo.txt
"""
import math
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
N = int(sys.argv[1]) if len(sys.argv) > 1 else 100_000
CASES = [
    (dist, alpha, rho, theta)
    for dist in ("beckmann", "ggx")
    for alpha in (0.1, 0.3, 0.6)
    for rho in (1.0, 0.5)
    for theta in (0.0, 45.0, 75.0)
]

print(f"# Mitsuba {mi.__version__} roughplastic albedo, {N} samples a case (scripts/mitsuba_roughplastic_albedo.py)")
print("# distribution alpha diffuse theta_deg albedo std_err")
rng = np.random.default_rng(20261127)
for dist, alpha, rho, theta in CASES:
    bsdf = mi.load_dict({
        "type": "roughplastic",
        "distribution": dist,
        "alpha": alpha,
        "diffuse_reflectance": {"type": "rgb", "value": [rho, rho, rho]},
    })
    si = mi.SurfaceInteraction3f()
    si.sh_frame = mi.Frame3f([0, 0, 1])
    t = math.radians(theta)
    si.wi = mi.Vector3f(math.sin(t), 0.0, math.cos(t))
    ctx = mi.BSDFContext()
    u = rng.random((N, 3))
    w = np.empty(N)
    for i in range(N):
        _, weight = bsdf.sample(ctx, si, float(u[i, 0]), mi.Point2f(float(u[i, 1]), float(u[i, 2])))
        w[i] = weight[0]
    print(f"{dist} {alpha} {rho} {theta} {w.mean():.6f} {w.std(ddof=1) / math.sqrt(N):.6f}")
    sys.stdout.flush()
