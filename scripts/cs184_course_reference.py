#!/usr/bin/env python3
"""What the CS184 course's path tracer computes for a course `.dae` scene,
by an estimator independent of embertrace: the course's path loop, written
here in Python, over Mitsuba 3's ray intersections and BSDFs.

    pip install mitsuba numpy
    apt-get install libllvm19   # Mitsuba's llvm variant (else scalar, slow)
    python3 scripts/cs184_course_reference.py SCENE.dae OUT_PREFIX \\
        [-r W H] [-m MAX_DEPTH] [--spp N] [--passes P] [--seed S]

writes OUT_PREFIX.exr (the mean of P independent passes of N samples per
pixel), OUT_PREFIX-var.exr (the variance of that mean, per pixel and
channel, from the spread of the passes) and OUT_PREFIX.json (provenance and
the image's mean). tests/data/collada/course_box-ref* were made with

    python3 scripts/cs184_course_reference.py tests/data/collada/course_box.dae \\
        tests/data/collada/course_box-ref -r 96 72 -m 5 --spp 2048 --passes 16

The loop follows the course (`src/pathtracer/pathtracer.cpp` of
github.com/cal-cs184/p3_1-pathtracer-current and its project spec):

- `zero_bounce_radiance`: the emission of the surface a camera ray hits
  (the CGL `<emission>` material, `EmissionBSDF::get_emission`, the same
  from either side);
- `one_bounce_radiance`, at every surface whose BSDF is not a delta BSDF:
  each light of `scene->lights` sampled `-l` times (a delta light once);
  the CGL `<area>` light uniformly by area with density
  `d^2 / (A |cos theta_l|)`, radiance only on the side it faces
  (`AreaLight::sample_L`); a point light with no falloff
  (`PointLight::sample_L`); shadow rays that stop short of the light, so a
  surface in the light's plane does not shadow it;
- `at_least_one_bounce_radiance`: the direct light above, then, while the
  ray's depth allows (`-m` bounces in all), one BSDF sample, whose hit adds
  its own `at_least_one_bounce_radiance`, plus its `zero_bounce_radiance`
  when the BSDF that sent it is a delta BSDF (mirror, glass). Lights are not
  geometry: no ray meets the CGL area light, and an emissive mesh found
  after a non-delta bounce adds nothing.

Russian roulette is left out (it changes no expectation). The course's
camera is rebuilt from the file as the course places it: it looks at the
centre of the geometry's bounding box (lights left out) from 1.5 times the
box's diagonal away, along the camera node's transformed point (0, 0, -1),
with +y up; `yfov` (or `xfov` and `aspect_ratio`) fixes a focal length in
pixels for the course's 800 x 600 window (`Camera::configure`: a file
aspect wider than the window's keeps the horizontal field), which `-r`
keeps. Pixels are box
filtered, row 0 at the top.

Surfaces: the course's diffuse BSDF is Mitsuba's `diffuse` inside
`twosided`; the CGL mirror is `conductor` with `material = none`; CGL glass
is `dielectric` (exact Fresnel, where the course's project spec asks for
Schlick's approximation: the one difference kept, on glass alone); the
emitting mesh has a black diffuse BSDF, like the course's `EmissionBSDF`.
Meshes keep their per-corner normals (smooth shading), spheres are centred
at the node's origin with the radius scaled by the length of the node's
transformed x axis. Nothing here reads embertrace's code or output.
"""
import argparse
import json
import os
import struct
import sys
import tempfile
import xml.etree.ElementTree as ET

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM):
    os.environ["DRJIT_LIBLLVM_PATH"] = LLVM

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

try:
    mi.set_variant("llvm_ad_rgb")
except Exception:
    mi.set_variant("scalar_rgb")

NS = "{http://www.collada.org/2005/11/COLLADASchema}"
WINDOW_HEIGHT = 600  # the course's default window: 800 x 600
WINDOW_ASPECT = 800 / 600
UP = {
    "Y_UP": np.eye(3),
    "Z_UP": np.array([[-1.0, 0, 0], [0, 0, 1], [0, 1, 0]]),  # (x, y, z) -> (-x, z, y)
    "X_UP": np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]]),  # (x, y, z) -> (y, x, -z)
}


def tag(e):
    return e.tag.replace(NS, "")


def find(e, path):
    return e.find("/".join(NS + p for p in path.split("/")))


def floats(e):
    return [float(x) for x in e.text.split()]


class Dae:
    """The course's subset of COLLADA: what its Cornell scenes use."""

    def __init__(self, path):
        self.root = ET.parse(path).getroot()
        self.ids = {e.get("id"): e for e in self.root.iter() if e.get("id")}
        up = find(self.root, "asset/up_axis").text.strip()
        self.up = np.eye(4)
        self.up[:3, :3] = UP[up]
        self.meshes = []  # (corner positions (3T, 3), corner normals or None, material)
        self.spheres = []  # (centre, radius, material)
        self.lights = []  # ("area", centre, dim_x, dim_y, facing, L) or ("point", p, I)
        self.camera = None  # (world matrix, camera element)
        scene = self.ref(find(self.root, "scene/instance_visual_scene").get("url"))
        for node in scene:
            if tag(node) == "node":
                self.node(node, self.up)

    def ref(self, url):
        return self.ids[url.lstrip("#")]

    def node(self, node, parent):
        m = parent.copy()
        for e in node:
            t = tag(e)
            if t == "matrix":
                m = m @ np.array(floats(e)).reshape(4, 4)
            elif t == "translate":
                tr = np.eye(4)
                tr[:3, 3] = floats(e)
                m = m @ tr
            elif t == "scale":
                m = m @ np.diag(floats(e) + [1.0])
            elif t in ("rotate", "lookat", "skew"):
                sys.exit(f"<{t}> in a node: not used by the course's scenes, not read here")
        for e in node:
            t = tag(e)
            if t == "instance_geometry":
                self.geometry(self.ref(e.get("url")), e, m)
            elif t == "instance_light":
                self.light(self.ref(e.get("url")), m)
            elif t == "instance_camera":
                self.camera = (m, self.ref(e.get("url")))
            elif t == "node":
                self.node(e, m)

    def material(self, inst):
        im = inst.find(f".//{NS}instance_material")
        mat = {"kind": "diffuse", "albedo": [0.5] * 3}
        if im is None:
            return mat
        effect = self.ref(self.ref(im.get("target")).find(f"{NS}instance_effect").get("url"))
        cgl = effect.find(f"{NS}extra/{NS}technique[@profile='CGL']")
        if cgl is not None:
            for b in cgl:  # the last BSDF listed wins, as in the course
                t = tag(b)
                if t == "emission":
                    mat = {"kind": "emission", "radiance": floats(find(b, "radiance"))}
                elif t == "mirror":
                    mat = {"kind": "mirror", "reflectance": floats(find(b, "reflectance"))}
                elif t == "glass":
                    mat = {"kind": "glass", "ior": floats(find(b, "ior"))[0],
                           "reflectance": floats(find(b, "reflectance")),
                           "transmittance": floats(find(b, "transmittance"))}
                elif t == "diffuse":
                    c = find(b, "reflectance")
                    mat = {"kind": "diffuse",
                           "albedo": floats(c if c is not None else find(b, "albedo"))}
                else:
                    sys.exit(f"CGL material <{t}> is not supported here")
            return mat
        common = find(effect, "profile_COMMON/technique")
        for shading in ("phong", "lambert", "blinn"):
            c = None if common is None else find(common, f"{shading}/diffuse/color")
            if c is not None:
                return {"kind": "diffuse", "albedo": floats(c)[:3]}
        return mat

    def geometry(self, g, inst, m):
        mat = self.material(inst)
        cgl = g.find(f"{NS}extra/{NS}technique[@profile='CGL']")
        if cgl is not None and find(cgl, "sphere/radius") is not None:
            r = floats(find(cgl, "sphere/radius"))[0]
            centre = m[:3, 3]
            self.spheres.append((centre, r * np.linalg.norm(m[:3, 0]), mat))
            return
        mesh = find(g, "mesh")
        sources = {}
        for s in mesh.findall(f"{NS}source"):
            arr = s.find(f"{NS}float_array")
            acc = s.find(f".//{NS}accessor")
            stride = int(acc.get("stride", "3")) if acc is not None else 3
            sources[s.get("id")] = np.array(floats(arr)).reshape(-1, stride)[:, :3]
        verts = {}
        for v in mesh.findall(f"{NS}vertices"):
            for i in v.findall(f"{NS}input"):
                if i.get("semantic") == "POSITION":
                    verts[v.get("id")] = sources[i.get("source").lstrip("#")]
        pos, nor = [], []
        for prim in mesh:
            t = tag(prim)
            if t not in ("polylist", "triangles"):
                continue
            inputs = prim.findall(f"{NS}input")
            width = 1 + max(int(i.get("offset")) for i in inputs)
            p = np.array([int(x) for x in find(prim, "p").text.split()]).reshape(-1, width)
            if t == "polylist":
                counts = [int(x) for x in find(prim, "vcount").text.split()]
            else:
                counts = [3] * (len(p) // 3)
            vsrc = nsrc = None
            for i in inputs:
                if i.get("semantic") == "VERTEX":
                    vsrc, voff = verts[i.get("source").lstrip("#")], int(i.get("offset"))
                elif i.get("semantic") == "NORMAL":
                    nsrc, noff = sources[i.get("source").lstrip("#")], int(i.get("offset"))
            k = 0
            for n in counts:
                for j in range(1, n - 1):  # fans, as the course does
                    for c in (k, k + j, k + j + 1):
                        pos.append(vsrc[p[c, voff]])
                        if nsrc is not None:
                            nor.append(nsrc[p[c, noff]])
                k += n
        pos = np.array(pos) @ m[:3, :3].T + m[:3, 3]
        if nor:
            # normals by the inverse transpose
            nor = np.array(nor) @ np.linalg.inv(m[:3, :3])
            nor /= np.linalg.norm(nor, axis=1, keepdims=True)
        self.meshes.append((pos, np.array(nor) if len(nor) else None, mat))

    def light(self, light, m):
        cgl = light.find(f"{NS}extra/{NS}technique[@profile='CGL']")
        tech = cgl if cgl is not None else find(light, "technique_common")
        e = [c for c in tech if isinstance(c.tag, str)][0]
        colour = floats(find(e, "color"))
        origin = m[:3, 3]

        def point(v):  # the course transforms directions as points
            return m[:3, :3] @ np.array(v, dtype=float) + origin

        if tag(e) == "area":
            facing = point([0, 0, -1]) - origin
            self.lights.append(("area", origin, point([-1, 0, 0]) - origin,
                                point([0, 1, 0]) - origin,
                                facing / np.linalg.norm(facing), colour))
        elif tag(e) == "point":
            self.lights.append(("point", origin, colour))
        else:
            sys.exit(f"<{tag(e)}> lights are not supported here")

    def view(self, width, height):
        """The course's camera: origin, forward, right and up scaled by the
        tangents of the half fields of view."""
        pts = [p for p, _, _ in self.meshes]
        pts += [np.array([c - r, c + r]) for c, r, _ in self.spheres]
        pts = np.concatenate(pts)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        target = 0.5 * (lo + hi)
        world, cam = self.camera
        d = (world @ np.array([0, 0, -1.0, 1]))[:3]
        d /= np.linalg.norm(d)
        origin = target + 1.5 * np.linalg.norm(hi - lo) * d
        persp = find(cam, "optics/technique_common/perspective")
        yfov, xfov = find(persp, "yfov"), find(persp, "xfov")
        aspect = find(persp, "aspect_ratio")
        # the course's collada.cpp: xfov (50 if absent); yfov, else from
        # xfov and aspect_ratio, else 35
        h = float(xfov.text) if xfov is not None else 50.0
        v = 35.0
        if yfov is not None:
            v = float(yfov.text)
        elif aspect is not None:
            v = 2 * np.degrees(np.arctan(np.tan(np.radians(0.5 * h)) / float(aspect.text)))
        # Camera::configure for the 800 x 600 window: a view wider than the
        # window keeps its horizontal field and narrows the vertical one's
        # tangent to fit
        half = lambda deg: np.tan(np.radians(0.5 * deg))  # noqa: E731
        if half(h) / half(v) > WINDOW_ASPECT:
            v = 2 * np.degrees(np.arctan(half(h) / WINDOW_ASPECT))
        focal = WINDOW_HEIGHT / (2 * half(v))
        ty = height / (2 * focal)
        tx = ty * width / height
        fwd = target - origin
        fwd /= np.linalg.norm(fwd)
        up = np.array([0, 0, -1.0]) if abs(d[1]) > 1 - 1e-6 else np.array([0, 1.0, 0])
        right = np.cross(fwd, up)
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        return origin, fwd, right * tx, up * ty


def write_ply(path, pos, nor):
    head = ("ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(pos)}\nproperty float x\nproperty float y\nproperty float z\n")
    if nor is not None:
        head += "property float nx\nproperty float ny\nproperty float nz\n"
    head += f"element face {len(pos) // 3}\nproperty list uchar int vertex_indices\nend_header\n"
    cols = pos if nor is None else np.hstack([pos, nor])
    body = cols.astype("<f4").tobytes()
    body += b"".join(struct.pack("<B3i", 3, 3 * t, 3 * t + 1, 3 * t + 2)
                     for t in range(len(pos) // 3))
    with open(path, "wb") as out:
        out.write(head.encode() + body)


def bsdf(mat):
    k = mat["kind"]
    if k == "diffuse":
        return {"type": "twosided",
                "b": {"type": "diffuse", "reflectance": {"type": "rgb", "value": mat["albedo"]}}}
    if k == "emission":
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0] * 3}}
    if k == "mirror":
        return {"type": "conductor", "material": "none",
                "specular_reflectance": {"type": "rgb", "value": mat["reflectance"]}}
    return {"type": "dielectric", "int_ior": mat["ior"], "ext_ior": 1.0,
            "specular_reflectance": {"type": "rgb", "value": mat["reflectance"]},
            "specular_transmittance": {"type": "rgb", "value": mat["transmittance"]}}


def mitsuba_scene(dae, tmp):
    d = {"type": "scene"}
    for k, (pos, nor, mat) in enumerate(dae.meshes):
        path = os.path.join(tmp, f"mesh{k}.ply")
        write_ply(path, pos, nor)
        shape = {"type": "ply", "filename": path, "bsdf": bsdf(mat)}
        if nor is None:
            shape["face_normals"] = True
        if mat["kind"] == "emission":
            # looked up with the viewer forced in front: the course's
            # emission is the same from either side
            shape["emitter"] = {"type": "area",
                                "radiance": {"type": "rgb", "value": mat["radiance"]}}
        d[f"mesh{k}"] = shape
    for k, (c, r, mat) in enumerate(dae.spheres):
        shape = {"type": "sphere", "center": [float(t) for t in c], "radius": float(r), "bsdf": bsdf(mat)}
        if mat["kind"] == "emission":
            shape["emitter"] = {"type": "area",
                                "radiance": {"type": "rgb", "value": mat["radiance"]}}
        d[f"sphere{k}"] = shape
    return mi.load_dict(d)


def vec(kind, v):
    return kind(*(float(t) for t in v))


def emission(scene, si, active):
    front = mi.SurfaceInteraction3f(si)
    front.wi = mi.Vector3f(0, 0, 1)
    return si.emitter(scene, active).eval(front, active)


def course_pass(scene, dae, width, height, spp, max_depth, ns_area, seed):
    """One pass: every pixel's mean over `spp` samples, as (H, W, 3)."""
    o, fwd, right, up = (vec(mi.Vector3f, v) for v in dae.view(width, height))
    n = width * height * spp
    idx = dr.arange(mi.UInt32, n)
    pix = idx // spp
    x = mi.Float(pix % width)
    y = mi.Float(pix // width)
    rng = mi.PCG32(n, mi.UInt64(seed) << 32)
    ctx = mi.BSDFContext()
    d = fwd + right * (2 * (x + rng.next_float32()) / width - 1) \
        + up * (1 - 2 * (y + rng.next_float32()) / height)
    ray = mi.Ray3f(o, dr.normalize(d))
    si = scene.ray_intersect(ray)
    active = si.is_valid()
    L = emission(scene, si, active)
    beta = mi.Spectrum(1.0)
    for depth in range(max_depth, 0, -1):
        b = si.bsdf(ray)
        delta = ~mi.has_flag(b.flags(), mi.BSDFFlags.Smooth)
        direct = active & ~delta
        for light in dae.lights:
            rounds = ns_area if light[0] == "area" else 1
            for _ in range(rounds):
                if light[0] == "area":
                    _, c, dx, dy, facing, le = light
                    u, v = rng.next_float32() - 0.5, rng.next_float32() - 0.5
                    p = vec(mi.Point3f, c) + vec(mi.Vector3f, dx) * u + vec(mi.Vector3f, dy) * v
                    area = float(np.linalg.norm(np.cross(dx, dy)))
                else:
                    _, c, le = light
                    p = vec(mi.Point3f, c)
                to = p - si.p
                dist = dr.norm(to)
                wi = to / dist
                if light[0] == "area":
                    cos_l = -dr.dot(vec(mi.Vector3f, facing), wi)
                    ok = direct & (cos_l > 0)
                    pdf = dr.square(dist) / (area * cos_l)
                else:
                    ok = direct & (dist > 0)
                    pdf = mi.Float(1.0)
                f = b.eval(ctx, si, si.to_local(wi), ok)  # cosine included
                # ends ShadowEpsilon (relative, 8.9e-4) short of the light
                shadow = si.spawn_ray_to(p)
                ok &= ~scene.ray_test(shadow, ok)
                L += dr.select(ok, beta * f * vec(mi.Spectrum, le) / (pdf * rounds), 0.0)
        if depth == 1:
            break
        bs, weight = b.sample(ctx, si, rng.next_float32(),
                              mi.Point2f(rng.next_float32(), rng.next_float32()), active)
        active &= (bs.pdf > 0) & (dr.max(weight) > 0)
        beta *= weight
        ray = si.spawn_ray(si.to_world(bs.wo))
        si = scene.ray_intersect(ray, active)
        active &= si.is_valid()
        L += dr.select(active & delta, beta * emission(scene, si, active), 0.0)
        dr.eval(L, beta, active, si, ray, rng)
    lv = np.array(L)  # (3, n)
    assert lv.shape == (3, n), lv.shape
    return lv.reshape(3, height, width, spp).mean(axis=3).transpose(1, 2, 0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("-r", nargs=2, type=int, default=[96, 72], metavar=("W", "H"))
    ap.add_argument("-m", type=int, default=5, help="bounces (the course's -m)")
    ap.add_argument("-l", type=int, default=1, help="samples per area light (the course's -l)")
    ap.add_argument("--spp", type=int, default=2048, help="samples per pixel per pass")
    ap.add_argument("--passes", type=int, default=16)
    ap.add_argument("--chunk", type=int, default=256, help="samples per pixel per launch")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    width, height = a.r
    dae = Dae(a.scene)
    with tempfile.TemporaryDirectory() as tmp:
        scene = mitsuba_scene(dae, tmp)
        passes = []
        for k in range(a.passes):
            acc = np.zeros((height, width, 3))
            chunks = max(1, a.spp // a.chunk)
            for j in range(chunks):
                seed = (a.seed * 1_000_003 + k) * 4096 + j
                acc += course_pass(scene, dae, width, height, a.spp // chunks, a.m, a.l, seed)
            passes.append(acc / chunks)
            print(f"pass {k + 1}/{a.passes}: mean {passes[-1].mean(axis=(0, 1))}", flush=True)
    stack = np.stack(passes)
    mean = stack.mean(axis=0)
    var_of_mean = stack.var(axis=0, ddof=1) / len(passes)
    mi.Bitmap(mean.astype(np.float32)).write(a.out + ".exr")
    mi.Bitmap(var_of_mean.astype(np.float32)).write(a.out + "-var.exr")
    info = {
        "scene": os.path.basename(a.scene),
        "made_by": "scripts/cs184_course_reference.py " + " ".join(sys.argv[1:]),
        "mitsuba": mi.__version__,
        "variant": mi.variant(),
        "resolution": [width, height],
        "max_depth": a.m,
        "light_samples": a.l,
        "spp_per_pass": a.spp // max(1, a.spp // a.chunk) * max(1, a.spp // a.chunk),
        "passes": a.passes,
        "mean_rgb": [float(v) for v in mean.mean(axis=(0, 1))],
        "stderr_of_mean_rgb": [float(v) for v in np.sqrt(var_of_mean.sum(axis=(0, 1)))
                               / (width * height)],
    }
    with open(a.out + ".json", "w") as out:
        json.dump(info, out, indent=1)
        out.write("\n")
    print(json.dumps(info, indent=1))


if __name__ == "__main__":
    main()
