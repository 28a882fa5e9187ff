#!/usr/bin/env python3
"""Mean square error per pixel of two or more embertrace builds, by seed.

Both samplers are unbiased, so a pixel's variance over seeds is its mean
square error. For each scene and spp, renders K seeds with each binary,
sums the per-pixel variance over the image, and prints each binary's sum
over the first's with a 95 % interval from resampling 16 x 16 blocks, the
same ratio without the 2 % of blocks with the largest variance, and the
median block's ratio (rare bright paths, which no sampler stratifies, rule
the whole-image ratio on scenes like `materials`).

    python3 benches/studies/sampler_variance.py OUT.json \
        "cornell-box:256:256,materials:256:128:-m+1" "16,64,256" 8 BIN_OLD BIN_NEW

A scene is name:width:height[:extra+flags]; SEED0 (default 1000) sets the
first seed. Used for the padded Sobol index shuffle (branch owen-shuffle).
"""
import json
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def read_pfm(path):
    """An RGB PFM as float64, rows from the top (PFM stores them bottom-up)."""
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return a[::-1].astype(np.float64)


def main():
    out, scenes, spps, k = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    bins = sys.argv[5:]
    seed0 = int(os.environ.get("SEED0", "1000"))
    rng = np.random.default_rng(1)
    res = {}
    tmp = f"/tmp/sampler-variance-{os.getpid()}.pfm"
    for spec in scenes.split(","):
        name, w, h, *extra = spec.split(":")
        extra = extra[0].split("+") if extra else []
        tag = name + ("[" + " ".join(extra) + "]" if extra else "")
        for spp in map(int, spps.split(",")):
            key = f"{tag}@{spp}"
            blocks = {}
            for b in bins:
                imgs = []
                for s in range(k):
                    subprocess.run([b, "render", os.path.join(ROOT, "scenes", name + ".toml"),
                                    "-r", w, h, "-s", str(spp), "--seed", str(seed0 + s),
                                    "-o", tmp, "-q", *extra], check=True)
                    imgs.append(read_pfm(tmp))
                var = np.stack(imgs).var(axis=0, ddof=1).mean(axis=2)
                hh, ww = var.shape[0] // 16 * 16, var.shape[1] // 16 * 16
                blocks[b] = var[:hh, :ww].reshape(hh // 16, 16, ww // 16, 16).sum(axis=(1, 3)).ravel()
                res.setdefault(key, {})[b] = {"mse": float(var.mean())}
            base = blocks[bins[0]]
            for b in bins[1:]:
                r = blocks[b].sum() / base.sum()
                idx = rng.integers(0, len(base), (2000, len(base)))
                lo, hi = np.percentile(blocks[b][idx].sum(1) / base[idx].sum(1), [2.5, 97.5])
                keep = (blocks[b] + base) < np.percentile(blocks[b] + base, 98)
                trimmed = blocks[b][keep].sum() / base[keep].sum()
                med = float(np.median(blocks[b] / base))
                res[key][b].update(ratio=[float(r), float(lo), float(hi)], trimmed=float(trimmed), median_block=med)
                print(f"{key} {os.path.basename(b)} / {os.path.basename(bins[0])}: MSE ratio {r:.4f} "
                      f"[{lo:.4f}, {hi:.4f}], trimmed {trimmed:.4f}, median block {med:.4f}", flush=True)
            with open(out, "w") as f:
                json.dump(res, f, indent=1)
    os.remove(tmp)


if __name__ == "__main__":
    main()
