#!/usr/bin/env python3
"""Writes the race's hard-lighting scenes as Mitsuba 3 XML, so that both
renderers read the same file:

- door-ajar.xml: two rooms joined by a doorway whose door stands ajar
  (15 degrees); the only light is a small ceiling panel in the far room, so
  the camera's room is lit through the gap alone (Veach's door scene,
  re-made here).
- many-lights.xml: a town square at night: 400 lamps (small emissive
  squares facing down, on a 20 x 20 grid over a floor of blocks) whose
  powers span three decades (log-uniform from 1 to 1000, in a fixed
  pseudo-random order), so choosing lights by power or by importance at
  the shading point matters.
- glossy-env.xml: glossy interreflections under an environment map: a
  corner of two rough-conductor walls (aluminium, alpha 0.05) over a
  rough gold floor (alpha 0.1), holding a rough-plastic sphere and a
  rough-copper one, lit only by `scenes/sky.exr`. The light that reaches
  most pixels has bounced between glossy surfaces, where the BSDF's lobe
  rather than the light decides which directions matter.

    python3 benches/race/hard/make_hard_scenes.py   # rewrites the .xml files

The film's reconstruction filter is a box, as embertrace's is (Mitsuba's
default Gaussian would spread each sample over a pixel's neighbours and
lower the per-pixel error the race compares). Every `$name` has a
`<default>`, so `mi.load_file(path, spp=..., ...)` and
`embertrace render path` read the same scene; the race overrides the
resolution and the sampler.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def quad(corner, e1, e2, bsdf, emitter=None, comment=None):
    """A `rectangle` whose corners are corner, corner+e1, corner+e1+e2 and
    corner+e2, facing e1 x e2."""
    cx = [corner[i] + 0.5 * (e1[i] + e2[i]) for i in range(3)]
    n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
    ln = math.sqrt(sum(c * c for c in n))
    n = [c / ln for c in n]
    rows = [[0.5 * e1[i], 0.5 * e2[i], n[i], cx[i]] for i in range(3)] + [[0, 0, 0, 1]]
    m = " ".join(f"{v:.6g}" for r in rows for v in r)
    out = []
    if comment:
        out.append(f"    <!-- {comment} -->")
    out.append('    <shape type="rectangle">')
    out.append(f'        <transform name="to_world"><matrix value="{m}"/></transform>')
    out.append(f'        <ref id="{bsdf}"/>')
    if emitter:
        out.append(f'        <emitter type="area"><rgb name="radiance" value="{emitter}"/></emitter>')
    out.append("    </shape>")
    return "\n".join(out)


def header(w, h, spp, max_depth, origin, target, fov):
    o = ", ".join(f"{v:g}" for v in origin)
    t = ", ".join(f"{v:g}" for v in target)
    return f"""<scene version="3.0.0">
    <default name="spp" value="{spp}"/>
    <default name="width" value="{w}"/>
    <default name="height" value="{h}"/>
    <default name="max_depth" value="{max_depth}"/>
    <default name="sampler" value="independent"/>
    <integrator type="path">
        <integer name="max_depth" value="$max_depth"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world">
            <lookat origin="{o}" target="{t}" up="0, 1, 0"/>
        </transform>
        <film type="hdrfilm">
            <integer name="width" value="$width"/>
            <integer name="height" value="$height"/>
            <rfilter type="box"/>
        </film>
        <sampler type="$sampler">
            <integer name="sample_count" value="$spp"/>
        </sampler>
    </sensor>
"""


def door_ajar():
    # rooms: x in [0, 4], y in [0, 2.5]; the camera's room z in [0, 4], the
    # lit room z in [-3, 0]; the wall at z = 0 has a doorway x in [1.5, 2.5],
    # y in [0, 2]
    W, H, Z0, Z1 = 4.0, 2.5, -3.0, 4.0
    dx0, dx1, dh = 1.5, 2.5, 2.0
    angle = math.radians(15.0)
    parts = [header(128, 128, 64, 24, (3.4, 1.4, 3.8), (1.6, 0.9, 0.0), 65)]
    parts.append("""    <bsdf type="twosided" id="wall">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.75, 0.73, 0.70"/></bsdf>
    </bsdf>
    <bsdf type="twosided" id="floor">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.45, 0.35, 0.25"/></bsdf>
    </bsdf>
    <bsdf type="twosided" id="door">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.55, 0.25, 0.15"/></bsdf>
    </bsdf>
    <bsdf type="diffuse" id="black">
        <rgb name="reflectance" value="0, 0, 0"/>
    </bsdf>""")
    L = Z1 - Z0
    parts.append(quad((0, 0, Z0), (0, 0, L), (W, 0, 0), "floor", comment="floor, both rooms"))
    parts.append(quad((0, H, Z0), (W, 0, 0), (0, 0, L), "wall", comment="ceiling"))
    parts.append(quad((0, 0, Z0), (0, H, 0), (0, 0, L), "wall", comment="left wall"))
    parts.append(quad((W, 0, Z0), (0, 0, L), (0, H, 0), "wall", comment="right wall"))
    parts.append(quad((0, 0, Z0), (W, 0, 0), (0, H, 0), "wall", comment="far room's back wall"))
    parts.append(quad((0, 0, Z1), (0, H, 0), (W, 0, 0), "wall", comment="wall behind the camera"))
    parts.append(quad((0, 0, 0), (dx0, 0, 0), (0, H, 0), "wall", comment="dividing wall, left of the door"))
    parts.append(quad((dx1, 0, 0), (W - dx1, 0, 0), (0, H, 0), "wall", comment="dividing wall, right"))
    parts.append(quad((dx0, dh, 0), (dx1 - dx0, 0, 0), (0, H - dh, 0), "wall", comment="above the door"))
    # the door: hinged at x = dx0, swung 15 degrees into the lit room
    width = dx1 - dx0
    e1 = (width * math.cos(angle), 0, -width * math.sin(angle))
    parts.append(quad((dx0, 0, 0), e1, (0, dh, 0), "door", comment="the door, ajar"))
    # the light: a 0.5 m panel on the lit room's ceiling, far from the door,
    # facing down
    parts.append(quad((3.0, H - 0.01, -2.6), (0.5, 0, 0), (0, 0, 0.5), "black",
                      emitter="400, 370, 300", comment="the only light"))
    parts.append("</scene>\n")
    return "\n".join(parts)


def cube(centre, half, bsdf):
    """A `cube` ([-1, 1]^3) scaled to half-extents `half` at `centre`."""
    c = ", ".join(f"{v:g}" for v in centre)
    h = ", ".join(f"{v:g}" for v in half)
    return f"""    <shape type="cube">
        <transform name="to_world"><scale value="{h}"/><translate value="{c}"/></transform>
        <ref id="{bsdf}"/>
    </shape>"""


def many_lights():
    parts = [header(256, 256, 64, 24, (0.0, 14.0, 16.0), (0.0, 0.0, 0.0), 50)]
    parts.append("""    <bsdf type="twosided" id="ground">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
    </bsdf>
    <bsdf type="twosided" id="block">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf>
    </bsdf>
    <bsdf type="diffuse" id="black">
        <rgb name="reflectance" value="0, 0, 0"/>
    </bsdf>""")
    parts.append(quad((-12, 0, 12), (24, 0, 0), (0, 0, -24), "ground", comment="the ground"))
    # a fixed linear congruential sequence: the same scene on every machine
    state = 12345

    def rand():
        nonlocal state
        state = (1103515245 * state + 12345) % (1 << 31)
        return state / (1 << 31)

    n = 20
    for i in range(n):
        for j in range(n):
            x = -10 + 20 * (i + 0.5) / n
            z = -10 + 20 * (j + 0.5) / n
            power = 10 ** (3 * rand())
            height = 0.6 + 1.4 * rand()
            if (i % 4, j % 4) == (1, 1):
                parts.append(cube((x + 0.5, 0.6, z + 0.5), (0.45, 0.6, 0.45), "block"))
            # a 0.1 m square lamp facing down
            parts.append(quad((x - 0.05, height, z - 0.05), (0.1, 0, 0), (0, 0, 0.1), "black",
                              emitter=f"{power:.4g}, {0.8 * power:.4g}, {0.6 * power:.4g}"))
    parts.append("</scene>\n")
    return "\n".join(parts)


def sphere(centre, radius, bsdf):
    c = ", ".join(f"{v:g}" for v in centre)
    return f"""    <shape type="sphere">
        <point name="center" value="{c}"/>
        <float name="radius" value="{radius:g}"/>
        <ref id="{bsdf}"/>
    </shape>"""


def rough_conductor(ident, material, alpha):
    """A GGX rough conductor of one of Mitsuba's named metals."""
    return f"""    <bsdf type="roughconductor" id="{ident}">
        <string name="material" value="{material}"/>
        <string name="distribution" value="ggx"/>
        <float name="alpha" value="{alpha}"/>
    </bsdf>"""


def glossy_env():
    parts = [header(128, 128, 64, 24, (2.6, 1.3, 2.6), (0.0, 0.45, 0.0), 50)]
    parts.append(rough_conductor("wall", "Al", "0.05"))
    parts.append(rough_conductor("floor", "Au", "0.1"))
    parts.append(rough_conductor("copper", "Cu", "0.2"))
    parts.append("""    <bsdf type="roughplastic" id="plastic">
        <string name="distribution" value="ggx"/>
        <float name="alpha" value="0.1"/>
        <rgb name="diffuse_reflectance" value="0.1, 0.25, 0.6"/>
    </bsdf>
    <emitter type="envmap">
        <string name="filename" value="../../../scenes/sky.exr"/>
    </emitter>""")
    # the corner: walls on x = 0 and z = 0 facing inwards, the floor y = 0,
    # 2 m each way
    parts.append(quad((0, 0, 0), (0, 0, 2), (2, 0, 0), "floor", comment="rough gold floor"))
    parts.append(quad((0, 0, 0), (0, 1.5, 0), (0, 0, 2), "wall", comment="wall on x = 0"))
    parts.append(quad((0, 0, 0), (2, 0, 0), (0, 1.5, 0), "wall", comment="wall on z = 0"))
    parts.append(sphere((0.55, 0.35, 0.9), 0.35, "plastic"))
    parts.append(sphere((1.0, 0.3, 0.4), 0.3, "copper"))
    parts.append("</scene>\n")
    return "\n".join(parts)


def main():
    with open(os.path.join(HERE, "door-ajar.xml"), "w") as f:
        f.write(door_ajar())
    with open(os.path.join(HERE, "many-lights.xml"), "w") as f:
        f.write(many_lights())
    with open(os.path.join(HERE, "glossy-env.xml"), "w") as f:
        f.write(glossy_env())


if __name__ == "__main__":
    main()
