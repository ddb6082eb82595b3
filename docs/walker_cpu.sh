#!/usr/bin/env bash
# CPU time per sample of `pt`'s two walkers (`--walker batched`, `--walker scalar`) on one
# thread, each backend (Embree, pir's BVH), on the Cornell box and the mirror-and-glass box:
# runs alternate between the walkers (PAIRS pairs per scene and backend), and the table gives
# each walker's median CPU time (user + system, /usr/bin/time) in microseconds per sample
# (pixels × spp) and scalar / batched (> 1: the batched walker is faster). Both walkers give
# the same image (checked: the EXRs' relative MSE against each other must be 0).
#
#     docs/walker_cpu.sh [SPP]        (default 32; 256 × 256 pixels)
#
# Environment: PAIRS (default 3), SHARED (default ../shared), PIR (default: builds and uses
# target/release/pir), PIR_ARGS (more render options, e.g. "--sampler independent").
set -euo pipefail
cd "$(dirname "$0")/.."
spp=${1:-32}
pairs=${PAIRS:-3}
shared=${SHARED:-../shared}
read -r -a extra <<<"${PIR_ARGS:-}"
# shellcheck source=docs/pir-binary.sh
source docs/pir-binary.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
samples=$((256 * 256 * spp))
echo "pt, one thread, 256x256, $spp spp, $pairs alternating pairs, $(date -u +%Y-%m-%d), load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-13s %-7s %14s %14s %16s\n' scene accel "batched us/spp" "scalar us/spp" "scalar/batched"
for entry in "cornell-box original" "mirror-glass sphere"; do
    read -r name file <<<"$entry"
    for accel in embree bvh; do
        for walker in batched scalar; do : >"$tmp/$walker"; done
        for _ in $(seq "$pairs"); do
            for walker in batched scalar; do
                /usr/bin/time -f '%U %S' -o "$tmp/time" "$pir" render "$shared/scenes/cornell-box/$file.toml" \
                    --method pt --spp "$spp" --resolution 256 256 --threads 1 --accel "$accel" \
                    --walker "$walker" "${extra[@]}" --no-preview -q -o "$tmp/$walker.exr" >/dev/null 2>&1
                awk '{ print $1 + $2 }' "$tmp/time" >>"$tmp/$walker"
            done
        done
        same=$("$pir" compare "$tmp/batched.exr" "$tmp/scalar.exr" | awk '/^relative MSE/ { print $3 }')
        [[ $same == 0.000000e0 ]] || echo "warning: $name $accel: the walkers' images differ (relative MSE $same)" >&2
        med() { sort -g "$tmp/$1" | awk -v n="$samples" '{ v[NR] = $1 } END { printf "%.4f", v[int((NR + 1) / 2)] * 1e6 / n }'; }
        b=$(med batched)
        s=$(med scalar)
        printf '%-13s %-7s %14s %14s %16s\n' "$name" "$accel" "$b" "$s" "$(awk -v b="$b" -v s="$s" 'BEGIN { printf "%.3f", s / b }')"
    done
done
