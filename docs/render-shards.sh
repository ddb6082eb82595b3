#!/usr/bin/env bash
# Render one scene in N shards and merge them: as a Slurm job array, or locally with GNU
# parallel. Every shard renders its share of the same global iterations (K+1, K+1+N, ...), so
# the merged image equals one run of all of them.
#
#   docs/render-shards.sh slurm    SCENE.toml OUT_DIR [N] [SPP] [METHOD]   # submits the array
#   docs/render-shards.sh parallel SCENE.toml OUT_DIR [N] [SPP] [METHOD]   # runs here
#   docs/render-shards.sh shard    SCENE.toml OUT_DIR  N   SPP   METHOD K  # one shard (used by both)
#   docs/render-shards.sh merge    SCENE.toml OUT_DIR  N                   # merge what is there
#   docs/render-shards.sh requeue  SCENE.toml OUT_DIR  N   K [K ...]       # rerun failed Slurm shards
#
# A shard that is killed (node failure, time limit) keeps its last checkpoint; running the same
# shard again resumes it, with the same random numbers. Under Slurm a failed shard blocks the
# merge (afterok); `requeue` requeues it, starts it now and lets the merge follow it.
#
# Environment: PIR (the pir binary), CHECKPOINT (seconds between checkpoints, 300), PROGRESS
# (seconds between progress lines in the logs, 60), THREADS (per shard), and for `slurm`: CPUS
# (per task, 8), TIME_LIMIT (per task, 04:00:00).
set -euo pipefail

mode=${1:?mode: slurm | parallel | shard | merge}
scene=${2:?scene file}
out=${3:?output folder}
n=${4:-16}
spp=${5:-1024}
method=${6:-pir-clamp}
pir=${PIR:-pir}                  # the pir binary (e.g. target/release/pir)
checkpoint=${CHECKPOINT:-300}    # seconds between checkpoints
progress=${PROGRESS:-60}         # seconds between progress lines in a shard's log

mkdir -p "$out"

shard() {
    local k=$1 file="$out/shard-$1-of-$n.exr"
    local args=(render "$scene" --method "$method" --spp "$spp" --shard "$k/$n"
                --checkpoint "$checkpoint" --progress-every "$progress" --out "$file" --no-preview)
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
        seq 0 $((n - 1)) | PIR="$pir" CHECKPOINT="$checkpoint" PROGRESS="$progress" THREADS=1 parallel --jobs "$(nproc)" \
            --retries 2 "$0 shard '$scene' '$out' $n $spp $method {}"
        merge
        ;;
    slurm)
        # An array of N tasks, then a merge that runs when all of them have succeeded. A task's
        # log is appended to, so that a requeued task's log keeps the attempts before.
        array=$(sbatch --parsable --array=0-$((n - 1)) --job-name=pir-shards \
            --cpus-per-task="${CPUS:-8}" --time="${TIME_LIMIT:-04:00:00}" \
            --output="$out/slurm-%A_%a.log" --open-mode=append --requeue \
            --wrap="THREADS=\$SLURM_CPUS_PER_TASK PIR='$pir' CHECKPOINT=$checkpoint PROGRESS=$progress $0 shard '$scene' '$out' $n $spp $method \$SLURM_ARRAY_TASK_ID")
        merge_job=$(sbatch --parsable --dependency=afterok:"$array" --job-name=pir-merge \
            --output="$out/slurm-merge.log" --wrap="PIR='$pir' $0 merge '$scene' '$out' $n")
        printf 'array=%s\nmerge=%s\n' "$array" "$merge_job" >"$out/slurm-jobs"
        echo "submitted array $array ($n shards) and its merge $merge_job (recorded in $out/slurm-jobs)"
        ;;
    requeue)
        # Slurm remembers that a task of the array failed, so the merge's `afterok` on the
        # array can never be met again: requeue the tasks, start them now (Slurm would hold a
        # requeued job back for a while) and make the merge wait for each task instead.
        shift 4
        [ $# -gt 0 ] || { echo "requeue: which shards? (K ...)" >&2; exit 2; }
        [ -f "$out/slurm-jobs" ] || { echo "$out/slurm-jobs: no Slurm submission recorded here" >&2; exit 2; }
        array=$(sed -n 's/^array=//p' "$out/slurm-jobs")
        merge_job=$(sed -n 's/^merge=//p' "$out/slurm-jobs")
        for k in "$@"; do
            scontrol requeue "${array}_$k"
            scontrol update jobid="${array}_$k" StartTime=now
        done
        deps=afterok$(for k in $(seq 0 $((n - 1))); do printf ':%s_%s' "$array" "$k"; done)
        if [ "$(squeue -h -j "$merge_job" -o %T 2>/dev/null)" = PENDING ]; then
            scontrol update jobid="$merge_job" dependency="$deps"
        else
            merge_job=$(sbatch --parsable --dependency="$deps" --job-name=pir-merge \
                --output="$out/slurm-merge.log" --wrap="PIR='$pir' $0 merge '$scene' '$out' $n")
            printf 'array=%s\nmerge=%s\n' "$array" "$merge_job" >"$out/slurm-jobs"
        fi
        echo "requeued shards $* of array $array; merge $merge_job waits for every shard"
        ;;
    *)
        echo "unknown mode $mode" >&2
        exit 2
        ;;
esac
