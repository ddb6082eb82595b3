#!/usr/bin/env bash
# The production-scale studies (issue 48): real interiors at film resolution, every method and
# Mitsuba 3's path tracer at equal wall time on the same machine, against long references.
#
#     docs/production.sh references [RES…]   make or resume the references (hours; resumable)
#     docs/production.sh study [RES…]        race the methods (TIME seconds per line)
#
# RES is WxH (default: 1280x720 1920x1080). Scenes:
# - living-room: ../shared/scenes/mitsuba/living-room/scene.xml ("The White Room", Mitsuba 3
#   XML, textured, four area lights in the windows). Reference: Mitsuba 3's own path tracer,
#   in chunks of CHUNK_SPP with seeds 0, 1, … (REF_CHUNKS of them; an interrupted run keeps
#   its chunks and resumes), averaged.
# - conference: scenes/conference-room/scene.toml (331k triangles, six ceiling panels).
#   Mitsuba cannot render it: most of its glossy materials have Kd + Ks above 1, which the
#   scene contract defines (albedo/π + specular · GGX) but no Mitsuba BSDF with reflectances
#   in [0, 1] represents, and Mitsuba refuses larger ones. Reference: a long `pir reference`
#   (pir's path tracer, checked against Mitsuba's on the living room and the shared scenes),
#   REF_SECONDS of it, resumable through its checkpoint, at seed REF_SEED (default 1000): a
#   reference at the study's seed would share the study's random numbers (`pir study` refuses
#   it), since `pt`'s first iterations would be the reference's own. A reference made at the
#   scene's seed by an older version of this script cannot be resumed at REF_SEED: delete it.
#
# Every study line renders alone on all cores (`pir study`, then Mitsuba at the same wall
# time, whole process, JIT and scene load included), so the machine should be otherwise idle.
# Output: out/production/SCENE-RES/ (not in git): the reference, the study's report, charts,
# image sheet and final EXRs, mitsuba.exr and a summary.md with every line's relative MSE,
# HDR-FLIP, mean difference and time to pt's final error.
#
# Environment: TIME (s per line, default 300), METHODS (default pt,pir-bdpt,pir-clamp,pir-vsl,
# pir-mis), MITSUBA_PYTHON (a Python with mitsuba and numpy; without one the Mitsuba lines
# are skipped with a message), SHARED (default ../shared), CHUNK_SPP (32), REF_CHUNKS (128),
# REF_SECONDS (21600), ONLY (a regex of SCENE-RES names to run).
set -euo pipefail
cd "$(dirname "$0")/.."

what=${1:?usage: docs/production.sh references|study [WxH…]}
shift
if (($#)); then resolutions=("$@"); else resolutions=(1280x720 1920x1080); fi
time_per_line=${TIME:-300}
methods=${METHODS:-pt,pir-bdpt,pir-clamp,pir-vsl,pir-mis}
shared=${SHARED:-../shared}
py=${MITSUBA_PYTHON:-}
if [[ -n $py ]] && ! "$py" -c 'import mitsuba' 2>/dev/null; then
    echo "note: $py cannot import mitsuba; Mitsuba's lines are skipped" >&2
    py=
fi

cargo build --release --quiet
pir=target/release/pir
out=out/production

# name scene (Mitsuba renders it: yes/no)
scenes=(
    "living-room $shared/scenes/mitsuba/living-room/scene.xml yes"
    "conference scenes/conference-room/scene.toml no"
)

wanted() { [[ $1 =~ ${ONLY:-.} ]]; }

reference() {
    local name=$1 scene=$2 mitsuba=$3 w=$4 h=$5 dir=$6
    mkdir -p "$dir/ref"
    if [[ $mitsuba == yes ]]; then
        if [[ -z $py ]]; then
            echo "$name: no MITSUBA_PYTHON; its reference needs Mitsuba 3, skipped" >&2
            return
        fi
        "$py" docs/production_mitsuba.py reference "$scene" "$dir/ref" "$w" "$h" \
            --chunk-spp "${CHUNK_SPP:-32}" --chunks "${REF_CHUNKS:-128}" >"$dir/ref/spp"
        cp "$dir/ref/reference.exr" "$dir/reference.exr"
    else
        local ref=$dir/ref/reference.exr
        if [[ -f $ref ]]; then
            "$pir" render "$scene" --method pt --resolution "$w" "$h" --resume "$ref" --time "${REF_SECONDS:-21600}" \
                --spp 1000000 --checkpoint 300 --seed "${REF_SEED:-1000}" --quiet
        else
            "$pir" render "$scene" --method pt --resolution "$w" "$h" --time "${REF_SECONDS:-21600}" \
                --spp 1000000 --checkpoint 300 --seed "${REF_SEED:-1000}" --out "$ref" --quiet
        fi
        cp "$ref" "$dir/reference.exr"
    fi
}

study() {
    local name=$1 scene=$2 mitsuba=$3 w=$4 h=$5 dir=$6
    if [[ ! -f $dir/reference.exr ]]; then
        echo "$name: no reference in $dir (run: docs/production.sh references ${w}x$h); skipped" >&2
        return
    fi
    rm -rf "$dir/study"
    "$pir" study "$scene" --reference "$dir/reference.exr" --methods "$methods" --time "$time_per_line" \
        --out "$dir/study"
    {
        echo "# $name at ${w}×$h, $time_per_line s per line, $(nproc) cores, $(date -u +%Y-%m-%dT%H:%MZ)"
        echo
        sed -n '/^| line/,/^$/p' "$dir/study/report.md"
    } >"$dir/summary.md"
    if [[ $mitsuba == yes && -n $py ]]; then
        local t0 t1 spp
        t0=$(date +%s.%N)
        spp=$("$py" docs/production_mitsuba.py equal-time "$scene" "$dir/mitsuba.exr" "$w" "$h" \
            --seconds "$time_per_line" | awk '{ print $1 }')
        t1=$(date +%s.%N)
        {
            echo "Mitsuba 3 (\`llvm_ad_rgb\`, its \`path\` integrator as the file sets it, independent"
            echo "sampler): $spp spp in $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') s, whole process:"
            echo
            echo '```'
            "$pir" compare "$dir/mitsuba.exr" "$dir/reference.exr"
            echo '```'
        } >>"$dir/summary.md"
    elif [[ $mitsuba == yes ]]; then
        echo "$name: no MITSUBA_PYTHON; Mitsuba's line skipped" >&2
    fi
    cat "$dir/summary.md"
}

for res in "${resolutions[@]}"; do
    w=${res%x*} h=${res#*x}
    for entry in "${scenes[@]}"; do
        read -r name scene mitsuba <<<"$entry"
        wanted "$name-$res" || continue
        if [[ ! -f $scene ]]; then
            echo "$name: $scene is absent; skipped" >&2
            continue
        fi
        case $what in
            references) reference "$name" "$scene" "$mitsuba" "$w" "$h" "$out/$name-$res" ;;
            study) study "$name" "$scene" "$mitsuba" "$w" "$h" "$out/$name-$res" ;;
            *) echo "usage: docs/production.sh references|study [WxH…]" >&2; exit 2 ;;
        esac
    done
done
