#!/usr/bin/env python3
"""Writes scenes/cornell-box.pbrt: the Cornell box of scenes/cornell-box.toml
(geometry from cornell-box.obj, materials from cornell-box.mtl, the camera of
the TOML) as a pbrt-v4 scene.

pbrt's camera space is left-handed (its LookAt puts the image's right along
up x view); `Scale -1 1 1` before the LookAt turns it into the right-handed
view the TOML describes, as exporters to pbrt do. The light is a
`diffuse` area light of radiance Ke emitting from the quad's front
(counter-clockwise winding); every surface is `diffuse` with reflectance Kd.
fov is pbrt's, for the shorter image side (the image is square).

Run from anywhere: python3 scenes/make_cornell_pbrt.py
"""
import os
import importlib.util

here = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("gltf", os.path.join(here, "make_cornell_gltf.py"))
gltf = importlib.util.module_from_spec(spec)
spec.loader.exec_module(gltf)


def nums(v):
    return " ".join(f"{x:.9g}" for x in v)


def main():
    mats = gltf.read_mtl(os.path.join(here, "cornell-box.mtl"))
    verts, groups = gltf.read_obj(os.path.join(here, "cornell-box.obj"))
    out = [
        "# The Cornell box of scenes/cornell-box.toml as a pbrt-v4 scene.",
        "# Written by scenes/make_cornell_pbrt.py; do not edit.",
        "Scale -1 1 1",
        "LookAt 0 1 3.9  0 1 0  0 1 0",
        'Camera "perspective" "float fov" [ 39.3 ]',
        'Film "rgb" "integer xresolution" [ 512 ] "integer yresolution" [ 512 ] "string filename" [ "cornell-box.exr" ]',
        'Sampler "zsobol" "integer pixelsamples" [ 64 ]',
        'Integrator "path" "integer maxdepth" [ 64 ]',
        "WorldBegin",
    ]
    for name, tris in groups:
        used = sorted({i for t in tris for i in t})
        remap = {v: k for k, v in enumerate(used)}
        m = mats[name]
        out.append("AttributeBegin")
        if max(m["Ke"]) > 0:
            out.append(f'  AreaLightSource "diffuse" "rgb L" [ {nums(m["Ke"])} ]')
        out.append(f'  Material "diffuse" "rgb reflectance" [ {nums(m["Kd"])} ]')
        out.append('  Shape "trianglemesh"')
        out.append(f'    "point3 P" [ {nums([c for v in used for c in verts[v]])} ]')
        out.append(f'    "integer indices" [ {" ".join(str(remap[i]) for t in tris for i in t)} ]')
        out.append("AttributeEnd")
    with open(os.path.join(here, "cornell-box.pbrt"), "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
