#!/usr/bin/env bash
# Runs each cargo-fuzz target for SECONDS (default 60) and prints executions and crashes.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      targets: scene checkpoint (default: both)
# FUZZ_SEED=N and FUZZ_RUNS=N make a run reproducible (CI uses both: the same inputs every time,
# so a green run stays green and a new crash shows up with the change that caused it).
# Builds the targets with cargo-fuzz's own flags (no `cargo install cargo-fuzz` needed; `cargo
# fuzz run TARGET` works on the same folder too). They are nightly compiler flags; on a stable
# toolchain RUSTC_BOOTSTRAP=1 unlocks them (set here). Crashes land in fuzz/artifacts/TARGET/.
set -uo pipefail
cd "$(dirname "$0")/../fuzz"
secs="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(scene checkpoint)
export RUSTC_BOOTSTRAP=1
seed_corpus() {
    mkdir -p corpus/scene corpus/checkpoint
    cp ../scenes/*.toml corpus/scene/ 2>/dev/null || true
}
seed_corpus
# The flags `cargo fuzz build -O` passes (cargo-fuzz 0.13), given here so that CI needs no
# `cargo install cargo-fuzz` (3-4 minutes of its 30). `--target` keeps build scripts and
# proc macros uninstrumented, as cargo-fuzz does.
host="$(rustc -vV | sed -n 's/^host: //p')"
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing \
-Cllvm-args=-simplifycfg-branch-fold-threshold=0 -Zsanitizer=address -Cdebug-assertions \
-Coverflow-checks"
build_log="$(mktemp)"
if ! cargo build --release --target "$host" --bins >"$build_log" 2>&1; then
    cat "$build_log"
    exit 2
fi
rm -f "$build_log"
status=0
for t in "${targets[@]}"; do
    log="$(mktemp)"
    extra=()
    [ -n "${FUZZ_SEED:-}" ] && extra+=("-seed=$FUZZ_SEED")
    [ -n "${FUZZ_RUNS:-}" ] && extra+=("-runs=$FUZZ_RUNS")
    mkdir -p "artifacts/$t"
    "target/$host/release/$t" -artifact_prefix="artifacts/$t/" "corpus/$t" \
        -max_total_time="$secs" -max_len=8192 -timeout=10 -rss_limit_mb=2048 "${extra[@]}" \
        >"$log" 2>&1
    rc=$?
    execs="$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)"
    [ -z "$execs" ] && execs="$(grep -oE '^#[0-9]+' "$log" | tail -1 | tr -d '#')"
    crashes="$(ls "artifacts/$t" 2>/dev/null | wc -l)"
    echo "fuzz $t: ${secs}s, ${execs:-?} executions, exit $rc, ${crashes} crash/timeout artifacts in fuzz/artifacts/$t"
    if [ $rc -ne 0 ]; then
        grep -E 'panicked|ERROR|SUMMARY|Test unit written' "$log" | head -20
        status=1
    fi
    rm -f "$log"
done
exit $status
