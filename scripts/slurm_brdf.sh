#!/bin/bash
# Run `roks brdf` (a micro scene) or `roks trace` (an object scene, one with
# [[cells]]) as a Slurm job array, one photon block per array task, then
# merge the blocks in a dependent job. The merged result equals a single run
# exactly (see src/shard.rs and src/output/object_tallies.rs). Runs the
# repository's target/release/roks (`cargo build --release`; or set
# ROKS=/path/to/roks) from any folder:
#
#   scripts/slurm_brdf.sh SCENE.toml OUT [SHARDS] [roks brdf|trace options...]
#   scripts/slurm_brdf.sh status OUT
#   scripts/slurm_brdf.sh resubmit OUT [I,J,...]
#
#   e.g. scripts/slurm_brdf.sh scenes/default.toml results/default 16 --photons 100000000
#        scripts/slurm_brdf.sh scenes/cylinder-cavity.toml results/cavity 32
#
# Submitting: shard I of SHARDS (default 8) goes to OUT.shards/III (three
# digits: 000, 001, ...), Slurm's logs to OUT.logs/shard-III.out and
# OUT.logs/merge.out, the merged result to OUT (beside the shards, not inside:
# roks replaces a result folder whole). Nothing is submitted unless all of
# this holds (otherwise one line on stderr, exit status 2):
#   * the roks binary exists, the scene file exists (its absolute path is
#     submitted), and `roks brdf --check` (`roks trace --check` for an object
#     scene) accepts the scene, the options, the exports the merge will
#     write (--export) and `--shard SHARDS-1/SHARDS` (a shard is whole
#     batches of 4096 photons: of every incidence angle for brdf, so SHARDS
#     may not exceed ceil(photons / 4096); of the beam positions laid end to
#     end for trace, so SHARDS may not exceed the sum over the positions of
#     ceil(photons / 4096));
#   * the options do not set --out, --shard or --threads (the script does);
#   * OUT does not exist, or is an empty folder, or a roks result folder;
#   * OUT.shards and OUT.logs do not exist or are empty (an earlier run's
#     shards are never mixed in: `status OUT` shows that run; delete both
#     folders to start afresh);
#   * CPUS (cores per shard) is at most the cores of a node of the partition
#     (SBATCH_PARTITION, else the default one); unset, it is 8 or the node's
#     cores if fewer;
#   * sinfo answers (a controller that is down is named, exit status 2).
# Settings from the environment: ROKS, CPUS, TIME (per shard, default
# 04:00:00), and sbatch's own SBATCH_PARTITION, SBATCH_ACCOUNT,
# SBATCH_MEM_PER_CPU, ... (the shards and the merge all read them).
# The run's settings and job ids are kept in OUT.shards/slurm_run.env.
#
# The merge job depends on every shard (afterok) and takes exactly the
# folders OUT.shards/000 .. OUT.shards/SHARDS-1. If a shard fails (a crash, a
# node lost, a time limit, scancel), Slurm cancels the merge
# (--kill-on-invalid-dep) instead of leaving it pending forever.
#
# Recovering from a failed shard:
#   1. scripts/slurm_brdf.sh status OUT
#      lists the shards done, pending or running, failed (with the last line of
#      their log) and missing (cancelled before they started), the state of
#      the merge, and prints the command that resubmits only what is left.
#      Exit status 0: merged, or still running with nothing lost;
#      1: something must be resubmitted; 2: no run at OUT.
#   2. Run the printed command, e.g.
#      scripts/slurm_brdf.sh resubmit OUT 1,3
#      It cancels a merge still waiting, submits shards 1 and 3 again with the
#      run's settings (same scene, options, shard count: the finished shards
#      are kept) and a new merge after them. Without a list it resubmits every
#      failed and missing shard; when none is left it submits only the merge.
#   The merged OUT is then byte for byte the single run's result (brdf.csv,
#   inplane.csv, or reflectance.csv, farfield.csv, farfield_stokes.csv, and
#   the pictures; summary.json except its timings).
set -euo pipefail

PROG=slurm_brdf.sh
SELF=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/$(basename "${BASH_SOURCE[0]}")
USAGE="usage: $PROG SCENE.toml OUT [SHARDS] [roks brdf|trace options...] | $PROG status OUT | $PROG resubmit OUT [I,J,...]"

# Bad input: one line naming what is wrong, exit status 2.
die() {
    local m="$PROG: $*"
    printf '%s\n' "${m//$'\n'/ }" >&2
    exit 2
}

# The first line of a command's output, for a one-line message.
first_line() { printf '%s' "$1" | head -n 1; }

need_slurm() {
    local c
    for c in sbatch squeue scancel sinfo; do
        command -v "$c" >/dev/null || die "no \`$c\` on this machine: run this on a Slurm login node"
    done
}

# The three-digit folder name of shard $1.
shard_name() { printf '%03d' "$1"; }

# OUT as an absolute path without a trailing slash.
absolute_out() {
    [ -n "$1" ] || die "OUT is empty; $USAGE"
    realpath -m -- "$1"
}

# Empty (or absent) folder $1, else die naming it.
require_empty() {
    if [ -e "$1" ] || [ -L "$1" ]; then
        [ -d "$1" ] || die "$1 exists and is not a folder"
        if [ -n "$(ls -A -- "$1")" ]; then
            die "$1 holds an earlier run's files (see: $PROG status ${OUT}); delete $OUT.shards and $OUT.logs to start afresh"
        fi
    fi
}

# Run sinfo with the arguments given; its output on stdout. When it fails
# (the controller is down, a bad partition), die with its first line.
sinfo_or_die() {
    local out rc=0
    out=$(sinfo "$@" 2>&1) || rc=$?
    if [ "$rc" -ne 0 ]; then
        die "sinfo cannot reach the Slurm controller (exit status $rc): $(first_line "${out:-no message}")"
    fi
    printf '%s\n' "$out"
}

# The most cores a node of partition $1 offers.
partition_cpus() {
    local out
    out=$(sinfo_or_die -h -N -p "$1" -o '%c') || exit $?
    printf '%s\n' "$out" | tr -dc '0-9\n' | sort -n | tail -n 1
}

# Load the run's settings kept in OUT.shards/slurm_run.env.
load_run() {
    STATE=$OUT.shards/slurm_run.env
    [ -f "$STATE" ] || die "$OUT: no run of $PROG there (no $STATE)"
    ROKS="" SCENE="" SHARDS="" CPUS="" TIME="" EXTRA="" MERGE_EXTRA="" JOBS="" CMD=brdf
    # shellcheck disable=SC1090 # the file this script wrote at submission
    . "$STATE" 2>/dev/null || die "$STATE: cannot read it"
    if [ -z "$ROKS" ] || [ -z "$SCENE" ] || ! [[ $SHARDS =~ ^[1-9][0-9]*$ ]] || [ -z "$CPUS" ] || [ -z "$TIME" ] || ! [[ $CMD =~ ^(brdf|trace)$ ]]; then
        die "$STATE: not a run file of $PROG (ROKS, SCENE, SHARDS, CPUS, TIME, CMD)"
    fi
}

# Submit the shards listed in $1 (Slurm array syntax, e.g. 0-7 or 1,3; empty:
# none) and, unless $3 is "no", a merge after them and after the shard jobs
# listed in $2 (job ids such as 14_2, colon-separated); record the job ids.
submit() {
    local list=$1 after=${2:-} out_q shards_q merge_dep=() array_id="" merge_id i dirs=""
    out_q=$(printf '%q' "$OUT")
    shards_q=$(printf '%q' "$OUT.shards")
    if [ -n "$list" ]; then
        # One shard per array task: task I runs block I of SHARDS.
        array_id=$(sbatch --parsable \
            --job-name="roks-$CMD" \
            --array="$list" \
            --cpus-per-task="$CPUS" \
            --time="$TIME" \
            --output="$OUT.logs/shard-%3a.out" \
            --wrap="$(printf '%q' "$ROKS") $CMD $(printf '%q' "$SCENE") -q --threads \$SLURM_CPUS_PER_TASK --shard \$SLURM_ARRAY_TASK_ID/$SHARDS --out $shards_q/\$(printf %03d \$SLURM_ARRAY_TASK_ID)$EXTRA" 2>&1) ||
            die "sbatch refused the shards: $(first_line "$array_id")"
        array_id=${array_id%%;*}
        after=$array_id${after:+:$after}
        echo "JOBS=\"\$JOBS $array_id\"" >>"$STATE"
    fi
    if [ "${3:-}" = no ]; then
        echo "submitted shards $list of $SHARDS as job array $array_id"
        return
    fi
    [ -z "$after" ] || merge_dep=(--dependency=afterok:"$after" --kill-on-invalid-dep=yes)
    # The merge takes exactly shards 000 .. SHARDS-1.
    for ((i = 0; i < SHARDS; i++)); do
        dirs+=" $shards_q/$(shard_name "$i")"
    done
    merge_id=$(sbatch --parsable \
        --job-name=roks-merge \
        "${merge_dep[@]+"${merge_dep[@]}"}" \
        --cpus-per-task=1 \
        --time=00:30:00 \
        --output="$OUT.logs/merge.out" \
        --wrap="$(printf '%q' "$ROKS") merge$dirs --out $out_q$MERGE_EXTRA" 2>&1) || {
        [ -z "$array_id" ] || scancel "$array_id" || true
        die "sbatch refused the merge job: $(first_line "$merge_id")${array_id:+ (shards $array_id cancelled)}"
    }
    merge_id=${merge_id%%;*}
    echo "JOBS=\"\$JOBS $merge_id\"" >>"$STATE"
    if [ -n "$list" ]; then
        echo "submitted shards $list of $SHARDS as job array $array_id, the merge as job $merge_id (cancelled by Slurm if a shard fails)"
    else
        echo "submitted the merge as job $merge_id"
    fi
    echo "follow it with: $SELF status $out_q"
}

# Sets DONE, RUNNING, PENDING, FAILED, MISSING (space-separated shard
# indices), FAILED_WHY (one line per failed shard), MERGE (one line),
# MERGE_STATE (queued, merged or none), and QUEUED and QUEUED_JOB (state and
# job id of each queued shard, by index).
survey() {
    local jobs="" j name job task state i dir log why merge_queued=""
    declare -gA QUEUED=() QUEUED_JOB=()
    squeue -h -o '%i' >/dev/null 2>&1 || die "squeue cannot reach the Slurm controller: $(first_line "$(squeue -h -o '%i' 2>&1)")"
    for j in $JOBS; do
        jobs+=$(squeue -h -r -j "$j" -o '%j %F %K %T' 2>/dev/null || true)$'\n'
    done
    while read -r name job task state; do
        [ -n "$name" ] || continue
        if [ "$name" = roks-merge ]; then
            merge_queued=$state
        elif [[ $task =~ ^[0-9]+$ ]]; then
            QUEUED[$task]=$state
            QUEUED_JOB[$task]=${job}_$task
        fi
    done <<<"$jobs"
    DONE="" RUNNING="" PENDING="" FAILED="" MISSING="" FAILED_WHY=""
    for ((i = 0; i < SHARDS; i++)); do
        dir=$OUT.shards/$(shard_name "$i")
        log=$OUT.logs/shard-$(shard_name "$i").out
        if [ -f "$dir/tallies.json" ]; then
            DONE+=" $i"
        elif [ -n "${QUEUED[$i]:-}" ]; then
            case ${QUEUED[$i]} in
                PENDING) PENDING+=" $i" ;;
                *) RUNNING+=" $i" ;;
            esac
        elif [ -f "$log" ]; then
            FAILED+=" $i"
            why=$(grep -v '^[[:space:]]*$' "$log" | tail -n 1 | tr -d '\r' | cut -c 1-300)
            FAILED_WHY+="failed: $(shard_name "$i"): ${why:-no message} ($log)"$'\n'
        else
            MISSING+=" $i"
        fi
    done
    if [ -n "$merge_queued" ]; then
        MERGE_STATE=queued
        MERGE="merge: ${merge_queued,,}"
        if [ -n "$FAILED$MISSING" ] && [ "$merge_queued" = PENDING ]; then
            MERGE+=" (it cannot start: shards failed; resubmitting cancels it)"
        fi
    elif [ -f "$OUT/summary.json" ] && newer_than_shards "$OUT/summary.json"; then
        MERGE_STATE=merged
        MERGE="merged: $OUT"
    else
        MERGE_STATE=none
        MERGE="merge: not run"
        [ ! -f "$OUT.logs/merge.out" ] || MERGE+=" ($OUT.logs/merge.out: $(grep -v '^[[:space:]]*$' "$OUT.logs/merge.out" | tail -n 1 | cut -c 1-300))"
    fi
}

# Whether file $1 is newer than every shard's tallies.json.
newer_than_shards() {
    local i
    for ((i = 0; i < SHARDS; i++)); do
        [ "$1" -nt "$OUT.shards/$(shard_name "$i")/tallies.json" ] || return 1
    done
}

# The shard indices in $1 (space-separated) as a Slurm array list, sorted,
# runs as ranges: "5 3 1 2" -> "1-3,5".
# shellcheck disable=SC2086 # $1 is split into indices
commas() {
    printf '%s\n' $1 | sort -n | awk '
        function run(a, b) { return a == b ? a : a "-" b }
        NF { if (n && $1 == last + 1) { last = $1; next }
             if (n) { out = out sep run(first, last); sep = "," }
             first = last = $1; n++ }
        END { if (n) out = out sep run(first, last); print out }'
}

# The indices of a Slurm array list: "1-3,5" -> " 1 2 3 5"; dies on others.
expand() {
    local part a b
    [[ $1 =~ ^[0-9]+(-[0-9]+)?(,[0-9]+(-[0-9]+)?)*$ ]] || die "resubmit: bad shard list \`$1\` (expected e.g. 1,3 or 2-5)"
    for part in ${1//,/ }; do
        a=$((10#${part%-*})) b=$((10#${part#*-}))
        ((a <= b)) || die "resubmit: bad range \`$part\` in \`$1\`"
        ((b < SHARDS)) || die "resubmit: shard $b does not exist (the run has shards 0-$((SHARDS - 1)))"
        seq -s ' ' "$a" "$b" | sed 's/^/ /'
    done | tr -d '\n'
}

# The number of shard indices in $1.
# shellcheck disable=SC2086 # $1 is split into indices
count() { set -- $1; echo $#; }

# The folder names of the shard indices in $1: " 1 3" -> " 001 003".
names() { local i; for i in $1; do printf ' %s' "$(shard_name "$i")"; done; }

status() {
    local left
    survey
    echo "run: $SHARDS shards of $SCENE into $OUT (roks $CMD options:${EXTRA:- none})"
    echo "done: $(count "$DONE") of $SHARDS"
    [ -z "$RUNNING" ] || echo "running:$(names "$RUNNING")"
    [ -z "$PENDING" ] || echo "pending:$(names "$PENDING")"
    printf '%s' "$FAILED_WHY"
    [ -z "$MISSING" ] || echo "missing:$(names "$MISSING") (cancelled before they started, or never submitted)"
    echo "$MERGE"
    left=$FAILED$MISSING
    if [ -n "$left" ]; then
        echo "resubmit the failed and missing shards and the merge with:"
        echo "  $SELF resubmit $(printf '%q' "$OUT") $(commas "$left")"
        return 1
    fi
    if [ -z "$RUNNING$PENDING" ] && [ "$MERGE_STATE" = none ]; then
        echo "all shards are done; merge them with:"
        echo "  $SELF resubmit $(printf '%q' "$OUT")"
        return 1
    fi
    return 0
}

resubmit() {
    local list=${1:-} i j old rest after=""
    survey
    local left=" $FAILED $MISSING "
    if [ -z "$list" ]; then
        list=$(commas "$FAILED $MISSING")
    else
        local wanted="" all
        all=$(expand "$list")
        for i in $all; do
            [[ $left == *" $i "* ]] || die "resubmit: shard $i is done, pending or running, not failed or missing (see: $PROG status $OUT)"
            [[ " $wanted " == *" $i "* ]] || wanted+=" $i"
        done
        list=$(commas "$wanted")
    fi
    if [ -z "$list" ] && [ -n "$RUNNING$PENDING" ]; then
        die "resubmit: nothing failed or missing; shards$(names "$RUNNING$PENDING") are still queued (see: $PROG status $OUT)"
    fi
    if [ -z "$list" ] && [ "$MERGE_STATE" = merged ]; then
        die "resubmit: nothing to do, $OUT is merged from all $SHARDS shards"
    fi
    # Shards failed or missing and not in the list: no merge yet.
    rest=""
    for i in $FAILED $MISSING; do
        [[ " $(expand "$list") " == *" $i "* ]] || rest+=" $i"
    done
    # A merge still waiting on the old shards would never run (or run on a
    # partial set): cancel it.
    for j in $JOBS; do
        old=$(squeue -h -j "$j" -o '%j %i' 2>/dev/null | awk '$1 == "roks-merge" {print $2}' || true)
        [ -z "$old" ] || scancel "$old"
    done
    if [ -n "$rest" ]; then
        submit "$list" "" no
        echo "the merge waits until shards$(names "$rest") are resubmitted too: $SELF resubmit $(printf '%q' "$OUT") $(commas "$rest")"
        return
    fi
    # The new merge also waits for the shards still queued from before.
    for i in $RUNNING $PENDING; do
        after+=${after:+:}${QUEUED_JOB[$i]}
    done
    submit "$list" "$after"
}

case ${1:-} in
    "" | -h | --help)
        sed -n '2,/^set -euo/p' "$SELF" | sed '$d; s/^# \{0,1\}//'
        [ -n "${1:-}" ] || exit 2
        exit 0
        ;;
    status | resubmit)
        mode=$1
        if [ $# -lt 2 ] || [ $# -gt 3 ] || { [ "$mode" = status ] && [ $# -eq 3 ]; }; then
            die "$USAGE"
        fi
        need_slurm
        OUT=$(absolute_out "$2")
        load_run
        if [ "$mode" = status ]; then status; else resubmit "${3:-}"; fi
        exit
        ;;
esac

# Submitting a new run.
[ $# -ge 2 ] || die "$USAGE"
SCENE=$1
OUT=$(absolute_out "$2")
shift 2
SHARDS=8
if [ $# -gt 0 ] && [[ $1 =~ ^[0-9]+$ ]]; then
    SHARDS=$((10#$1))
    shift
fi
((SHARDS >= 1)) || die "SHARDS: must be at least 1, got 0"
opts=()
exports=()
while [ $# -gt 0 ]; do
    a=$1
    shift
    case $a in
        --out | --out=* | --shard | --shard=* | --threads | --threads=*)
            die "option ${a%%=*}: set by $PROG (OUT, SHARDS, CPUS); leave it out" ;;
        -q | --quiet) ;;
        # The merge exports the whole table (the shards' own would be partial).
        --export)
            [ $# -gt 0 ] || die "option --export: needs its formats (e.g. --export zemax,merl)"
            exports+=(--export "$1")
            shift ;;
        --export=*) exports+=("$a") ;;
        *) opts+=("$a") ;;
    esac
done
EXTRA=$(printf ' %q' "${opts[@]+"${opts[@]}"}")
[ ${#opts[@]} -gt 0 ] || EXTRA=""
MERGE_EXTRA=$(printf ' %q' "${exports[@]+"${exports[@]}"}")
[ ${#exports[@]} -gt 0 ] || MERGE_EXTRA=""

ROKS=${ROKS:-$(dirname "$SELF")/../target/release/roks}
if ! [ -f "$ROKS" ] || ! [ -x "$ROKS" ]; then
    die "ROKS: no roks binary at $ROKS (run cargo build --release, or set ROKS)"
fi
ROKS=$(realpath -- "$ROKS")
[ -f "$SCENE" ] || die "$SCENE: no such scene file"
SCENE=$(realpath -- "$SCENE")
# An object scene (zones, `[[cells]]`) is traced by roks trace.
CMD=brdf
if grep -qE '^[[:space:]]*\[\[[[:space:]]*cells[[:space:]]*\]\]' -- "$SCENE"; then
    CMD=trace
fi
TIME=${TIME:-04:00:00}

if [ -e "$OUT" ] || [ -L "$OUT" ]; then
    [ -d "$OUT" ] || die "OUT: $OUT exists and is not a folder"
    if [ -n "$(ls -A -- "$OUT")" ]; then
        if [ -n "$(find "$OUT/" -mindepth 1 -maxdepth 1 -type d -print -quit)" ] ||
            ! grep -qs '"version"' "$OUT/summary.json"; then
            die "OUT: $OUT exists and is neither empty nor a roks result folder, which the merge replaces whole; choose a new folder"
        fi
    fi
fi
require_empty "$OUT.shards"
require_empty "$OUT.logs"
need_slurm

# Cores per shard: no more than a node of the partition has.
partition=${SBATCH_PARTITION:-}
if [ -z "$partition" ]; then
    partitions=$(sinfo_or_die -h -o '%P')
    partition=$(printf '%s\n' "$partitions" | sed -n 's/\*$//p' | head -n 1)
fi
[ -n "$partition" ] || die "no default Slurm partition: set SBATCH_PARTITION"
node_cpus=$(partition_cpus "$partition")
[ -n "$node_cpus" ] || die "SBATCH_PARTITION: no nodes in the Slurm partition \`$partition\`"
if [ -z "${CPUS:-}" ]; then
    CPUS=$((node_cpus < 8 ? node_cpus : 8))
elif ! [[ $CPUS =~ ^[0-9]+$ ]] || ((10#$CPUS < 1)); then
    die "CPUS: expected a number of cores per shard, got \`$CPUS\`"
elif ((10#$CPUS > node_cpus)); then
    die "CPUS: $CPUS cores per shard, but the nodes of partition \`$partition\` have at most $node_cpus (the shards would pend forever)"
fi
CPUS=$((10#$CPUS))

# Let roks check the scene, the options, the last shard and the exports the
# merge will write (`--check`: everything the run checks, nothing traced or
# written) before anything is submitted, so that a run the merge would refuse
# (an unknown format, rgl of azimuths no RGL file holds, pbsdf without a
# Mueller tally) is refused now, not after every shard has run.
set +e
# shellcheck disable=SC2086
why=$(eval "$(printf '%q' "$ROKS") $CMD $(printf '%q' "$SCENE") -q --check --shard $((SHARDS - 1))/$SHARDS --out $(printf '%q' "$OUT.shards/$(shard_name $((SHARDS - 1)))")$EXTRA$MERGE_EXTRA" 2>&1 >/dev/null)
rc=$?
set -e
if [ "$rc" -ne 0 ]; then
    why=$(first_line "$why")
    die "roks $CMD refuses the run: ${why#roks: }${why:+ }(exit status $rc)"
fi

mkdir -p -- "$OUT.shards" "$OUT.logs" || die "OUT: cannot create $OUT.shards and $OUT.logs"
STATE=$OUT.shards/slurm_run.env
{
    echo "# $PROG run: sourced by \`$PROG status|resubmit\`"
    printf 'ROKS=%q\nSCENE=%q\nCMD=%q\nSHARDS=%q\nCPUS=%q\nTIME=%q\nEXTRA=%q\nMERGE_EXTRA=%q\nJOBS=""\n' \
        "$ROKS" "$SCENE" "$CMD" "$SHARDS" "$CPUS" "$TIME" "$EXTRA" "$MERGE_EXTRA"
} >"$STATE"
submit "0-$((SHARDS - 1))"
