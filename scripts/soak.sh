#!/usr/bin/env bash
# Soak run: the lecture's 5000-particle scene for STEPS steps (default 10^6), a report line
# every EVERY steps (default 10000): step, time, non-finite particles, particles outside the
# walls, kinetic and total energy, peak RSS (VmHWM), wall time. Exits non-zero if any particle
# ever went non-finite or escaped.   scripts/soak.sh [STEPS] [EVERY] [extra carom soak args]
set -euo pipefail
cd "$(dirname "$0")/.."
steps="${1:-1000000}"
every="${2:-10000}"
shift 2 2>/dev/null || shift $# 
cargo build --release -q -p carom-cli
exec target/release/carom soak scenes/lecture_5000_grid100.toml --steps "$steps" --every "$every" "$@"
