#!/usr/bin/env python3
"""The race: embertrace against Mitsuba 3 on the same scenes, side by side
in one run. For each scene it renders an spp ladder with embertrace at its
defaults (no flags) and with Mitsuba 3 `llvm_ad_rgb` at its default sampler
(`independent`) and its best ones (`ldsampler`, `multijitter`), and reports

- RMSE against each renderer's own high-spp reference, with the
  reference's own variance taken out (the reference is the mean of two
  independent halves, whose difference estimates it);
- samples per second (the render call's wall time: embertrace's
  `render_seconds`, Mitsuba's `mi.render` including its per-call tracing;
  scene loading and acceleration-structure builds are left out on both
  sides);
- time to equal error: `log time` fitted against `log RMSE` over the
  ladder, for each renderer, evaluated at the RMSE that Mitsuba's best
  sampler reaches at the middle rung; and the ratio to Mitsuba;
- embertrace's renderer efficiency (`embertrace bench SCENE --efficiency`):
  samples per second divided by what Embree's queries alone would allow
  for the rays the render traced.

    pip install mitsuba numpy
    apt-get install libllvm19     # Mitsuba's llvm variant; Debian 12's LLVM 15 crashes it
    python3 benches/race/race.py --reps 2 --ref-spp 4096   # all scenes
    # (48 min with one --ours-extra row on a 2-core AMD EPYC)
    python3 benches/race/race.py --scenes cornell-box --reps 1 --ref-spp 1024   # quick look

References are cached in `--out`/cache, keyed by the converted scene's
bytes, the resolution and the reference spp. Results go to `--out`/race.json
and race.md. Both renderers use every core of the machine.
"""
import argparse
import hashlib
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM):
    os.environ["DRJIT_LIBLLVM_PATH"] = LLVM

import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, HERE)
import mitsuba_scene  # noqa: E402

# scene -> (file, width, height)
SCENES = {
    "cornell-box": ("scenes/cornell-box.toml", 256, 256),
    "cornell-mesh": ("scenes/cornell-mesh.toml", 256, 256),
    "cornell-spheres": ("scenes/cornell-spheres.toml", 256, 256),
    "materials": ("scenes/materials.toml", 256, 128),
    # hard lighting (issue 38), Mitsuba 3 XML that both renderers read as
    # it is: benches/race/hard/make_hard_scenes.py
    "door-ajar": ("benches/race/hard/door-ajar.xml", 128, 128),
    "many-lights": ("benches/race/hard/many-lights.xml", 256, 256),
    "glossy-env": ("benches/race/hard/glossy-env.xml", 128, 128),
}
MITSUBA_SAMPLERS = ["independent", "ldsampler", "multijitter"]
# Above this many samples per pixel (references) renders are not timed,
# so Mitsuba's kernel needs no warm-up render.
TIMED_SPP = 1024


def log(*a):
    print(*a, flush=True)


def embertrace_bin():
    return os.path.join(ROOT, "target", "release", "embertrace")


def read_exr(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


class Ours:
    """embertrace, run as a process with its defaults plus `extra` flags."""

    def __init__(self, scene_file, width, height, work, extra=()):
        self.scene = os.path.join(ROOT, scene_file)
        self.res = [str(width), str(height)]
        self.work = work
        self.extra = list(extra)
        self.name = "embertrace" + ("".join(" " + e for e in self.extra))

    def render(self, spp, seed, extra=()):
        out = os.path.join(self.work, "ours.exr")
        rep = os.path.join(self.work, "ours.json")
        cmd = [embertrace_bin(), "render", self.scene, "-r", *self.res, "-s", str(spp),
               "--seed", str(seed), "-o", out, "--report", rep, "-q", *self.extra, *extra]
        subprocess.run(cmd, check=True)
        with open(rep) as f:
            report = json.load(f)
        return read_exr(out), report["render_seconds"], report


class Mitsuba:
    """Mitsuba 3 (llvm_ad_rgb), in this process, one loaded scene per sampler."""

    def __init__(self, converted, width, height, sampler):
        self.converted, self.width, self.height = converted, width, height
        self.sampler = sampler
        self.name = f"mitsuba {sampler}"
        if converted.endswith(".xml"):
            # a scene written as Mitsuba XML: read as it is, with its
            # `$width`, `$height` and `$sampler` set
            self.scene = mi.load_file(converted, width=width, height=height, sampler=sampler)
        else:
            self.scene = mi.load_dict(mitsuba_scene.scene_dict(converted, width, height, sampler))
        self.warm = set()

    def render(self, spp, seed):
        scene = self.scene
        if spp not in self.warm and spp <= TIMED_SPP:
            # the first render of a kernel compiles it: not part of the timing
            np.array(mi.render(scene, spp=spp, seed=seed + 7919))
            self.warm.add(spp)
        t0 = time.perf_counter()
        img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
        dt = time.perf_counter() - t0
        return img[:, :, :3], dt


def reference(renderer, key, spp, cache):
    """Mean of two independent halves of `spp` samples, and the variance of
    that mean per pixel and channel averaged over the image (estimated from
    the halves' difference: E[(a - b)^2] = 2 var(half) = 4 var(mean))."""
    path = os.path.join(cache, key + ".npz")
    if os.path.exists(path):
        z = np.load(path)
        return z["ref"], float(z["var"])
    log(f"  reference {renderer.name} {spp} spp ...")
    t0 = time.perf_counter()
    halves = [renderer.render(spp // 2, 100_003 + k)[0] for k in range(2)]
    ref = 0.5 * (halves[0] + halves[1])
    var = float(np.mean((halves[0] - halves[1]) ** 2) / 4.0)
    np.savez_compressed(path, ref=ref, var=var)
    log(f"  ... {time.perf_counter() - t0:.0f} s")
    return ref, var


def rmse(img, ref, ref_var):
    """RMSE of `img` against the true image: the measured mean square error
    less the reference's own variance."""
    mse = float(np.mean((img - ref) ** 2)) - ref_var
    return math.sqrt(max(mse, 1e-30))


def fit(points):
    """Least-squares fit of log t = a + b log e over (e, t) points."""
    x = np.log([p[0] for p in points])
    y = np.log([p[1] for p in points])
    b, a = np.polyfit(x, y, 1) if len(points) > 1 else (-2.0, y[0] + 2.0 * x[0])
    return float(a), float(b)


def time_at(ab, e):
    a, b = ab
    return math.exp(a + b * math.log(e))


def efficiency(scene_file, width, height):
    """embertrace's renderer efficiency, from `bench --efficiency`."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "eff.json")
        r = subprocess.run([embertrace_bin(), "bench", os.path.join(ROOT, scene_file),
                            "--efficiency", "-r", str(width), str(height), "--json", out],
                           capture_output=True, text=True)
        if r.returncode != 0:
            log(f"  (no efficiency: {r.stderr.strip().splitlines()[-1:]})")
            return None
        with open(out) as f:
            return json.load(f)


def race_scene(name, args, cache):
    scene_file, w, h = SCENES[name]
    if args.width:
        w, h = args.width, args.height
    work = tempfile.mkdtemp(prefix=f"race-{name}-")
    try:
        if scene_file.endswith(".xml"):
            converted = os.path.join(work, "scene.xml")
            shutil.copy(os.path.join(ROOT, scene_file), converted)
        else:
            converted = os.path.join(work, "scene.toml")
            subprocess.run([embertrace_bin(), "convert", os.path.join(ROOT, scene_file),
                            converted], check=True, capture_output=True)
        digest = hashlib.sha256()
        for f in sorted(os.listdir(work)):
            with open(os.path.join(work, f), "rb") as fh:
                digest.update(f.encode() + fh.read())
        key = f"{name}-{w}x{h}-{args.ref_spp}-{digest.hexdigest()[:16]}"

        ours = [Ours(scene_file, w, h, work)] + [
            Ours(scene_file, w, h, work, extra.split()) for extra in args.ours_extra]
        # Mitsuba reads an XML scene where it is, so that the files it names
        # (an environment map) resolve as they do for embertrace; the copy in
        # `work` only feeds the cache key
        mitsuba_scene_file = (os.path.join(ROOT, scene_file) if scene_file.endswith(".xml")
                              else converted)
        theirs = [Mitsuba(mitsuba_scene_file, w, h, s) for s in args.samplers]
        refs = {
            "ours": reference(ours[0], key + "-ours", args.ref_spp, cache),
            "mitsuba": reference(theirs[0], key + "-mitsuba", args.ref_spp, cache),
        }
        # do the two references show the same scene? (mean relative difference)
        ro, rm = refs["ours"][0], refs["mitsuba"][0]
        ref_bias = float(np.mean(ro) / np.mean(rm) - 1.0)

        results = {r.name: {"points": []} for r in ours + theirs}
        ours[0].render(args.ladder[0], 1)  # warm the file cache
        for spp in args.ladder:
            for rep in range(args.reps):
                seed = 1 + rep
                for r in ours + theirs:
                    if isinstance(r, Ours):
                        img, dt, report = r.render(spp, seed)
                        ref, var = refs["ours"]
                    else:
                        img, dt = r.render(spp, seed)
                        ref, var = refs["mitsuba"]
                    results[r.name]["points"].append(
                        {"spp": spp, "seed": seed, "seconds": dt, "rmse": rmse(img, ref, var)})
            line = []
            for r in ours + theirs:
                pts = [p for p in results[r.name]["points"] if p["spp"] == spp]
                line.append(f"{r.name}: {statistics.median(p['seconds'] for p in pts):.3f} s "
                            f"rmse {statistics.fmean(p['rmse'] for p in pts):.5f}")
            log(f"  {spp:5d} spp | " + " | ".join(line))

        # per rung: median time, RMS of the RMSEs (mean MSE)
        for r in ours + theirs:
            res = results[r.name]
            rungs = []
            for spp in args.ladder:
                pts = [p for p in res["points"] if p["spp"] == spp]
                t = statistics.median(p["seconds"] for p in pts)
                e = math.sqrt(statistics.fmean(p["rmse"] ** 2 for p in pts))
                rungs.append({"spp": spp, "seconds": t, "rmse": e,
                              "samples_per_second": w * h * spp / t})
            res["rungs"] = rungs
            res["fit"] = fit([(g["rmse"], g["seconds"]) for g in rungs])
            res["samples_per_second"] = rungs[-1]["samples_per_second"]
        mid = len(args.ladder) // 2
        target = min(results[m.name]["rungs"][mid]["rmse"] for m in theirs)
        for r in ours + theirs:
            results[r.name]["time_at_target"] = time_at(results[r.name]["fit"], target)
        best = min(theirs, key=lambda m: results[m.name]["time_at_target"])
        t_best = results[best.name]["time_at_target"]
        # Mitsuba's default sampler, when it raced (`--samplers` may leave it out)
        t_ind = results.get("mitsuba independent", {}).get("time_at_target")
        for r in ours + theirs:
            results[r.name]["ratio_to_mitsuba_best"] = results[r.name]["time_at_target"] / t_best
            results[r.name]["ratio_to_mitsuba_independent"] = (
                results[r.name]["time_at_target"] / t_ind if t_ind else None)
        eff = efficiency(scene_file, w, h) if not args.no_efficiency else None
        return {"scene": name, "resolution": [w, h], "target_rmse": target,
                "mitsuba_best": best.name, "reference_mean_ratio_minus_1": ref_bias,
                "efficiency": eff, "renderers": results}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def markdown(all_results, args):
    lines = [
        f"Ladder {', '.join(map(str, args.ladder))} spp, {args.reps} seeds each, references "
        f"{args.ref_spp} spp; time to equal error at the RMSE Mitsuba's best sampler reaches "
        f"at {args.ladder[len(args.ladder) // 2]} spp.",
        "",
        "| scene | renderer | RMSE at " + " / ".join(map(str, args.ladder))
        + " spp | Msamples/s | time to equal error | / Mitsuba best | / Mitsuba independent |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    for r in all_results:
        for name, res in r["renderers"].items():
            errs = " / ".join(f"{g['rmse']:.4f}" for g in res["rungs"])
            lines.append(
                f"| {r['scene']} | {name} | {errs} | {res['samples_per_second'] / 1e6:.2f} | "
                f"{res['time_at_target']:.3f} s | {res['ratio_to_mitsuba_best']:.2f}x | "
                + (f"{res['ratio_to_mitsuba_independent']:.2f}x |"
                   if res['ratio_to_mitsuba_independent'] is not None else "- |"))
    lines.append("")
    lines.append("| scene | Mitsuba best | target RMSE | references' means differ by | "
                 "embertrace efficiency |")
    lines.append("|---|---|---:|---:|---:|")
    for r in all_results:
        eff = r["efficiency"]
        e = f"{eff['efficiency']:.2f}" if eff else "-"
        lines.append(f"| {r['scene']} | {r['mitsuba_best']} | {r['target_rmse']:.5f} | "
                     f"{100 * r['reference_mean_ratio_minus_1']:+.2f} % | {e} |")
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default=",".join(SCENES))
    p.add_argument("--ladder", default="16,64,256")
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--ref-spp", type=int, default=8192)
    p.add_argument("--samplers", default=",".join(MITSUBA_SAMPLERS))
    p.add_argument("--ours-extra", action="append", default=[],
                   help="also race embertrace with these flags (e.g. '--sampler independent')")
    p.add_argument("-r", nargs=2, type=int, metavar=("W", "H"),
                   help="override every scene's resolution")
    p.add_argument("--out", default=os.path.join(ROOT, "target", "race"))
    p.add_argument("--no-build", action="store_true")
    p.add_argument("--no-efficiency", action="store_true")
    args = p.parse_args()
    args.ladder = [int(x) for x in args.ladder.split(",")]
    args.samplers = args.samplers.split(",")
    args.width, args.height = args.r if args.r else (None, None)
    if not args.no_build:
        subprocess.run(["cargo", "build", "--release", "-q"], cwd=ROOT, check=True)
    mi.set_variant("llvm_ad_rgb")
    cache = os.path.join(args.out, "cache")
    os.makedirs(cache, exist_ok=True)
    all_results = []
    for name in args.scenes.split(","):
        log(f"{name}:")
        all_results.append(race_scene(name, args, cache))
    with open(os.path.join(args.out, "race.json"), "w") as f:
        json.dump({"mitsuba": mi.__version__, "args": vars(args), "scenes": all_results}, f,
                  indent=1)
    md = markdown(all_results, args)
    with open(os.path.join(args.out, "race.md"), "w") as f:
        f.write(md)
    print(md)


if __name__ == "__main__":
    main()
