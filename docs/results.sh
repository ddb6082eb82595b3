#!/usr/bin/env bash
# Regenerates the studies that docs/results.md shows. One command:
#
#     docs/results.sh            (from the checkout; about 80 minutes on 2 cores)
#
# Every study races the methods at equal wall-clock time, one at a time on all threads, so the
# machine should be otherwise idle. TIME_SCALE=0.25 docs/results.sh makes every budget a
# quarter as long (a quick look, not the published figures). ONLY=REGEX docs/results.sh runs
# only the studies whose names match (e.g. ONLY=mis for the weighed connections' studies). The
# Cornell box's reference is the project's shared Mitsuba 3 reference (../shared, beside the
# checkout); without it that study is skipped with a message. The others use references
# committed under scenes/.
#
# Where the output goes, so that a rerun adds numbers to git and not megabytes of images:
# - out/results/NAME/ (ignored by git: /out in .gitignore) gets everything `pir study` writes:
#   every chart as PNG and SVG, the image sheet, the final EXRs, the report;
# - docs/results/NAME/ (in git) gets the numbers, report.md, snapshots.csv and study.json, and
#   one chart as SVG (the relative MSE against time, the final relative MSE against the swept
#   parameter for a sweep, or the chart docs/results.md shows; see `chart_of`). Its report.md
#   links that chart and points the other images' links to out/results/NAME/.
set -euo pipefail
cd "$(dirname "$0")/.."

scale=${TIME_SCALE:-1}
secs() { awk -v t="$1" -v s="$scale" 'BEGIN { printf "%g", t * s }'; }

cargo build --release --quiet
pir=target/release/pir
out=docs/results
images=out/results
mkdir -p "$out" "$images"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Whether the study NAME is to run (ONLY).
wanted() { [[ $1 =~ ${ONLY:-.} ]]; }

# The chart kept in git for a study whose docs/results.md section shows another one than the
# relative MSE against time.
declare -A chart_of=([corner-diffuse]=max_rel_se [corner-glossy]=max_rel_se [glossy]=max_rel_se)

# keep NAME: copies the numbers and one chart of study NAME from $images/NAME to $out/NAME,
# its report's image links pointing to the kept chart or to $images/NAME.
keep() {
    local name=$1 from=$images/$1 to=$out/$1 chart=${chart_of[$1]:-rel_mse}
    [ -f "$from/sweep-rel_mse.svg" ] && chart=sweep-rel_mse
    mkdir -p "$to"
    cp "$from/report.md" "$from/snapshots.csv" "$from/study.json" "$from/$chart.svg" "$to/"
    sed -i -e "s#](\([A-Za-z0-9_.-]*\.\(png\|svg\|exr\)\))#](../../../$from/\1)#g" \
        -e "s#](../../../$from/$chart\.\(png\|svg\))#]($chart.svg)#g" \
        -e "1a\\
\\
In git: this report, \`snapshots.csv\`, \`study.json\` and \`$chart.svg\`. The other charts, the image\\
sheet and the final EXRs are written by \`docs/results.sh\` to \`$from/\` (not in git)." \
        "$to/report.md"
}

# study NAME SCENE REFERENCE SECONDS [more pir study flags…]
study() {
    local name=$1 scene=$2 reference=$3 time=$4
    shift 4
    wanted "$name" || return 0
    echo "== $name: $scene, $(secs "$time") s per line" >&2
    rm -rf "${images:?}/$name" "${out:?}/$name"
    "$pir" study "$scene" --reference "$reference" --time "$(secs "$time")" --out "$images/$name" "$@"
    keep "$name"
}

# pt_1024 SCENE REFERENCE NAME: the relative MSE of pt at 1,024 spp against REFERENCE, the error
# each line's time is measured against (--target-rel-mse).
pt_1024() {
    "$pir" render "$1" --spp 1024 --out "$tmp/$3-pt-1024.exr" --quiet >&2
    local e
    e=$("$pir" compare "$tmp/$3-pt-1024.exr" "$2" | awk '/^relative MSE/ { print $3 }')
    echo "$3, pt at 1,024 spp: relative MSE $e" >&2
    echo "$e"
}

# Scenes with their references (SCENE REFERENCE).
shared=../shared
cornell=("$shared/scenes/cornell-box/original.toml" "$shared/references/cornell-box-original.exr")
cornell_glossy=(scenes/cornell-box/glossy.toml scenes/cornell-box/reference-glossy-128.exr)
corner=(scenes/stress/corner/scene.toml scenes/stress/corner/reference-64.exr)
near_mirror=(scenes/stress/glossy/scene.toml scenes/stress/glossy/reference-128.exr)
slit=(scenes/stress/slit/scene.toml scenes/stress/slit/reference-128.exr)
mori=(scenes/mori-knob/scene.toml scenes/mori-knob/reference-256.exr)
dense_indirect=(scenes/dense/indirect.toml scenes/dense/reference-indirect-256.exr)
dense_direct=(scenes/dense/direct.toml scenes/dense/reference-direct-256.exr)

# The resampled gather's settings in its studies (docs/results.md, "The resampled gather"), and
# the thesis' consistent methods with it against pt: is it the better default for them too?
resample=(--gather resample --vpls 256 --gather-candidates 128 --gather-samples 4)
thesis_resample=(--methods pt,pir-clamp,pir-vsl "${resample[@]}")

if [ -f "${cornell[1]}" ]; then
    # The error of pt at 1,024 spp is the target each method's time is measured against
    # (rendered only if a study that uses it is to run).
    target=
    for name in cornell-box cornell-box-mis cornell-box-resample cornell-box-thesis-resample; do
        wanted "$name" && target=pending
    done
    if [ -n "$target" ]; then
        target=$(pt_1024 "${cornell[@]}" cornell)
    fi
    # pir-mis and pir-bdpt at their defaults (docs/results.md, "Weighed connections" and
    # "Bidirectional weights") against pt and pir-clamp.
    study cornell-box-mis "${cornell[@]}" 60 --target-rel-mse "$target" --methods pt,pir-clamp,pir-mis,pir-bdpt
    study cornell-box "${cornell[@]}" 60 --target-rel-mse "$target"
    # The resampled gather against pt, same target.
    study cornell-box-resample "${cornell[@]}" 60 --target-rel-mse "$target" --methods pt,pir-clamp "${resample[@]}"
    study cornell-box-thesis-resample "${cornell[@]}" 60 --target-rel-mse "$target" "${thesis_resample[@]}"
    # The thesis' parameter study (figures 5.1-5.4), at 128x128.
    for sweep in alpha=0.3,0.5,0.6,0.7,0.9 clamp=1,3,10,30,100 radius=0.02,0.05,0.1,0.2,0.4; do
        study "sweep-${sweep%%=*}" "${cornell[@]}" 10 --resolution 128 128 --sweep "$sweep"
    done
else
    echo "skipping the Cornell box studies: $shared/references is absent" >&2
fi

study cornell-glossy "${cornell_glossy[@]}" 30
study corner-diffuse scenes/stress/corner/diffuse.toml scenes/stress/corner/reference-diffuse-64.exr 10
study corner-glossy "${corner[@]}" 10
study glossy "${near_mirror[@]}" 20
# The radius trade-off where it bites: glossy receivers want larger spheres than creases do.
study sweep-radius-glossy "${near_mirror[@]}" 10 --resolution 64 64 --sweep radius=0.02,0.05,0.1,0.2
study slit "${slit[@]}" 20
study slit-resample "${slit[@]}" 20 --methods pt,pir-clamp "${resample[@]}"
study caustic scenes/stress/caustic/scene.toml scenes/stress/caustic/reference-128.exr 20
# pir-mis and pir-bdpt at their defaults on the glossy scenes and the slit, against pt and the
# thesis' best.
study cornell-glossy-mis "${cornell_glossy[@]}" 30 --methods pt,pir-clamp,pir-vsl,pir-mis,pir-bdpt
study glossy-mis "${near_mirror[@]}" 20 --methods pt,pir-clamp,pir-vsl,pir-mis,pir-bdpt
study corner-glossy-mis "${corner[@]}" 10 --methods pt,pir-clamp,pir-vsl,pir-mis,pir-bdpt
study slit-mis "${slit[@]}" 20 --methods pt,pir-clamp,pir-mis,pir-bdpt
# The thesis' methods with the resampled gather on the same scenes.
study cornell-glossy-thesis-resample "${cornell_glossy[@]}" 30 "${thesis_resample[@]}"
study glossy-thesis-resample "${near_mirror[@]}" 20 "${thesis_resample[@]}"
study corner-glossy-thesis-resample "${corner[@]}" 10 "${thesis_resample[@]}"
study slit-thesis-resample "${slit[@]}" 20 "${thesis_resample[@]}"
# Issue 12's bars as it states them (256x256, 30 s): the glossy scenes, pt against the
# methods that weigh their connections (the knob's study below is at 256x256 already).
study cornell-glossy-256 scenes/cornell-box/glossy.toml scenes/cornell-box/reference-glossy-256.exr 30 --methods pt,pir-bdpt,pir-mis
study glossy-256 scenes/stress/glossy/scene.toml scenes/stress/glossy/reference-256.exr 30 --methods pt,pir-bdpt,pir-mis
study corner-glossy-256 scenes/stress/corner/scene.toml scenes/stress/corner/reference-256.exr 30 --methods pt,pir-bdpt,pir-mis
# The Mori knob (issue 12's glossy scene; its mesh is in ../shared) at 256x256 for 30 s.
if [ -f "$shared/scenes/mori-knob/testObj.obj" ]; then
    study mori-knob-mis "${mori[@]}" 30 --methods pt,pir-clamp,pir-vsl,pir-mis,pir-bdpt
    study mori-knob-thesis-resample "${mori[@]}" 30 "${thesis_resample[@]}"
else
    echo "skipping the Mori knob studies: $shared/scenes/mori-knob is absent" >&2
fi
# Dense glossy meshes (the dragon and the bunny, scenes/dense/README.md), lit indirectly and
# directly, every method at 256x256 for 30 s: the shape of issues 11 and 12's held-out scenes.
if [ -f "$shared/scenes/dragon/dragon_res2_meshopt100k.obj" ] && [ -f "$shared/scenes/bunny/bun_zipper.obj" ]; then
    study dense-indirect "${dense_indirect[@]}" 30
    study dense-direct "${dense_direct[@]}" 30
    study dense-indirect-thesis-resample "${dense_indirect[@]}" 30 "${thesis_resample[@]}"
    study dense-direct-thesis-resample "${dense_direct[@]}" 30 "${thesis_resample[@]}"
else
    echo "skipping the dense-mesh studies: $shared/scenes/dragon or bunny is absent" >&2
fi
# The Cornell box with the Stanford bunny (../shared/scenes/bunny), 256x256, 60 s, against a
# Mitsuba 3 reference that is not committed (docs/bunny-reference.sh: where it is, and its
# rendering when missing and MITSUBA_PYTHON, a Python that imports mitsuba, is set).
if wanted cornell-bunny-mis; then
    bunny_scene=$shared/scenes/bunny/cornell-bunny.toml
    bunny_ref=$(docs/bunny-reference.sh "$shared" "${MITSUBA_PYTHON:-}")
    if [ -f "$bunny_scene" ] && [ -f "$bunny_ref" ]; then
        bunny_target=$(pt_1024 "$bunny_scene" "$bunny_ref" bunny)
        study cornell-bunny-mis "$bunny_scene" "$bunny_ref" 60 --target-rel-mse "$bunny_target" --methods pt,pir-clamp,pir-vsl,pir-mis,pir-bdpt
    else
        echo "skipping the bunny's study: $bunny_scene or its reference $bunny_ref is absent" >&2
    fi
fi
echo "done: numbers and one chart per study in $out, all images in $images" >&2
