#!/usr/bin/env bash
# Renders every method (and the gathers, connections and samplers that take other code paths)
# on a few scenes with both ray-query backends, at a small size and a fixed seed, and prints one
# pixel hash per image (examples/exr_hash.rs). Run it before and after a change that must not
# change any image and diff the two outputs:
#
#     docs/bitexact.sh > before.txt; (change); docs/bitexact.sh > after.txt; diff before.txt after.txt
#
# PIR=BINARY measures another build (e.g. a copy of the binary from before the change) instead
# of this checkout's.
#
# About 3 minutes on 2 cores. OUT (default a temporary folder) keeps the images.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet --bin pir --example exr_hash
PIR=${PIR:-target/release/pir}
OUT="${OUT:-$(mktemp -d)}"
mkdir -p "$OUT"

SCENES="scenes/cornell-box/scene.toml scenes/cornell-box/glossy.toml scenes/stress/caustic/scene.toml
        scenes/stress/slit/scene.toml scenes/mori-knob/scene.toml"
# Every method at its defaults, then the other code paths: each gather for points, spheres,
# weighed points and pir-bdpt, pir-bdpt's connections and light samples, explicit counts,
# independent numbers.
CONFIGS=(
  "pt" "ir" "ir-clamp" "pir-clamp" "vsl" "pir-vsl" "pir-mis" "pir-bdpt"
  "pt --sampler independent" "pir-bdpt --sampler independent"
  "pir-clamp --gather tree" "pir-clamp --gather resample --gather-samples 3 --gather-candidates 20"
  "ir --gather resample" "vsl --gather tree" "pir-vsl --gather resample --radius 0.05"
  "pir-mis --gather all" "pir-mis --gather tree"
  "pir-bdpt --gather all" "pir-bdpt --gather tree" "pir-bdpt --connect all --light-samples 3"
  "pir-bdpt --connect first-two --vpls 16" "pir-clamp --max-depth 3 --vpls 7"
)
for scene in $SCENES; do
  name=$(echo "$scene" | sed 's|scenes/||; s|/|_|g; s|\.toml||')
  for backend in embree bvh; do
    for config in "${CONFIGS[@]}"; do
      tag=$(echo "$config" | tr ' ' '_' | tr -d '-')
      out="$OUT/${name}__${backend}__${tag}.exr"
      # shellcheck disable=SC2086
      $PIR render "$scene" --method $config --accel "$backend" --resolution 40 30 --spp 3 \
        --seed 7 --threads 2 --quiet --out "$out" >/dev/null
    done
  done
done
target/release/examples/exr_hash "$OUT"/*.exr | sed "s|$OUT/||"
