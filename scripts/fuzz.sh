#!/usr/bin/env bash
# Runs each cargo-fuzz target for SECONDS (default 60) and prints executions and crashes.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      targets: scene checkpoint (default: both)
# FUZZ_SEED=N and FUZZ_RUNS=N make a run reproducible (CI uses both: the same inputs every time,
# so a green run stays green and a new crash shows up with the change that caused it).
# Needs `cargo install cargo-fuzz`. cargo-fuzz needs nightly compiler flags; on a stable
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
build_log="$(mktemp)"
if ! cargo fuzz build -O >"$build_log" 2>&1; then
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
    cargo fuzz run -O "$t" "corpus/$t" -- -max_total_time="$secs" -max_len=8192 \
        -timeout=10 -rss_limit_mb=2048 "${extra[@]}" >"$log" 2>&1
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
