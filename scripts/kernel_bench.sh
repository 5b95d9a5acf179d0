#!/usr/bin/env bash
# The micro kernels side by side: builds commit 6ce6b98 (the tracer before
# the speed work), a base commit (default: main) and the working tree, each
# from its own git worktree into its own target dir with
# `cargo build --release`, then runs the cases alternating the binaries,
# ROUNDS rounds. Per run it prints the whole process's wall-clock seconds
# and peak memory (`/usr/bin/time -f "%e %M"`) and the tracing rate from
# summary.json (M segments/s); per case the median over the rounds of each
# binary's figures and of the ratios taken within each round against
# 6ce6b98 and against the base.
#
#   scripts/kernel_bench.sh                  # 5 rounds, 1e6 photons (default scene)
#   ROUNDS=3 PHOTONS=200000 scripts/kernel_bench.sh
#   SHARED_TARGET=/path/target scripts/kernel_bench.sh   # one target dir, built in turn
#   NO_BUILD=1 CASES=default scripts/kernel_bench.sh      # binaries already in $WORK
#
# The new binary runs twice per round: `--kernel scalar` and
# `--kernel wavefront` (the older binaries have no `--kernel`).
set -euo pipefail

ROOT=$(git rev-parse --show-toplevel)
WORK=${WORK:-/tmp/roks-kernel-bench}
OLD=${OLD:-6ce6b98}
BASE=${BASE:-main}
ROUNDS=${ROUNDS:-5}
PHOTONS=${PHOTONS:-1000000}
FIELD_PHOTONS=${FIELD_PHOTONS:-$((PHOTONS / 5))}
THREADS=${THREADS:-2}
mkdir -p "$WORK"

# build NAME REV: the binary of REV ("worktree": the working tree) as $WORK/roks-NAME.
build() {
    local name=$1 rev=$2 src target
    if [ "$rev" = worktree ]; then
        src=$ROOT
    else
        src=$WORK/src-$name
        if [ ! -d "$src" ]; then
            git -C "$ROOT" worktree add --detach "$src" "$rev" >/dev/null
        else
            git -C "$src" checkout --detach -q "$rev"
        fi
    fi
    target=${SHARED_TARGET:-$WORK/target-$name}
    CARGO_TARGET_DIR=$target cargo build --release -q --manifest-path "$src/Cargo.toml"
    cp "$target/release/roks" "$WORK/roks-$name"
}

if [ -z "${NO_BUILD:-}" ]; then
    build old "$OLD"
    build base "$BASE"
    build new worktree
fi

# run LABEL EXE ARGS...: one timed run; prints "LABEL wall_s peak_MB Msegments_per_s".
run() {
    local label=$1 exe=$2
    shift 2
    local out=$WORK/out-$label
    rm -rf "$out"
    local t
    /usr/bin/time -f "%e %M" -o "$WORK/time.txt" "$exe" "$@" --out "$out" -q >/dev/null 2>&1
    t=$(tail -1 "$WORK/time.txt")
    local rate
    rate=$(python3 -c 'import json,sys
s=json.load(open(sys.argv[1]))
inc=s["incidence"]
print("%.3f" % (sum(i["segments"] for i in inc)/sum(i["seconds"] for i in inc)/1e6))' "$out/summary.json")
    echo "$label ${t% *} $(( ${t#* } / 1024 )) $rate"
}

# case NAME SCENE-ARGS...: ROUNDS alternated rounds of the four binaries.
case_() {
    local name=$1
    shift
    local log=$WORK/$name.log
    : >"$log"
    for r in $(seq 1 "$ROUNDS"); do
        {
            run old "$WORK/roks-old" "$@"
            run base "$WORK/roks-base" "$@"
            run scalar "$WORK/roks-new" "$@" --kernel scalar
            run wavefront "$WORK/roks-new" "$@" --kernel wavefront
        } | sed "s/^/$r /" | tee -a "$log"
    done
    python3 - "$log" "$name" <<'EOF'
import statistics as st, sys
rows = [l.split() for l in open(sys.argv[1])]
by = {}
for r, label, wall, mb, rate in rows:
    by.setdefault(label, {})[int(r)] = (float(wall), int(mb), float(rate))
rounds = sorted(by["old"])
print(f"## {sys.argv[2]}: medians of {len(rounds)} alternated rounds")
print("| binary | wall s | peak MB | M segments/s | rate / 6ce6b98 | rate / base | wall base / wall |")
print("|---|---:|---:|---:|---:|---:|---:|")
for label in ["old", "base", "scalar", "wavefront"]:
    m = by[label]
    med = lambda k: st.median(m[i][k] for i in rounds)
    ratio = lambda ref, k: st.median(m[i][k] / by[ref][i][k] for i in rounds)
    wall_ratio = st.median(by["base"][i][0] / m[i][0] for i in rounds)
    print(f"| {label} | {med(0):.2f} | {med(1):.0f} | {med(2):.2f} | {ratio('old', 2):.3f} | "
          f"{ratio('base', 2):.3f} | {wall_ratio:.3f} |")
EOF
}

for c in ${CASES:-default gaussian}; do
    case $c in
    default)
        case_ default_60deg brdf --theta 60 --photons "$PHOTONS" --threads "$THREADS" \
            --stats-resolution 64
        ;;
    gaussian)
        case_ gaussian_rough_60deg brdf "$ROOT/scenes/gaussian-rough.toml" --theta 60 \
            --photons "$FIELD_PHOTONS" --threads "$THREADS" --stats-resolution 64
        ;;
    esac
done
