# Instructions per ray of a backend's single-ray query, counted by single-stepping it in gdb:
# the real code path of the machine it runs on, AVX-512 versions included, which valgrind 3.19
# cannot run (it reports a CPU without AVX-512, so that pir and Embree run their AVX2 code).
#
#     cargo build --release --example accel_ratio
#     strip --strip-debug -o /tmp/ar target/release/examples/accel_ratio   # (faster steps)
#     BIN=/tmp/ar BACKEND=bvh SCENE=bunny WORKLOAD=gather RAYS=256 OUT=/tmp/bvh.txt \
#         gdb -q -batch -x docs/stepcount.py
#
# BACKEND: bvh (the traversal version `VERSION` names, which must be the one the CPU runs:
# `avx512`, the default, on CPUs with Ice Lake's AVX-512 set, else `avx2`, or `baseline`
# without AVX2) or embree (from `rtcOccluded1` or
# `rtcIntersect1` to its return, the API's checks included). WORKLOAD: a workload of
# `accel_ratio` (closest, occluded, gather); closest steps the closest-hit query, the others
# occlusion. RAYS: how many of the workload's rays, from the first (`SKIP` leaves some out
# first). OUT gets the count of each ray, their mean, and how often each instruction address
# ran (addresses as the process saw them: subtract the load address, 0x555555554000 for pir's
# binary under gdb, to find them in `objdump -d`).
#
# About 2,500 steps a second: 256 gather rays of the bunny take under two minutes. Counts are
# of instructions, not time, and the same on every run of the same binary.
import collections
import os
import subprocess

import gdb

env = os.environ
binary = env["BIN"]
backend = env.get("BACKEND", "bvh")
scene = env.get("SCENE", "bunny")
workload = env.get("WORKLOAD", "gather")
rays = int(env.get("RAYS", "64"))
skip = int(env.get("SKIP", "0"))
out = env.get("OUT", "/dev/stdout")
closest = workload == "closest"

gdb.execute("set pagination off")
# The quoted symbol names below are C syntax (gdb would pick Rust's from debug info).
gdb.execute("set language c")
gdb.execute("set confirm off")
gdb.execute("file " + binary)
if backend == "embree":
    gdb.execute("break *" + ("rtcIntersect1" if closest else "rtcOccluded1"))
elif backend == "bvh":
    entry = "closest_hit_dispatch" if closest else "any_hit_dispatch"
    version = env.get("VERSION", "avx512")
    symbols = subprocess.run(["nm", binary], capture_output=True, text=True, check=True).stdout
    found = [
        line.split()[2]
        for line in symbols.splitlines()
        if entry + "_" in line
        and "resolver" not in line
        and (
            "avx512" in line
            if version == "avx512"
            else "avx2" in line and "avx512" not in line
            if version == "avx2"
            else "avx2" not in line
        )
    ]
    if not found:
        raise SystemExit(f"no {version} version of {entry} in {binary}")
    gdb.execute(f"break *'{found[0]}'")
else:
    raise SystemExit(f"BACKEND={backend}: expected bvh or embree")

gdb.execute(f"run {backend} {scene} {workload} 1 > /dev/null")
if not gdb.selected_inferior().pid:
    raise SystemExit("the query was never called: is VERSION the version this CPU runs?")
counts = []
where = collections.Counter()
inferior = gdb.selected_inferior()
for k in range(skip + rays):
    if not inferior.pid:
        print(f"the program ended after {k} queries: fewer than SKIP + RAYS")
        break
    # The breakpoint is on the function's first instruction (`break *`: a plain `break`
    # skips a prologue, after which the return address is no longer on top of the stack);
    # step until the return.
    sp = int(gdb.parse_and_eval("$sp"))
    ret = int.from_bytes(bytes(inferior.read_memory(sp, 8)), "little")
    n = 0
    while True:
        pc = int(gdb.selected_frame().pc())
        if pc == ret:
            break
        if k >= skip:
            where[pc] += 1
        gdb.execute("stepi", to_string=True)
        n += 1
    if k >= skip:
        counts.append(n)
    gdb.execute("continue", to_string=True)

mean = sum(counts) / max(len(counts), 1)
with open(out, "w") as f:
    f.write(f"{backend} {scene} {workload}: {len(counts)} rays, mean {mean:.1f} instructions\n")
    f.write("per ray: " + " ".join(map(str, counts)) + "\n")
    for pc, c in sorted(where.items()):
        f.write(f"{pc:x} {c}\n")
if inferior.pid:
    gdb.execute("kill")
