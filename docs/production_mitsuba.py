#!/usr/bin/env python3
"""Mitsuba 3's side of the production-scale studies (docs/production.sh).

Setup (Debian 12, as root): python3 -m venv VENV; VENV/bin/pip install mitsuba numpy;
apt-get install -y libllvm19 (for llvm_ad_rgb).

    production_mitsuba.py reference SCENE OUTDIR W H --chunk-spp N --chunks C
        Renders the reference in C chunks of N spp, seeds 0 … C−1, one EXR per chunk in OUTDIR
        (written atomically, skipped when already there: an interrupted run resumes), then
        writes OUTDIR/reference.exr, the float64 mean of every chunk there, and prints its spp.
    production_mitsuba.py equal-time SCENE OUT.exr W H --seconds T
        Renders with Mitsuba's own integrator for about T seconds of wall time: a first render
        of 1 spp (its JIT compiled) measures the time per sample pass, then as many spp as fit
        in what is left of T. Prints "spp wall_seconds".
    production_mitsuba.py spp SCENE OUT.exr W H --spp N [--seed S]
        One render of N spp with seed S (default 1), the whole process timed from outside
        (docs/pt_vs_mitsuba.sh: Mitsuba's side at a fixed sample count).

SCENE is a Mitsuba XML file (loaded unchanged but for the film size, through its `resx`/`resy`
defaults as Mitsuba's own examples name them, or the film's width/height otherwise) or a pir
TOML scene, which goes through ../shared/tools/mitsuba_ref.py's independent reading of the
scene contract.
"""
import argparse
import glob
import importlib.util
import os
import sys
import tempfile
import time

import numpy as np
import mitsuba as mi

mi.set_variant(os.environ.get("MI_VARIANT", "llvm_ad_rgb"))
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.environ.get("SHARED", os.path.join(REPO, "..", "shared"))


def load(scene, w, h):
    if scene.endswith(".toml"):
        spec = importlib.util.spec_from_file_location("mitsuba_ref", os.path.join(SHARED, "tools", "mitsuba_ref.py"))
        ref = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(ref)
        with tempfile.TemporaryDirectory() as tmp:
            return mi.load_dict(ref.build(scene, (w, h), None, 1, tmp))
    try:
        return mi.load_file(scene, resx=w, resy=h)
    except Exception:
        s = mi.load_file(scene)
        params = mi.traverse(s)
        params["sensor.film.size"] = [w, h]
        params.update()
        return s


def render(scene, spp, seed):
    return np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)[..., :3]


def write(path, img):
    tmp = path + ".part.exr"
    mi.Bitmap(img.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(tmp)
    os.replace(tmp, path)


def reference(a):
    os.makedirs(a.outdir, exist_ok=True)
    scene = None
    for seed in range(a.chunks):
        path = os.path.join(a.outdir, f"chunk-{seed:04d}.exr")
        if os.path.exists(path):
            continue
        scene = scene or load(a.scene, a.width, a.height)
        t = time.time()
        write(path, render(scene, a.chunk_spp, seed))
        print(f"chunk {seed}: {a.chunk_spp} spp in {time.time() - t:.1f} s", file=sys.stderr, flush=True)
    chunks = sorted(glob.glob(os.path.join(a.outdir, "chunk-*.exr")))
    acc = sum(np.array(mi.Bitmap(c), dtype=np.float64)[..., :3] for c in chunks)
    write(os.path.join(a.outdir, "reference.exr"), acc / len(chunks))
    print(len(chunks) * a.chunk_spp)


def equal_time(a):
    start = time.time()
    scene = load(a.scene, a.width, a.height)
    t = time.time()
    render(scene, 1, 1000)  # compiles the kernels; its time is the cost of one pass after that
    t = time.time()
    render(scene, 1, 1001)
    per_spp = max(time.time() - t, 1e-3)
    spp = max(1, int((a.seconds - (time.time() - start)) / per_spp))
    img = render(scene, spp, 1002)
    write(a.out, img)
    print(spp, f"{time.time() - start:.2f}")


def fixed_spp(a):
    write(a.out, render(load(a.scene, a.width, a.height), a.spp, a.seed))


def main():
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)

    def command(name, out):
        """A sub-command of SCENE OUT WIDTH HEIGHT, OUT named `out`."""
        p = sub.add_parser(name)
        p.add_argument("scene")
        p.add_argument(out)
        p.add_argument("width", type=int)
        p.add_argument("height", type=int)
        return p

    r = command("reference", "outdir")
    r.add_argument("--chunk-spp", type=int, default=32)
    r.add_argument("--chunks", type=int, default=128)
    command("equal-time", "out").add_argument("--seconds", type=float, required=True)
    f = command("spp", "out")
    f.add_argument("--spp", type=int, required=True)
    f.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    {"reference": reference, "equal-time": equal_time, "spp": fixed_spp}[a.cmd](a)


if __name__ == "__main__":
    main()
