"""The Python module: arrays of the right shape and values, the same bits
as the command line, progress, a released GIL, Ctrl-C, and errors as Python
exceptions. Run by scripts/python-test (from .ci/run)."""

import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import embertrace

ROOT = pathlib.Path(__file__).resolve().parents[2]
CORNELL = str(ROOT / "scenes" / "cornell-box.toml")
BINARY = os.environ.get("EMBERTRACE_BIN")


def test_render_returns_height_by_width_by_3_float32():
    image = embertrace.render(CORNELL, spp=2, resolution=(24, 16))
    assert isinstance(image, np.ndarray)
    assert image.shape == (16, 24, 3)
    assert image.dtype == np.float32
    assert np.isfinite(image).all()
    # the Cornell box's walls are lit: most pixels see light
    assert (image.sum(axis=2) > 0).mean() > 0.5


def test_scene_defaults_apply_when_arguments_are_left_out():
    scene = embertrace.load(CORNELL)
    w, h = scene.resolution
    image = scene.render(spp=1)
    assert image.shape == (h, w, 3)
    assert scene.triangles > 0
    assert pathlib.Path(scene.path).name == "cornell-box.toml"


def test_the_same_seed_gives_the_same_bits_and_another_seed_does_not():
    scene = embertrace.load(CORNELL)
    a = scene.render(spp=3, resolution=(16, 16), seed=5, threads=1)
    b = scene.render(spp=3, resolution=(16, 16), seed=5, threads=2, passes=3)
    c = scene.render(spp=3, resolution=(16, 16), seed=6)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.skipif(BINARY is None, reason="EMBERTRACE_BIN (the CLI to compare with) is not set")
def test_the_image_is_the_command_lines_bit_for_bit(tmp_path):
    out = tmp_path / "cli.pfm"
    subprocess.run(
        # both take the same backend for the scene (embree+naive, for one
        # this small) when none is named
        [BINARY, "render", CORNELL, "-o", str(out), "-s", "4", "-r", "20", "12", "--seed", "9", "-q"],
        check=True,
    )
    cli = read_pfm(out)
    image = embertrace.render(CORNELL, spp=4, resolution=(20, 12), seed=9)
    assert np.array_equal(image, cli)


def read_pfm(path):
    """A colour PFM (little-endian), rows from the top."""
    data = pathlib.Path(path).read_bytes()
    header, w_h, scale, rest = data.split(b"\n", 3)
    assert header == b"PF"
    w, h = map(int, w_h.split())
    assert float(scale) < 0, "little-endian"
    pixels = np.frombuffer(rest, dtype="<f4").reshape(h, w, 3)
    return pixels[::-1]  # PFM stores the bottom row first


def test_both_backends_render_the_same_image():
    kwargs = dict(spp=2, resolution=(16, 16), seed=1)
    embree = embertrace.render(CORNELL, accel="embree", **kwargs)
    bvh = embertrace.render(CORNELL, accel="bvh", **kwargs)
    # the same rays; the backends may differ in a hit's last bits
    assert np.abs(embree - bvh).max() < 1e-3 * max(1.0, float(embree.max()))


def test_progress_reports_every_pass_in_order():
    seen = []
    embertrace.render(CORNELL, spp=6, resolution=(8, 8), passes=3, progress=seen.append)
    assert [(p["pass"], p["samples"]) for p in seen] == [(1, 2), (2, 4), (3, 6)]
    assert all(p["passes"] == 3 and p["spp"] == 6 for p in seen)


def test_an_exception_in_the_progress_callback_stops_the_render():
    calls = []

    def progress(p):
        calls.append(p)
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        embertrace.render(CORNELL, spp=8, resolution=(8, 8), passes=8, progress=progress)
    assert len(calls) == 1


def test_rendering_releases_the_gil():
    # One render thread on a long render; if it held the GIL, this thread
    # could not count until the render returned.
    done = {}

    def work():
        embertrace.render(CORNELL, spp=400, resolution=(64, 64), threads=1)
        done["render"] = time.perf_counter()

    t = threading.Thread(target=work)
    t.start()
    time.sleep(0.05)  # let the render begin
    n = 0
    while n < 100_000:
        n += 1
    counted = time.perf_counter()
    t.join()
    assert counted < done["render"], "the counting waited for the render: the GIL was held"


CHILD = """
import signal, sys, embertrace
# a child started with SIGINT ignored (a non-interactive shell's background
# job, as `cmd &` in a script) keeps it ignored; Ctrl-C's handler is what
# is under test
signal.signal(signal.SIGINT, signal.default_int_handler)
def progress(p):
    if p["pass"] == 1:
        print("rendering", flush=True)
try:
    embertrace.render(sys.argv[1], spp=100000, resolution=(32, 32), passes=100000, progress=progress)
    print("finished", flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
"""


def test_ctrl_c_interrupts_a_render():
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, CORNELL], stdout=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout.readline().strip() == "rendering"
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        out, _ = child.communicate(timeout=60)
        assert out.strip() == "interrupted"
        assert time.monotonic() - sent < 10
        assert child.returncode == 0
    finally:
        child.kill()


def test_plan_names_the_effects():
    plan = embertrace.load(CORNELL).plan()
    assert "effects" in plan and "kernel" in plan
    assert "emission" in plan["effects"] or plan["effects"]


def test_a_missing_file_is_an_os_error():
    with pytest.raises(OSError, match="no-such-scene.toml"):
        embertrace.load("no-such-scene.toml")


def test_a_bad_scene_is_a_scene_error_naming_file_and_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera]\nfov = \n")
    with pytest.raises(embertrace.SceneError, match=r"bad\.toml:2"):
        embertrace.load(str(bad))
    assert issubclass(embertrace.SceneError, ValueError)


def test_bad_arguments_are_value_errors():
    with pytest.raises(ValueError, match="accel"):
        embertrace.render(CORNELL, spp=1, accel="octree")
    with pytest.raises(ValueError):
        embertrace.render(CORNELL, spp=1, passes=0)
    with pytest.raises(ValueError, match="guiding"):
        embertrace.render(CORNELL, spp=1, guiding="maybe")


def test_guiding_is_a_keyword_and_changes_the_samples():
    kw = dict(spp=4, resolution=(8, 8), seed=3, threads=1)
    off = embertrace.render(CORNELL, guiding="off", **kw)
    # auto leaves the Cornell box unguided: the same image as off
    assert (embertrace.render(CORNELL, **kw) == off).all()
    on = embertrace.render(CORNELL, guiding="on", **kw)
    assert on.shape == off.shape
    assert (on != off).any()


DENOISE = "denoise" in embertrace.build_info()["features"].split(",")


@pytest.mark.skipif(DENOISE, reason="this module has the denoiser")
def test_denoise_without_the_feature_says_how_to_get_it():
    with pytest.raises(ValueError, match="Open Image Denoise"):
        embertrace.render(CORNELL, spp=1, resolution=(8, 8), denoise=True)


@pytest.mark.skipif(not DENOISE, reason="a module built without --features denoise")
def test_denoise_smooths_the_image_and_keeps_its_mean():
    kwargs = dict(spp=4, resolution=(64, 64), seed=2)
    noisy = embertrace.render(CORNELL, **kwargs)
    clean = embertrace.render(CORNELL, denoise=True, **kwargs)
    assert clean.shape == noisy.shape and clean.dtype == np.float32
    assert abs(clean.mean() / noisy.mean() - 1) < 0.02
    # neighbouring pixels of the back wall differ far less once denoised
    wall = lambda img: np.abs(np.diff(img[24:40, 24:40, 1], axis=1)).mean()
    assert wall(clean) < wall(noisy) / 3


def test_build_info_names_the_version_and_backend():
    info = embertrace.build_info()
    assert info["version"] == embertrace.__version__
    assert len(info["source"]) == 16
    assert info["embree"] is None or info["embree"].startswith("Embree ")
