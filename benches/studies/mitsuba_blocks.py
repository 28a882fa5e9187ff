#!/usr/bin/env python3
"""Block-by-block comparison of an embertrace build with Mitsuba 3 on one
Mitsuba XML scene, with many more passes than tests/mitsuba.rs takes, to
tell a systematic difference from noise.

Mitsuba (scalar_rgb) renders P passes of SPP samples; embertrace renders
P * SPP / 96 passes of 96 spp; both with different seeds per pass. Prints,
per 8 x 8 block, channel 0, the relative difference and its z-score (the
standard error from both sides' spread over passes).

    pip install mitsuba numpy
    BIN=target/release/embertrace python3 benches/studies/mitsuba_blocks.py \
        tests/data/mitsuba/production.xml 8 768

Edited copies of a scene (an emitter or a shape removed) go in a scratch
folder next to copies of its assets.
"""
import os
import subprocess
import sys

import mitsuba as mi
import numpy as np

from sampler_variance import read_pfm

mi.set_variant("scalar_rgb")


def main():
    xml, passes, spp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    binary = os.environ.get("BIN", "target/release/embertrace")
    scene = mi.load_file(xml)
    theirs = np.stack([np.array(mi.render(scene, spp=spp, seed=500 + k), dtype=np.float64)[:, :, :3]
                       for k in range(passes)])
    tmp = f"/tmp/mitsuba-blocks-{os.getpid()}.pfm"
    ours = []
    for k in range(passes * spp // 96):
        subprocess.run([binary, "render", xml, "-s", "96", "--seed", str(50000 + k), "-o", tmp, "-q"],
                       check=True)
        ours.append(read_pfm(tmp))
    os.remove(tmp)
    ours = np.stack(ours)
    h, w = theirs.shape[1:3]

    def blocks(x):
        return x.reshape(x.shape[0], h // 8, 8, w // 8, 8, 3).mean(axis=(2, 4))

    bo, bt = blocks(ours), blocks(theirs)
    d = bo.mean(0) - bt.mean(0)
    se = np.sqrt(bo.var(0, ddof=1) / len(bo) + bt.var(0, ddof=1) / len(bt))
    np.set_printoptions(precision=3, suppress=True, linewidth=200)
    with np.errstate(invalid="ignore", divide="ignore"):
        print("relative difference, channel 0 (rows top to bottom):")
        print((d / bt.mean(0))[:, :, 0])
        print("z, channel 0:")
        print((d / se)[:, :, 0])
    print("whole image, relative:", (ours.mean() - theirs.mean()) / theirs.mean())


if __name__ == "__main__":
    main()
