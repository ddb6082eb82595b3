#!/usr/bin/env bash
# pir's path tracer against Mitsuba 3's, side by side (issue 13): the Cornell box, the
# mirror-and-glass box, the Cornell box with the bunny and Veach's MIS scene in Mitsuba's own
# XML, each rendered by both at the same sample count, with each one's wall time (the whole
# process: start-up, scene load, BVH build, for Mitsuba its JIT), its CPU time (user + system, all threads), relative MSE against the
# reference (`pir compare`: mean over pixels and channels of (x − r)² / (r² + 0.01)) and
# efficiency = 1 / (relative MSE × wall time). The last columns are pir's efficiency over
# Mitsuba's (≥ 1: pir is at least as efficient), by wall time and by CPU time; on a machine
# shared with other work the CPU-time ratio is the steadier of the two. pir writes its EXR alone
# (`--no-preview`), as Mitsuba does.
#
#     docs/pt_vs_mitsuba.sh [SPP]          (default 512; about 2 minutes per scene on 2 cores)
#
# Environment:
#   MITSUBA_PYTHON  a Python with the `mitsuba` and `numpy` packages (default: /tmp/mi/bin/python
#                   if it exists). Without one, only pir's figures are printed. To set one up
#                   (as root, once per machine):
#                       apt-get install -y libllvm19
#                       python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba numpy
#   SHARED          the shared data folder (default: ../shared beside the checkout), which holds
#                   the scenes, the references and tools/mitsuba_ref.py.
#   BUNNY_REF       the bunny scene's reference EXR (default: $SHARED/references/cornell-bunny.exr,
#                   else target/bench-refs/cornell-bunny.exr; docs/bunny-reference.sh, shared with
#                   docs/results.sh). When missing and Mitsuba is there, it is rendered first
#                   (8,192 spp, about 2 minutes); a scene with no reference is skipped with a
#                   message.
#   RUNS            renders per renderer and scene; the median time is used (default 1).
#   SEED            seed of both renderers (default 1; the shared references use Mitsuba's 0).
#   SAMPLERS        pir's samplers to measure, each against the same Mitsuba run (default
#                   "sobol independent": pir's default, and the independent numbers that
#                   Mitsuba's `independent` sampler, which mitsuba_ref.py uses, also draws);
#                   "default" passes no --sampler, for a pir older than that option).
#   PIR             a pir binary to measure instead of this checkout's (e.g. an older build, for
#                   before/after figures); by default the script builds and uses target/release/pir.
#   PIR_ARGS        more options for every pir render (e.g. "--threads 1"), word-split.
#   SCENES          the scenes to measure, by name (default "cornell-box mirror-glass bunny
#                   veach-mis"). veach-mis is Mitsuba's own XML file of Veach's multiple-importance
#                   test (shared/scenes/mitsuba/veach-mis), rendered by both at 320×180: Mitsuba
#                   loads it unchanged but for the film size (docs/production_mitsuba.py spp), pir
#                   reads it as Mitsuba 3 would. Its reference (Mitsuba, 4,096 spp, about a minute)
#                   is rendered into target/bench-refs/ when missing and Mitsuba is there.
#
#   CALLGRIND      1: also count pir's instructions per sample under callgrind (valgrind's
#                   tool; slow): two renders at 64×64 of 2 and 4 spp on one thread, their
#                   difference per pixel sample, so that loading and building count for
#                   nothing. Valgrind's CPU has no AVX-512, so Embree and pir run their AVX2 code.
#
# After each scene's rows, pir's rays per second in the render (its summary's Mrays/s, all
# threads) against `pir rays`' rate for the scene's bounce rays traced in 16-wide batches
# with nothing else done (the same threads and backend): the share of the backend's own
# limit that the path tracer reaches.
#
# The first lines say which vector width each renderer runs at: the CPU's widest vector ISA
# (from /proc/cpuinfo's flags), the packet width pir's Embree wrapper picks for its batch
# queries (from pir's render summary), and the lane count of Mitsuba's LLVM backend (Dr.Jit's
# `jit_llvm_vector_width`).
#
# Timings need an otherwise idle machine: run it alone. Both renderers use every core.
set -euo pipefail
cd "$(dirname "$0")/.."

spp=${1:-512}
runs=${RUNS:-1}
seed=${SEED:-1}
samplers=${SAMPLERS:-sobol independent}
read -r -a pir_args <<<"${PIR_ARGS:-}"
wanted=${SCENES:-cornell-box mirror-glass bunny veach-mis}
shared=${SHARED:-../shared}
py=${MITSUBA_PYTHON:-}
if [[ -z $py && -x /tmp/mi/bin/python ]]; then py=/tmp/mi/bin/python; fi
if [[ -n $py ]] && ! "$py" -c 'import mitsuba' 2>/dev/null; then
    echo "note: $py cannot import mitsuba; pir only" >&2
    py=
fi

# shellcheck source=docs/pir-binary.sh
source docs/pir-binary.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

bunny_ref=
if [[ " $wanted " == *" bunny "* ]]; then bunny_ref=$(docs/bunny-reference.sh "$shared" "$py"); fi

# A Mitsuba XML scene's reference at W×H: Mitsuba, 16 chunks of 256 spp, kept in target/bench-refs/.
xml_reference() {
    local scene=$1 name=$2 w=$3 h=$4 dir=target/bench-refs/$2-${3}x$4
    if [[ ! -f $dir/reference.exr && -n $py && -f $scene ]]; then
        echo "$name: rendering its Mitsuba reference (4,096 spp) into $dir" >&2
        "$py" docs/production_mitsuba.py reference "$scene" "$dir" "$w" "$h" --chunk-spp 256 --chunks 16 >/dev/null
    fi
    echo "$dir/reference.exr"
}
veach_xml=$shared/scenes/mitsuba/veach-mis/scene.xml
veach_ref=
if [[ " $wanted " == *" veach-mis "* ]]; then veach_ref=$(xml_reference "$veach_xml" veach-mis 320 180); fi

# name scene reference [width height: an XML scene's film size for both renderers]
scenes=(
    "cornell-box $shared/scenes/cornell-box/original.toml $shared/references/cornell-box-original.exr"
    "mirror-glass $shared/scenes/cornell-box/sphere.toml $shared/references/cornell-box-sphere.exr"
    "bunny $shared/scenes/bunny/cornell-bunny.toml $bunny_ref"
    "veach-mis $veach_xml $veach_ref 320 180"
)

# seconds COMMAND… : "wall cpu" seconds of one run (cpu = user + system of all its threads)
seconds() {
    /usr/bin/time -f '%e %U %S' -o "$tmp/time" "$@" >"$tmp/log" 2>&1 || { cat "$tmp/log" >&2; return 1; }
    awk '{ printf "%.2f %.2f", $1, $2 + $3 }' "$tmp/time"
}

relmse() { "$pir" compare "$1" "$2" | awk '/^relative MSE/ { print $3 }'; }

# measure REFERENCE OUT.exr COMMAND… : "wall cpu relmse" of the median-wall-time run, whose
# log is left in $tmp/log
measure() {
    local ref=$1 out=$2
    shift 2
    local runs_out=() i median
    for i in $(seq "$runs"); do
        runs_out+=("$(seconds "$@") $(relmse "$out" "$ref") $i")
        cp "$tmp/log" "$tmp/log.$i"
    done
    median=$(printf '%s\n' "${runs_out[@]}" | sort -g | awk '{ v[NR] = $0 } END { print v[int((NR + 1) / 2)] }')
    cp "$tmp/log.${median##* }" "$tmp/log"
    echo "${median% *}"
}

eff() { awk -v t="$1" -v e="$2" 'BEGIN { printf "%.4g", 1 / (t * e) }'; }

# ratio PIR_SECONDS MITSUBA_SECONDS : pir's efficiency over Mitsuba's, with the relative MSEs
# e_pir and e_mi of the scene being measured
ratio() { awk -v a="$1" -v b="$2" -v x="$e_pir" -v y="$e_mi" 'BEGIN { printf "%.2f", (b * y) / (a * x) }'; }

# The CPU's widest vector ISA, from its flags.
cpu_isa() {
    local flags
    flags=" $(grep -m1 '^flags' /proc/cpuinfo | cut -d: -f2) "
    for isa in avx512f:AVX-512 avx2:AVX2 avx:AVX sse4_2:SSE4.2; do
        if [[ $flags == *" ${isa%%:*} "* ]]; then
            echo "${isa#*:}"
            return
        fi
    done
    echo "SSE2 or other"
}
cpu_model=$(grep -m1 '^model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
# pir's accelerator line of a one-sample render: its ISA, native packets and batch width.
pir_accel=$("$pir" render "$shared/scenes/cornell-box/original.toml" --method pt --spp 1 --no-preview \
    --resolution 8 8 -o "$tmp/probe.exr" 2>&1 | sed -n 's/^pir: accelerator //p')
pir_packets=$(sed -n 's/.*batches in \([0-9]*\)-wide packets.*/\1/p' <<<"$pir_accel")
mi_width=
if [[ -n $py ]]; then
    mi_width=$("$py" -c '
import ctypes, os, drjit as dr, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
dr.eval(dr.llvm.Float(1) + 1)
lib = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
f = getattr(lib, "_Z21jit_llvm_vector_widthv")
f.restype = ctypes.c_uint32
print(f())' 2>/dev/null || echo "?")
fi
echo "cpu: $cpu_model, vector ISA $(cpu_isa), $(nproc) threads"
echo "pir: ${pir_packets:-?}-wide Embree packets for batch queries (accelerator: ${pir_accel:-unknown})${PIR_ARGS:+, options: $PIR_ARGS}"
[[ -n $py ]] && echo "mitsuba: llvm_ad_rgb, ${mi_width:-?}-wide LLVM vectors"
echo "pir pt vs Mitsuba 3 path, $spp spp, seed $seed, $(nproc) threads, $(date -u +%Y-%m-%d), load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-13s %-17s %8s %8s %12s %11s %12s %12s\n' scene renderer wall/s cpu/s "rel. MSE" efficiency \
    "pir/Mi wall" "pir/Mi cpu"
rates=()
for entry in "${scenes[@]}"; do
    read -r name scene ref width height <<<"$entry"
    [[ " $wanted " == *" $name "* ]] || continue
    if [[ ! -f $ref ]]; then
        echo "$name: no reference ($ref); skipped" >&2
        continue
    fi
    size=()
    [[ -n ${width:-} ]] && size=(--resolution "$width" "$height")
    if [[ -n $py ]]; then
        if [[ $scene == *.xml ]]; then
            mi_cmd=("$py" docs/production_mitsuba.py spp "$scene" "$tmp/mi.exr" "$width" "$height" --spp "$spp"
                --seed "$seed")
        else
            mi_cmd=("$py" "$shared/tools/mitsuba_ref.py" "$scene" "$tmp/mi.exr" --spp "$spp" --seed "$seed")
        fi
        read -r w_mi c_mi e_mi < <(measure "$ref" "$tmp/mi.exr" "${mi_cmd[@]}")
        printf '%-13s %-17s %8s %8s %12s %11s\n' "$name" "mitsuba" "$w_mi" "$c_mi" "$e_mi" "$(eff "$w_mi" "$e_mi")"
    fi
    for sampler in $samplers; do
        choice=(--sampler "$sampler")
        [[ $sampler == default ]] && choice=()
        read -r w_pir c_pir e_pir < <(measure "$ref" "$tmp/pir.exr" \
            "$pir" render "$scene" --method pt --spp "$spp" --seed "$seed" "${size[@]}" "${choice[@]}" \
            --no-preview "${pir_args[@]}" -o "$tmp/pir.exr")
        row=$(printf '%-13s %-17s %8s %8s %12s %11s' "$name" "pir ($sampler)" "$w_pir" "$c_pir" "$e_pir" \
            "$(eff "$w_pir" "$e_pir")")
        if [[ -n $py ]]; then
            row="$row $(printf '%12s %12s' "$(ratio "$w_pir" "$w_mi")" "$(ratio "$c_pir" "$c_mi")")"
        fi
        echo "$row"
        rates+=("$(sed -n 's/.* \([0-9.]*\) Mrays\/s .*/\1/p' "$tmp/log" | head -1)")
    done
    # The backend's own rate for this scene's bounce rays, batched, on the same threads.
    raw=$("$pir" rays "$scene" "${size[@]}" "${pir_args[@]}" 2>/dev/null | awk '/^bounce, closest hit/ { print $4 }')
    printf '%-13s rays: %s Mrays/s in the renders (%s), %s Mrays/s for bounce rays alone (pir rays): %s\n' \
        "$name" "${rates[*]}" "$samplers" "${raw:-?}" \
        "$(awk -v r="${rates[0]:-0}" -v b="${raw:-0}" 'BEGIN { if (b > 0) printf "%.0f %% of the limit", 100 * r / b; else print "?" }')"
    rates=()
    if [[ ${CALLGRIND:-0} == 1 ]]; then
        instructions() {
            valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" "$pir" render "$scene" --method pt \
                --spp "$1" --resolution 64 64 --threads 1 --seed "$seed" -o "$tmp/cg.exr" >/dev/null 2>&1
            sed -n 's/^summary: \([0-9]*\).*/\1/p' "$tmp/cg.out"
        }
        i2=$(instructions 2) i4=$(instructions 4)
        printf '%-13s instructions per pixel sample (callgrind, pir default sampler, 64×64, one thread): %s\n' \
            "$name" "$(awk -v a="$i2" -v b="$i4" 'BEGIN { printf "%.0f", (b - a) / (64 * 64 * 2) }')"
    fi
done
