"""Build a Mitsuba 3 scene dictionary from an embertrace TOML scene written
by `embertrace convert` (every mesh an OBJ with one explicit material,
every image an EXR), so both renderers draw the same scene.

Only the subset the race scenes use is mapped; anything else raises
ValueError naming the key, so a race never silently renders a different
scene. Conventions (each one checked in tests/mitsuba.rs or
scripts/mitsuba_materials_check.py):

- embertrace's `max_depth = k` bounces is Mitsuba's `max_depth = k + 1`
  (Mitsuba counts path segments);
- embertrace's diffuse surfaces scatter on both sides: `twosided`;
- `plastic` is Mitsuba's `plastic`/`roughplastic` with `nonlinear = true`,
  the sum over internal reflections embertrace implements;
- emission is a one-sided `area` emitter (two-sided emitters are refused);
- the film uses the box filter, embertrace's pixel filter, so both
  renderers estimate the same image (Mitsuba's default Gaussian would
  average neighbouring pixels and trade sharpness for noise).
"""
import os
import tomllib

import mitsuba as mi


def _rgb(v):
    if isinstance(v, (int, float)):
        v = [float(v)] * 3
    return {"type": "rgb", "value": [float(x) for x in v]}


def _texture_or_rgb(mat, key, default, base):
    if "texture" in mat:
        return {"type": "bitmap", "filename": os.path.join(base, mat["texture"]),
                "filter_type": "bilinear"}
    return _rgb(mat.get(key, default))


def _bsdf(mat, base):
    kind = mat.get("type", "diffuse")
    if kind == "diffuse":
        inner = {"type": "diffuse", "reflectance": _texture_or_rgb(mat, "diffuse", 0.8, base)}
        return {"type": "twosided", "bsdf": inner}
    if kind == "mirror":
        return {"type": "conductor", "material": "none",
                "specular_reflectance": _rgb(mat.get("reflectance", 1.0))}
    if kind == "glass":
        return {"type": "dielectric", "int_ior": float(mat.get("ior", 1.5)), "ext_ior": 1.0,
                "specular_reflectance": _rgb(mat.get("reflectance", 1.0)),
                "specular_transmittance": _rgb(mat.get("transmittance", 1.0))}
    if kind == "conductor":
        alpha = float(mat.get("alpha", 0.1))
        d = {"eta": _rgb(mat.get("eta", 0.0)), "k": _rgb(mat.get("k", 1.0))}
        if alpha == 0.0:
            return {"type": "conductor", **d}
        return {"type": "roughconductor", "alpha": alpha,
                "distribution": mat.get("distribution", "ggx"), **d}
    if kind == "plastic":
        alpha = float(mat.get("alpha", 0.0))
        d = {"int_ior": float(mat.get("ior", 1.5)), "ext_ior": 1.0,
             "nonlinear": bool(mat.get("nonlinear", True)),
             "diffuse_reflectance": _texture_or_rgb(mat, "diffuse", 0.8, base)}
        if alpha == 0.0:
            return {"type": "plastic", **d}
        return {"type": "roughplastic", "alpha": alpha,
                "distribution": mat.get("distribution", "ggx"), **d}
    raise ValueError(f"material type `{kind}` is not mapped to Mitsuba")


def _shape(d, mat, base):
    d["bsdf"] = _bsdf(mat, base)
    if "emission" in mat:
        if mat.get("two_sided", False):
            raise ValueError("two-sided emitters are not mapped to Mitsuba")
        d["emitter"] = {"type": "area", "radiance": _rgb(mat["emission"])}
    return d


def scene_dict(toml_path, width, height, sampler="independent", spp=16):
    """The Mitsuba scene dictionary for the converted scene `toml_path` at
    `width` x `height` with `sampler` drawing `spp` samples per pixel."""
    base = os.path.dirname(os.path.abspath(toml_path))
    with open(toml_path, "rb") as f:
        s = tomllib.load(f)
    known = {"camera", "film", "render", "mesh", "sphere", "light"}
    for key in s:
        if key not in known:
            raise ValueError(f"{toml_path}: `{key}` is not mapped to Mitsuba")
    cam = s["camera"]
    if cam.get("aperture_radius", 0.0) or "focal_pixels" in cam:
        raise ValueError(f"{toml_path}: lens and focal_pixels are not mapped")
    render = s.get("render", {})
    integrator = {"type": "path", "max_depth": int(render.get("max_depth", 64)) + 1}
    d = {
        "type": "scene",
        "integrator": integrator,
        "sensor": {
            "type": "perspective",
            "fov": float(cam.get("fov_y", 39.3)),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=cam["origin"], target=cam["target"], up=cam.get("up", [0, 1, 0])),
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": sampler, "sample_count": spp},
        },
    }
    for i, m in enumerate(s.get("mesh", [])):
        d[f"mesh{i}"] = _shape({"type": "obj", "filename": os.path.join(base, m["file"])},
                               m.get("material", {}), base)
    for i, sp in enumerate(s.get("sphere", [])):
        d[f"sphere{i}"] = _shape({"type": "sphere", "center": sp["center"],
                                  "radius": float(sp["radius"])}, sp.get("material", {}), base)
    for i, light in enumerate(s.get("light", [])):
        kind = light["type"]
        if kind == "environment" and "file" in light:
            scale = light.get("radiance", 1.0)
            if isinstance(scale, list):
                if len(set(scale)) != 1:
                    raise ValueError("a coloured envmap scale is not mapped")
                scale = scale[0]
            d[f"light{i}"] = {"type": "envmap", "filename": os.path.join(base, light["file"]),
                              "scale": float(scale)}
        elif kind == "environment":
            d[f"light{i}"] = {"type": "constant", "radiance": _rgb(light.get("radiance", 1.0))}
        elif kind == "point":
            d[f"light{i}"] = {"type": "point", "position": light["position"],
                              "intensity": _rgb(light["intensity"])}
        elif kind == "spot":
            o = light["position"]
            t = light.get("target") or [a + b for a, b in zip(o, light["direction"])]
            axis = [b - a for a, b in zip(o, t)]
            # any up not along the axis: the cone is round about it
            up = [1, 0, 0] if abs(axis[0]) < 0.9 * max(abs(x) for x in axis) else [0, 1, 0]
            cutoff = float(light.get("cutoff_angle", 20.0))
            d[f"light{i}"] = {"type": "spot",
                              "to_world": mi.ScalarTransform4f().look_at(origin=o, target=t, up=up),
                              "intensity": _rgb(light["intensity"]),
                              "cutoff_angle": cutoff,
                              "beam_width": float(light.get("beam_width", 0.75 * cutoff))}
        elif kind == "directional":
            d[f"light{i}"] = {"type": "directional", "direction": light["direction"],
                              "irradiance": _rgb(light["irradiance"])}
        else:
            raise ValueError(f"light type `{kind}` is not mapped to Mitsuba")
    return d
