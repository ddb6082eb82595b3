#!/usr/bin/env bash
# The backend table of docs/speed.md (section "Ray-query backends: benchmarks"), measured and printed by one run:
# `cargo bench --bench accel` several times, the median of the runs for every figure, with
# the machine (lscpu's model name, cores) and the date above the table.
#
#     docs/accel_table.sh [RUNS]      (default 5; about 3.5 minutes per run on 2 cores)
#
# Queries run on one thread (`RAYON_NUM_THREADS=1`, as in the command of docs/speed.md): rays per
# second of each backend's single-ray calls, and of Embree's 16-wide packets, as ratios to
# Embree's single-ray rate of the same run (absolute rates drift by ±15 % from run to run on a
# shared machine; ratios taken within one run hold better). The ratio printed is the median
# over runs of each run's ratio, with the range of the runs' ratios in brackets; Embree's own
# rate in parentheses is the median of its rates.
# Builds run on every core (Embree's TBB threads, and a rayon pool of one thread per core that
# the bench makes for the BVH, whatever RAYON_NUM_THREADS says), and the BVH once more on one
# thread (benches/accel.rs, `bench_build`). Scenes: the generated Cornell-like box and
# 1M-triangle closed scene, the conference room of scenes/conference-room, and the Stanford
# bunny and dragon when `../shared/scenes` is present (see benches/accel.rs).
# Without Embree, the BVH's absolute rates are printed instead of ratios.
#
# Environment: RUNS (overrides the argument), KEEP=DIR keeps criterion's output and the logs
# in DIR (default: a temporary directory, removed at the end), BENCH=FILE runs that accel
# bench binary (e.g. a copy of an older build's `target/release/deps/accel-*`, for
# before/after figures) instead of building this checkout's.
#
# Timings need a machine that is otherwise idle, or at least not busier during one run than
# another: run it alone.
set -euo pipefail
cd "$(dirname "$0")/.."

runs=${RUNS:-${1:-5}}
if [[ -n ${KEEP:-} ]]; then
    out=$KEEP
    mkdir -p "$out"
else
    out=$(mktemp -d)
    trap 'rm -rf "$out"' EXIT
fi

queries='^(cornell|bunny|dragon|closed1m|conference)/(embree/(closest|occluded|gather)(-batch)?|bvh/(closest|occluded|gather))$'
if [[ -n ${BENCH:-} ]]; then
    bench() { "$BENCH" --bench "$@"; }
else
    cargo bench --bench accel --no-run >&2
    bench() { cargo bench --bench accel -- "$@"; }
fi
for ((r = 1; r <= runs; r++)); do
    echo "run $r of $runs: queries (1 thread)" >&2
    RAYON_NUM_THREADS=1 CRITERION_HOME="$out/run$r/queries" \
        bench --noplot "$queries" >"$out/run$r-queries.log" 2>&1
    echo "run $r of $runs: builds (all cores, and the BVH on one thread)" >&2
    CRITERION_HOME="$out/run$r/build" \
        bench --noplot '^build/' >"$out/run$r-build.log" 2>&1
done

model=$(lscpu | sed -n 's/^Model name: *//p' | head -1)
cores=$(nproc)
embree=$(grep -ho ': embree [0-9][^:]*' "$out/run1-queries.log" | head -1 | sed 's/^: embree //' || true)

python3 - "$out" "$runs" "$model" "$cores" "$embree" <<'EOF'
import glob, json, os, re, statistics, sys, datetime

out, runs, model, cores, embree = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]

def results(d):
    """full id -> (median ns per iteration, elements per iteration or None)"""
    r = {}
    for f in glob.glob(os.path.join(d, "**/new/benchmark.json"), recursive=True):
        b = json.load(open(f))
        est = json.load(open(os.path.join(os.path.dirname(f), "estimates.json")))
        tp = b.get("throughput") or {}
        r[b["full_id"]] = (est["median"]["point_estimate"], tp.get("Elements"))
    return r

runs_q = [results(f"{out}/run{r}/queries") for r in range(1, runs + 1)]
runs_b = [results(f"{out}/run{r}/build") for r in range(1, runs + 1)]

# Triangle counts from the bench's own description of the BVH.
tris = {}
for line in open(f"{out}/run1-queries.log"):
    m = re.match(r"(\w+): bvh \(.*?(\d+) triangles", line)
    if m:
        tris[m.group(1)] = int(m.group(2))

def rate(res, key):
    if key not in res:
        return None
    ns, n = res[key]
    return n / ns * 1e3  # M elements per second

def spread(rs):
    """The median of per-run ratios and their range when there are several ("–" for none)."""
    if not rs:
        return "–"
    m = f"{statistics.median(rs):.2f}"
    return m + (f" [{min(rs):.2f}–{max(rs):.2f}]" if len(rs) > 1 else "")

def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None

names = {"cornell": "Cornell-like box", "bunny": "bunny", "dragon": "dragon",
         "closed1m": "generated closed scene", "conference": "conference room"}
work = {"closest": "closest hit, random rays", "occluded": "occlusion, random segments",
        "gather": "one point → 1,024 targets"}

def count(n):
    return f"{n / 1e6:.0f}M" if n >= 1e6 else (f"{n / 1e3:.0f}k" if n >= 1e3 else str(n))

scenes = [s for s in names if s in tris]
have_embree = any(k.startswith(f"{s}/embree/") for s in scenes for k in runs_q[0])
today = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
print(f"Measured {today} on {model} ({cores} cores){', Embree ' + embree if embree else ''}; "
      f"median of {runs} runs of `docs/accel_table.sh`{' [their range]' if runs > 1 else ''}.")
print()
if have_embree:
    print("| scene (triangles) | workload | Embree single (M rays/s) | Embree 16-wide | pir BVH |")
    print("|---|---|---|---|---|")
else:
    print("| scene (triangles) | workload | pir BVH (M rays/s) |")
    print("|---|---|---|")
for s in scenes:
    for w in work:
        label = f"{names[s]} ({count(tris[s])}) | {work[w]}"
        if have_embree:
            e = med(rate(q, f"{s}/embree/{w}") for q in runs_q)
            def ratio(k):
                rs = []
                for q in runs_q:
                    a, b = rate(q, k), rate(q, f"{s}/embree/{w}")
                    if a is not None and b:
                        rs.append(a / b)
                return spread(rs)
            print(f"| {label} | 1 ({e:.2f}) | {ratio(f'{s}/embree/{w}-batch')} | {ratio(f'{s}/bvh/{w}')} |")
        else:
            print(f"| {label} | {med(rate(q, f'{s}/bvh/{w}') for q in runs_q):.2f} |")
print()

def build_ms(rs, backend, s):
    return med(rs_[f"build/{backend}/{s}"][0] / 1e6 if f"build/{backend}/{s}" in rs_ else None for rs_ in rs)

print("| build (ms) | " + " | ".join(f"{names[s]}" for s in scenes) + " |")
print("|---|" + "---|" * len(scenes))
rows = [(f"pir BVH ({cores} threads)", runs_b, "bvh"), ("pir BVH (1 thread)", runs_b, "bvh-1thread")]
if have_embree:
    rows.append((f"Embree, medium quality (TBB, {cores} threads)", runs_b, "embree"))
for label, rs, backend in rows:
    cells = []
    for s in scenes:
        v = build_ms(rs, backend, s)
        cells.append("–" if v is None else f"{v:.2f}" if v < 1 else f"{v:.1f}")
    print(f"| {label} | " + " | ".join(cells) + " |")
if have_embree:
    cells = []
    for s in scenes:
        rs = [b[f"build/bvh/{s}"][0] / b[f"build/embree/{s}"][0] for b in runs_b
              if f"build/bvh/{s}" in b and f"build/embree/{s}" in b]
        cells.append(spread(rs))
    print(f"| BVH / Embree ({cores} threads, ratio per run) | " + " | ".join(cells) + " |")
EOF
