#!/usr/bin/env bash
# How the cost of a `pir-bdpt` iteration grows with the scene's triangles, the iteration's VPLs
# and the image's pixels (issue 48, item 3). One thread, the default method and gather; each
# line is one render, and its figures are the renderer's own statistics per iteration: the
# light paths' time (tracing the VPLs and the splats to the camera), the pixels' time (camera
# paths with their gathers), the time per pixel sample, and the rays per pixel sample.
#
#     docs/scaling.sh [SPP]        (default 8; a few minutes on an idle machine)
#
# Environment: SHARED (default ../shared) for the meshes of the dense and big scenes, whose
# lines are skipped with a message when it is absent; PIR, a pir binary to measure instead of
# this checkout's build.
set -euo pipefail
cd "$(dirname "$0")/.."
spp=${1:-8}
shared=${SHARED:-../shared}
# shellcheck source=docs/pir-binary.sh
source docs/pir-binary.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

echo "pir-bdpt, one thread, $spp spp, $(date -u +%Y-%m-%d), load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| what varies | scene | triangles | pixels | VPLs / iteration | light paths ms / iteration | pixels ms / iteration | µs / pixel sample | closest-hit + shadow rays / pixel sample |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"

# line LABEL SCENE W H [pir options…]
line() {
    local label=$1 scene=$2 w=$3 h=$4
    shift 4
    if [[ ! -f $scene ]]; then
        echo "scaling: $scene is missing; its line is skipped" >&2
        return
    fi
    "$pir" render "$scene" --spp "$spp" --resolution "$w" "$h" --threads 1 --quiet \
        --out "$tmp/x.exr" "$@" 2>"$tmp/log" || { cat "$tmp/log" >&2; return 1; }
    local log tris pix prep rays vpls name
    log=$(cat "$tmp/log")
    tris=$(sed -n 's/.*(\([0-9]*\) triangles, [0-9]* emitting).*/\1/p' <<<"$log" | head -1)
    pix=$(sed -n 's/.*(\([0-9.]*\) s pixels, [0-9.]* s preparation).*/\1/p' <<<"$log" | head -1)
    prep=$(sed -n 's/.*s pixels, \([0-9.]*\) s preparation).*/\1/p' <<<"$log" | head -1)
    rays=$(sed -n 's/.*(\([0-9]*\) closest-hit, \([0-9]*\) shadow.*/\1 \2/p' <<<"$log" | head -1)
    vpls=$(sed -n 's/.* \([0-9]*\) VPLs per iteration from.*/\1/p' <<<"$log" | head -1)
    name="$(basename "$(dirname "$scene")")/$(basename "$scene")"
    awk -v label="$label" -v name="$name" -v tris="$tris" -v px=$((w * h)) -v spp="$spp" \
        -v pix="$pix" -v prep="$prep" -v rays="$rays" -v vpls="${vpls:-0}" 'BEGIN {
            split(rays, r, " ")
            printf "| %s | %s | %d | %d | %d | %.2f | %.1f | %.2f | %.1f |\n", label, name, tris, px, vpls,
                1000 * prep / spp, 1000 * pix / spp, 1e6 * pix / (px * spp), (r[1] + r[2]) / (px * spp)
        }'
}

# The scene's triangles, at 128 × 128 and the default light paths.
line triangles scenes/cornell-box/scene.toml 128 128
line triangles scenes/mori-knob/scene.toml 128 128
line triangles scenes/dense/indirect.toml 128 128
line triangles scenes/conference-room/scene.toml 128 128
line triangles "$shared/scenes/mitsuba/living-room/scene.xml" 128 128
# The iteration's VPLs (light paths given), the Cornell box and the conference room at 128 × 128.
for n in 64 256 1024 4096; do line "VPLs (--vpls $n)" scenes/cornell-box/scene.toml 128 128 --vpls "$n"; done
for n in 64 256 1024 4096; do line "VPLs (--vpls $n)" scenes/conference-room/scene.toml 128 128 --vpls "$n"; done
# The image's pixels, the Cornell box and the conference room.
for s in 64 128 256 512; do line pixels scenes/cornell-box/scene.toml "$s" "$s"; done
for s in 128 256 512; do line pixels scenes/conference-room/scene.toml "$((s * 16 / 9))" "$s"; done
