#!/bin/bash
# Run `roks brdf` as a Slurm job array, one photon block per array task, then
# merge the blocks in a dependent job. The merged result equals a single run
# exactly (see src/shard.rs). Usage, from the repository (roks built with
# `cargo build --release`):
#
#   scripts/slurm_brdf.sh SCENE.toml OUT_DIR [SHARDS] [extra roks brdf options...]
#   e.g. scripts/slurm_brdf.sh scenes/default.toml results/default 16 --photons 100000000
#
# Shards go to OUT_DIR.shards/NNN, Slurm's logs to OUT_DIR.logs/, the merged
# result to OUT_DIR (beside, not inside: roks replaces a result folder whole,
# and refuses one holding subfolders). SHARDS must not
# exceed photons/4096. Edit the #SBATCH-style options below (partition, time,
# cores) for your cluster, or set SBATCH_PARTITION, SBATCH_ACCOUNT, ... in the
# environment (sbatch reads them).
set -euo pipefail

SCENE=${1:?usage: $0 SCENE.toml OUT_DIR [SHARDS] [roks brdf options...]}
OUT=${2:?usage: $0 SCENE.toml OUT_DIR [SHARDS] [roks brdf options...]}
SHARDS=${3:-8}
shift $(( $# < 3 ? $# : 3 ))
ROKS=${ROKS:-$(pwd)/target/release/roks}
CPUS=${CPUS:-8}
TIME=${TIME:-04:00:00}

[ -x "$ROKS" ] || { echo "no roks binary at $ROKS (cargo build --release, or set ROKS)" >&2; exit 2; }
mkdir -p "$OUT.shards" "$OUT.logs"
EXTRA=$(printf ' %q' "$@")

# One shard per array task: task I runs block I of SHARDS.
array_id=$(sbatch --parsable \
    --job-name=roks-brdf \
    --array=0-$((SHARDS - 1)) \
    --cpus-per-task="$CPUS" \
    --time="$TIME" \
    --output="$OUT.logs/shard-%a.out" \
    --wrap="$(printf '%q' "$ROKS") brdf $(printf '%q' "$SCENE") -q --threads \$SLURM_CPUS_PER_TASK --shard \$SLURM_ARRAY_TASK_ID/$SHARDS --out $(printf '%q' "$OUT.shards")/\$(printf %03d \$SLURM_ARRAY_TASK_ID)$EXTRA")

# The merge runs once every array task has succeeded.
merge_id=$(sbatch --parsable \
    --job-name=roks-merge \
    --dependency=afterok:"$array_id" \
    --cpus-per-task=1 \
    --time=00:30:00 \
    --output="$OUT.logs/merge.out" \
    --wrap="$(printf '%q' "$ROKS") merge $(printf '%q' "$OUT.shards")/* --out $(printf '%q' "$OUT")")

echo "submitted shards as job array $array_id (0-$((SHARDS - 1))), merge as job $merge_id"
