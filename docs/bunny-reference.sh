#!/usr/bin/env bash
# The reference of the Cornell box with the bunny (../shared/scenes/bunny/cornell-bunny.toml),
# which is not committed; docs/results.sh and docs/pt_vs_mitsuba.sh both measure against it.
# Prints its path: BUNNY_REF, else SHARED/references/cornell-bunny.exr if present, else
# target/bench-refs/cornell-bunny.exr. When that file is missing, the scene is there and PYTHON
# (a Python that imports mitsuba, see SHARED/tools/mitsuba_ref.py) is given, renders it first:
# Mitsuba 3, 8,192 spp, seed 7 (about 2 minutes on 2 cores with `llvm_ad_rgb`).
#
#     docs/bunny-reference.sh SHARED [PYTHON]
set -euo pipefail
shared=$1
py=${2:-}
scene=$shared/scenes/bunny/cornell-bunny.toml
ref=${BUNNY_REF:-}
if [[ -z $ref ]]; then
    ref=$shared/references/cornell-bunny.exr
    [[ -f $ref ]] || ref=target/bench-refs/cornell-bunny.exr
fi
if [[ ! -f $ref && -f $scene && -n $py ]]; then
    echo "rendering the bunny's reference with Mitsuba (8,192 spp) into $ref" >&2
    mkdir -p "$(dirname "$ref")"
    "$py" "$shared/tools/mitsuba_ref.py" "$scene" "$ref" --spp 8192 --seed 7 >&2
fi
echo "$ref"
