#!/usr/bin/env python3
"""embertrace's reading of Mitsuba 3's `roughplastic` against Mitsuba itself.

A rough plastic plane (Beckmann, alpha 0.15, linear base, diffuse
0.6 / 0.08 / 0.05) fills a 32 x 32 view at 45 degrees under a white
constant sky, so each pixel shows the BSDF's directional albedo; both
renderers read the same XML. Prints each side's image mean per channel
with its standard error over 8 seeds of 1024 spp, and their ratio.

    python3 benches/studies/roughplastic_gap.py   # about a minute on 2 cores
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "benches", "race"))
sys.path.insert(0, HERE)
# the race's module points Dr.Jit at LLVM 19 before it loads Mitsuba
from race import mi  # noqa: E402
from sampler_variance import read_pfm  # noqa: E402

SCENE = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="3"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="10"/>
    <transform name="to_world"><lookat origin="0, -3, 3" target="0, 0, 0" up="0, 0, 1"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
    <sampler type="independent"><integer name="sample_count" value="1024"/></sampler>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
  <shape type="rectangle">
    <transform name="to_world"><scale value="3"/></transform>
    <bsdf type="roughplastic">
      <string name="distribution" value="beckmann"/>
      <float name="alpha" value="0.15"/>
      <rgb name="diffuse_reflectance" value="0.6, 0.08, 0.05"/>
    </bsdf>
  </shape>
</scene>
"""
SEEDS = 8
SPP = 1024


def main():
    binary = os.path.join(ROOT, "target", "release", "embertrace")
    with tempfile.TemporaryDirectory() as tmp:
        xml = os.path.join(tmp, "roughplastic.xml")
        with open(xml, "w") as f:
            f.write(SCENE)
        mi.set_variant("llvm_ad_rgb")
        scene = mi.load_file(xml)
        theirs = np.array([
            np.array(mi.render(scene, seed=s, spp=SPP))[..., :3].reshape(-1, 3).mean(0)
            for s in range(SEEDS)
        ])
        ours = []
        for s in range(SEEDS):
            out = os.path.join(tmp, "ours.pfm")
            subprocess.run([binary, "render", xml, "-s", str(SPP), "--seed", str(s),
                            "-o", out, "-q"], check=True)
            ours.append(read_pfm(out).reshape(-1, 3).mean(0))
        ours = np.array(ours)
    for name, a in (("mitsuba", theirs), ("embertrace", ours)):
        se = a.std(0, ddof=1) / np.sqrt(len(a))
        print(f"{name:10} mean {np.round(a.mean(0), 5)}  standard error {np.round(se, 6)}")
    print(f"embertrace / mitsuba: {np.round(ours.mean(0) / theirs.mean(0), 4)}")


if __name__ == "__main__":
    main()
