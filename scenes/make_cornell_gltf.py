#!/usr/bin/env python3
"""Writes scenes/cornell-box.gltf and scenes/cornell-box.glb: the Cornell box
of scenes/cornell-box.toml (geometry from cornell-box.obj, materials from
cornell-box.mtl, the camera of the TOML) as glTF 2.0, the .gltf with its
buffer in a data: URI, the .glb with it in the binary chunk.

The materials are Lambertian, as the OBJ's are: metallic 0 and
KHR_materials_specular's specularFactor 0 make the glTF BRDF exactly
base_color / pi (the specification's Appendix B with the specular layer's
weight 0). The light's radiance Ke is emissiveFactor times
KHR_materials_emissive_strength (the factor scaled to a largest component
of 1, as the schema requires), emitting from the front alone
(doubleSided false). The camera is a node at the TOML's origin looking down
its -z (the TOML looks from z = 3.9 towards the origin), yfov 39.3 degrees.

Run from anywhere: python3 scenes/make_cornell_gltf.py
"""
import base64
import json
import math
import os
import struct

here = os.path.dirname(os.path.abspath(__file__))


def read_mtl(path):
    mats, cur = {}, None
    for line in open(path):
        w = line.split()
        if not w or w[0].startswith("#"):
            continue
        if w[0] == "newmtl":
            cur = w[1]
            mats[cur] = {"Kd": [0.0, 0.0, 0.0], "Ke": [0.0, 0.0, 0.0]}
        elif w[0] in ("Kd", "Ke"):
            mats[cur][w[0]] = [float(x) for x in w[1:4]]
    return mats


def read_obj(path):
    """Vertices and, per material in first-use order, its triangles."""
    verts, groups, order, cur = [], {}, [], None
    for line in open(path):
        w = line.split()
        if not w:
            continue
        if w[0] == "v":
            verts.append([float(x) for x in w[1:4]])
        elif w[0] == "usemtl":
            cur = w[1]
            if cur not in groups:
                groups[cur] = []
                order.append(cur)
        elif w[0] == "f":
            idx = [int(x.split("/")[0]) - 1 for x in w[1:]]
            for k in range(1, len(idx) - 1):
                groups[cur].append((idx[0], idx[k], idx[k + 1]))
    return verts, [(m, groups[m]) for m in order]


def build():
    mats = read_mtl(os.path.join(here, "cornell-box.mtl"))
    verts, groups = read_obj(os.path.join(here, "cornell-box.obj"))
    blob = bytearray()
    views, accessors, primitives, materials = [], [], [], []

    def add_view(data, target):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob.extend(data)
        return len(views) - 1

    # positions, shared by every primitive
    pos = b"".join(struct.pack("<3f", *v) for v in verts)
    lo = [min(v[i] for v in verts) for i in range(3)]
    hi = [max(v[i] for v in verts) for i in range(3)]
    accessors.append({"bufferView": add_view(pos, 34962), "componentType": 5126,
                      "count": len(verts), "type": "VEC3", "min": lo, "max": hi})
    for name, tris in groups:
        idx = b"".join(struct.pack("<3I", *t) for t in tris)
        accessors.append({"bufferView": add_view(idx, 34963), "componentType": 5125,
                          "count": 3 * len(tris), "type": "SCALAR"})
        m = mats[name]
        mat = {
            "name": name,
            "pbrMetallicRoughness": {"baseColorFactor": m["Kd"] + [1.0],
                                     "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
        }
        strength = max(m["Ke"])
        if strength > 0:
            mat["emissiveFactor"] = [c / strength for c in m["Ke"]]
            mat["extensions"]["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
        materials.append(mat)
        primitives.append({"attributes": {"POSITION": 0}, "indices": len(accessors) - 1,
                           "material": len(materials) - 1})
    while len(blob) % 4:
        blob.append(0)
    gltf = {
        "asset": {"version": "2.0", "generator": "embertrace scenes/make_cornell_gltf.py"},
        "extensionsUsed": ["KHR_materials_specular", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "cornell box", "nodes": [0, 1]}],
        "nodes": [
            {"name": "box", "mesh": 0},
            {"name": "camera", "camera": 0, "translation": [0.0, 1.0, 3.9]},
        ],
        "cameras": [{"name": "front", "type": "perspective",
                     "perspective": {"yfov": math.radians(39.3), "aspectRatio": 1.0,
                                     "znear": 0.01}}],
        "meshes": [{"name": "cornell box", "primitives": primitives}],
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob)}],
    }
    return gltf, bytes(blob)


def main():
    gltf, blob = build()
    # .gltf: the buffer as a data: URI
    text = dict(gltf)
    text["buffers"] = [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]
    with open(os.path.join(here, "cornell-box.gltf"), "w") as f:
        json.dump(text, f, indent=1)
        f.write("\n")
    # .glb: JSON chunk (padded with spaces) then BIN chunk (padded with zeros)
    js = json.dumps(gltf, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    with open(os.path.join(here, "cornell-box.glb"), "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


if __name__ == "__main__":
    main()
