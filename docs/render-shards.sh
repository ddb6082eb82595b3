#!/usr/bin/env bash
# Render one scene in N shards and merge them: as a Slurm job array, or locally with GNU
# parallel. Every shard renders its share of the same global iterations (K+1, K+1+N, ...), so
# the merged image equals one run of all of them.
#
#   docs/render-shards.sh slurm    SCENE.toml OUT_DIR [N] [SPP] [METHOD]   # submits the array
#   docs/render-shards.sh parallel SCENE.toml OUT_DIR [N] [SPP] [METHOD]   # runs here
#   docs/render-shards.sh shard    SCENE.toml OUT_DIR  N   SPP   METHOD K  # one shard (used by both)
#   docs/render-shards.sh merge    SCENE.toml OUT_DIR  N                   # merge what is there
#
# A shard that is killed (node failure, time limit) keeps its last checkpoint; running the same
# shard again resumes it, with the same random numbers.
set -euo pipefail

mode=${1:?mode: slurm | parallel | shard | merge}
scene=${2:?scene file}
out=${3:?output folder}
n=${4:-16}
spp=${5:-1024}
method=${6:-pir-clamp}
pir=${PIR:-pir}                  # the pir binary (e.g. target/release/pir)
checkpoint=${CHECKPOINT:-300}    # seconds between checkpoints

mkdir -p "$out"

shard() {
    local k=$1 file="$out/shard-$1-of-$n.exr"
    local args=(render "$scene" --method "$method" --spp "$spp" --shard "$k/$n"
                --checkpoint "$checkpoint" --out "$file" --no-preview --quiet)
    if [ -n "${THREADS:-}" ]; then args+=(--threads "$THREADS"); fi
    if [ -f "$file" ]; then args+=(--resume "$file"); fi
    "$pir" "${args[@]}"
}

merge() {
    "$pir" merge "$out"/shard-*-of-"$n".exr -o "$out/merged.exr"
}

case "$mode" in
    shard)
        shard "${7:?shard index K}"
        ;;
    merge)
        merge
        ;;
    parallel)
        # One shard per core at a time, each single-threaded; GNU parallel retries failures.
        seq 0 $((n - 1)) | PIR="$pir" CHECKPOINT="$checkpoint" THREADS=1 parallel --jobs "$(nproc)" \
            --retries 2 "$0 shard '$scene' '$out' $n $spp $method {}"
        merge
        ;;
    slurm)
        # An array of N tasks, then a merge that runs when all of them have succeeded.
        array=$(sbatch --parsable --array=0-$((n - 1)) --job-name=pir-shards \
            --cpus-per-task="${CPUS:-8}" --time="${TIME_LIMIT:-04:00:00}" \
            --output="$out/slurm-%A_%a.log" --requeue \
            --wrap="THREADS=\$SLURM_CPUS_PER_TASK PIR='$pir' CHECKPOINT=$checkpoint $0 shard '$scene' '$out' $n $spp $method \$SLURM_ARRAY_TASK_ID")
        sbatch --dependency=afterok:"$array" --job-name=pir-merge --output="$out/slurm-merge.log" \
            --wrap="PIR='$pir' $0 merge '$scene' '$out' $n"
        echo "submitted array $array ($n shards) and its merge"
        ;;
    *)
        echo "unknown mode $mode" >&2
        exit 2
        ;;
esac
