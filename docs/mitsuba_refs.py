#!/usr/bin/env python3
"""Render Mitsuba 3 reference images of the public scenes in shared/scenes/mitsuba/.

Setup (Debian 12, as root):
    python3 -m venv VENV
    VENV/bin/pip install mitsuba numpy      # used: mitsuba 3.9.1, drjit 1.5.0
    apt-get install -y libllvm19                          # for the llvm_ad_rgb variant

Usage:
    VENV/bin/python docs/mitsuba_refs.py [--scenes DIR] [--out DIR] [--only JOB ...]
                                                  [--variant llvm_ad_rgb|scalar_rgb]

With no --job, every job runs in its own child process under `/usr/bin/time -v` (so that each
has its own wall time and peak RSS), then results.json and results.md (a markdown table) are
written in --out.  `--job NAME` runs one job in this process and writes NAME.json.

What a job does (nothing of the scene is changed except the film size, set through the scene
file's own <default>s, and the sample count/seed passed to mi.render):
  * load the scene file with mi.load_file(path, <resolution defaults>), timed;
  * reference: `chunks` renders of mi.render(scene, spp=chunk_spp, seed=k), k = 0..chunks-1,
    averaged in float64 and written as a linear float32 RGB EXR (NAME_ref_<spp>spp.exr);
  * low-spp: renders of mi.render(scene, spp=64, seed=s), s = 1000..1003 (seeds disjoint from
    the reference's), the first written as NAME_64spp_seed1000.exr;
  * relative MSE of each low-spp render against the reference:
        relMSE = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01).
    Because the reference has noise of its own, E[measured] ~ true * (1 + 64/ref_spp); the
    "corrected" figure divides by that factor.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

# ../shared beside the checkout (this file is docs/mitsuba_refs.py); the output outside git.
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES_DEFAULT = os.path.join(REPO, "..", "shared", "scenes", "mitsuba")
OUT_DEFAULT = os.path.join(REPO, "out", "mitsuba-refs")
LOW_SPP = 64
LOW_SEEDS = [1000, 1001, 1002, 1003]

# name: (scene file relative to --scenes, load_file keyword overrides, chunk_spp, chunks
#        [, chunk counts after which the partial average is also written])
JOBS = {
    "cornell-box_320x180": ("cornell-box/scene.xml", dict(resx=320, resy=180), 1024, 16),
    "cornell-box_64x36": ("cornell-box/scene.xml", dict(resx=64, resy=36), 1024, 4),
    "veach-mis_320x180": ("veach-mis/scene.xml", dict(resx=320, resy=180), 1024, 4),
    # matpreview's film defaults are `width`/`height` (683x512); 256 x round(256*512/683)=192.
    # Its camera has fov_axis="smaller" (vertical fov fixed), so the 1.3333 vs 1.3340 aspect
    # change only crops 0.05% of the width.
    "matpreview_256x192": ("matpreview/matpreview.xml", dict(width=256, height=192), 1024, 4),
    # Living room: 4096 spp (the first 1024-spp chunk, seed 0, is also written on its own).
    "living-room_320x180": ("living-room/scene.xml", dict(resx=320, resy=180), 1024, 4, [1]),
}
# Extra measurement jobs (not renders): import only, and load only of the living room.
AUX_JOBS = ["baseline-import", "living-room_load"]


def rel_mse(x, r):
    import numpy as np
    return float(np.mean((x - r) ** 2 / (r * r + 0.01)))


def run_job(name, args):
    t_import = time.perf_counter()
    import numpy as np
    import mitsuba as mi
    mi.set_variant(args.variant)
    import_s = time.perf_counter() - t_import
    res = dict(job=name, mitsuba=mi.__version__, variant=mi.variant(), import_s=import_s)
    try:
        import drjit as dr
        res["drjit"] = dr.__version__
    except Exception:
        pass

    if name == "baseline-import":
        return res

    if name == "living-room_load":
        path = os.path.join(args.scenes, "living-room/scene.xml")
        t = time.perf_counter()
        scene = mi.load_file(path)  # file's own defaults (1280x720); resolution does not matter
        res.update(scene=path, load_s=time.perf_counter() - t,
                   shapes=len(scene.shapes()), emitters=len(scene.emitters()))
        return res

    rel, kw, chunk_spp, chunks = JOBS[name][:4]
    partial_saves = JOBS[name][4] if len(JOBS[name]) > 4 else []
    path = os.path.join(args.scenes, rel)
    t = time.perf_counter()
    scene = mi.load_file(path, **kw)
    load_s = time.perf_counter() - t
    film = scene.sensors()[0].film()
    size = [int(v) for v in film.size()]
    res.update(scene=path, overrides=kw, resolution=size, load_s=load_s,
               integrator=" ".join(str(scene.integrator()).split()),
               rfilter=str(film.rfilter()))

    def render(spp, seed):
        t = time.perf_counter()
        img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
        return img, time.perf_counter() - t

    def write(fname, img):
        out = os.path.join(args.out, fname)
        bmp = mi.Bitmap(np.ascontiguousarray(img.astype(np.float32)), mi.Bitmap.PixelFormat.RGB)
        bmp.write(out)
        return out

    acc = None
    chunk_times = []
    partials = []
    for k in range(chunks):
        img, dt = render(chunk_spp, k)
        chunk_times.append(dt)
        acc = img if acc is None else acc + img
        print(f"[{name}] ref chunk {k + 1}/{chunks}: {dt:.1f} s", file=sys.stderr, flush=True)
        if k + 1 in partial_saves:
            part = acc / (k + 1)
            partials.append(dict(spp=chunk_spp * (k + 1), seeds=list(range(k + 1)),
                                 time_s=sum(chunk_times),
                                 mean_rgb=[float(v) for v in part.mean(axis=(0, 1))],
                                 path=write(f"{name}_ref_{chunk_spp * (k + 1)}spp.exr", part),
                                 img=part))
    ref = acc / chunks
    ref_spp = chunk_spp * chunks
    ref_path = write(f"{name}_ref_{ref_spp}spp.exr", ref)
    res["ref"] = dict(path=ref_path, spp=ref_spp, chunk_spp=chunk_spp, seeds=list(range(chunks)),
                      time_s=sum(chunk_times), chunk_times_s=chunk_times,
                      mean_rgb=[float(v) for v in ref.mean(axis=(0, 1))],
                      finite=bool(np.isfinite(ref).all()), shape=list(ref.shape))
    if partials:
        res["partial_refs"] = partials

    low = []
    for i, seed in enumerate(LOW_SEEDS):
        img, dt = render(LOW_SPP, seed)
        entry = dict(spp=LOW_SPP, seed=seed, time_s=dt,
                     mean_rgb=[float(v) for v in img.mean(axis=(0, 1))],
                     rel_mse=rel_mse(img, ref))
        if partials:  # also against each partial reference, e.g. the living room's 1024 spp
            entry["rel_mse_vs_partial"] = {str(pr["spp"]): rel_mse(img, pr["img"]) for pr in partials}
        if i == 0:
            entry["path"] = write(f"{name}_{LOW_SPP}spp_seed{seed}.exr", img)
        low.append(entry)
        print(f"[{name}] {LOW_SPP} spp seed {seed}: {dt:.1f} s relMSE {entry['rel_mse']:.5g}",
              file=sys.stderr, flush=True)
    vals = [e["rel_mse"] for e in low]
    factor = 1.0 + LOW_SPP / ref_spp
    for pr in partials:
        pr["rel_mse_vs_final_ref"] = rel_mse(pr.pop("img"), ref)
    res["low"] = low
    res["rel_mse_64"] = dict(seed1000=vals[0], mean=float(np.mean(vals)), min=min(vals),
                             max=max(vals), ref_noise_factor=factor,
                             mean_corrected=float(np.mean(vals)) / factor)
    return res


TIME_FIELDS = {
    "Elapsed (wall clock) time (h:mm:ss or m:ss)": "process_wall",
    "Maximum resident set size (kbytes)": "peak_rss_kb",
    "User time (seconds)": "user_s",
    "System time (seconds)": "sys_s",
}


def parse_time_v(text):
    out = {}
    for line in text.splitlines():
        line = line.strip()
        for key, field in TIME_FIELDS.items():
            if line.startswith(key + ":"):
                val = line[len(key) + 1:].strip()
                if field == "process_wall":
                    parts = [float(p) for p in val.split(":")]
                    secs = 0.0
                    for p in parts:
                        secs = secs * 60 + p
                    out["process_wall_s"] = secs
                elif field == "peak_rss_kb":
                    out["peak_rss_mib"] = int(val) / 1024.0
                else:
                    out[field] = float(val)
    return out


def fmt3(v):
    return ", ".join(f"{x:.4f}" for x in v)


def write_table(results, out):
    lines = ["| job | scene file | resolution | spp (reference) | seeds | ref time (s) | "
             "load (s) | peak RSS (MiB) | mean R, G, B (reference) | mean R, G, B (64 spp, seed 1000) | "
             "Mitsuba relMSE @64 spp, seed 1000 | mean of 4 seeds [min–max] | corrected for ref noise |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        if "ref" not in r:
            continue
        ref, m = r["ref"], r["rel_mse_64"]
        scene = os.path.relpath(r["scene"], os.path.dirname(os.path.dirname(r["scene"])))
        seeds = f"{ref['seeds'][0]}–{ref['seeds'][-1]} (×{ref['chunk_spp']})" if len(ref["seeds"]) > 1 \
            else f"{ref['seeds'][0]}"
        lines.append(
            f"| {r['job']} | `{scene}` | {r['resolution'][0]}×{r['resolution'][1]} | {ref['spp']} | "
            f"{seeds}; 64 spp: {', '.join(str(e['seed']) for e in r['low'])} | {ref['time_s']:.1f} | "
            f"{r['load_s']:.3f} | {r.get('peak_rss_mib', float('nan')):.0f} | {fmt3(ref['mean_rgb'])} | "
            f"{fmt3(r['low'][0]['mean_rgb'])} | {m['seed1000']:.5f} | {m['mean']:.5f} "
            f"[{m['min']:.5f}–{m['max']:.5f}] | {m['mean_corrected']:.5f} |")
    with open(os.path.join(out, "results.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", default=SCENES_DEFAULT)
    ap.add_argument("--out", default=OUT_DEFAULT)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--job")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--load-repeats", type=int, default=3)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    if args.job:
        res = run_job(args.job, args)
        with open(os.path.join(args.out, args.job + ".json"), "w") as f:
            json.dump(res, f, indent=1)
        return

    names = args.only or (AUX_JOBS + list(JOBS))
    results = []
    for name in names:
        repeats = args.load_repeats if name in AUX_JOBS else 1
        for rep in range(repeats):
            cmd = ["/usr/bin/time", "-v", sys.executable, os.path.abspath(__file__), "--job", name,
                   "--scenes", args.scenes, "--out", args.out, "--variant", args.variant]
            print(" ".join(cmd), file=sys.stderr, flush=True)
            p = subprocess.run(cmd, stderr=subprocess.PIPE, text=True)
            sys.stderr.write("\n".join(l for l in p.stderr.splitlines() if l.startswith("[")) + "\n")
            if p.returncode != 0:
                print(p.stderr, file=sys.stderr)
                results.append(dict(job=name, failed=True, returncode=p.returncode,
                                    stderr_tail=p.stderr[-2000:]))
                continue
            with open(os.path.join(args.out, name + ".json")) as f:
                res = json.load(f)
            res.update(parse_time_v(p.stderr))
            res["repeat"] = rep
            if repeats > 1:
                os.rename(os.path.join(args.out, name + ".json"),
                          os.path.join(args.out, f"{name}.{rep}.json"))
            else:
                with open(os.path.join(args.out, name + ".json"), "w") as f:
                    json.dump(res, f, indent=1)
            results.append(res)

    # Merge with results of earlier runs (when --only re-runs a subset).
    path = os.path.join(args.out, "results.json")
    old = []
    if args.only and os.path.exists(path):
        with open(path) as f:
            old = [r for r in json.load(f) if r["job"] not in names]
    results = old + results
    order = AUX_JOBS + list(JOBS)
    results.sort(key=lambda r: (order.index(r["job"]) if r["job"] in order else 99, r.get("repeat", 0)))
    with open(path, "w") as f:
        json.dump(results, f, indent=1)
    print(write_table(results, args.out))
    for r in results:
        if r["job"] in AUX_JOBS and not r.get("failed"):
            print(f"{r['job']} #{r['repeat']}: load {r.get('load_s', 0):.3f} s, import {r['import_s']:.2f} s, "
                  f"process wall {r['process_wall_s']:.2f} s, peak RSS {r['peak_rss_mib']:.0f} MiB")


if __name__ == "__main__":
    main()
