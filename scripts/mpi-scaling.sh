#!/usr/bin/env bash
# Strong and weak scaling of a split run over 1, 2 and 4 MPI ranks on this machine, with the
# traffic per step that the ranks send each other (issue 6).
#
#   scripts/mpi-scaling.sh [STEPS] [PER_RANK]      (defaults: 200 steps, 50000 particles)
#
# Needs Open MPI (apt-get install openmpi-bin libopenmpi-dev libclang-dev). Builds carom with
# `--features mpi`. Every rank runs one thread (`--threads 1`), so P ranks use P cores; the
# single-process rows are the shared-memory baseline. Prints a Markdown table.
set -euo pipefail
cd "$(dirname "$0")/.."
steps="${1:-200}"
per_rank="${2:-50000}"
cargo build --release -q -p carom-cli --features mpi
carom="$PWD/target/release/carom"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# A walled 2D box under gravity at 30% area fraction, r = 1, k = 0.5: `count` particles, the
# width fixed, the height growing with the count, so that ranks (slabs along y) get the same
# shape whatever their number.
scene() { # count file
    local count=$1 file=$2
    python3 - "$count" "$file" <<'PY'
import math, sys
count, path = int(sys.argv[1]), sys.argv[2]
width = 400.0
height = count * math.pi / 0.30 / width
open(path, "w").write(f"""name = "scaling {count}"
dimensions = 2
dt = 0.005
gravity = [0.0, -9.8]
restitution = 0.5
[domain]
min = [0.0, 0.0]
max = [{width}, {height:.3f}]
walls = true
[[fill]]
count = {count}
radius = 1.0
speed = 10.0
seed = 1
""")
PY
}

# ms/step, KiB sent per rank per step, collectives per step of one run
measure() { # launcher... -- scene
    local out
    out="$("$@" --steps "$steps" 2>&1)" || { echo "$out" >&2; exit 1; }
    local ms kib coll
    ms=$(awk '/^time/ { print $5 }' <<<"$out")
    kib=$(awk '/^traffic/ { print $2 }' <<<"$out")
    coll=$(awk '/^traffic/ { for (i = 1; i < NF; i++) if ($(i+1) == "collectives") print $i }' <<<"$out")
    echo "${ms} ${kib:--} ${coll:--}"
}

mpi() { # ranks, then `carom run` arguments
    local ranks=$1
    shift
    mpirun --allow-run-as-root --oversubscribe -np "$ranks" "$carom" run "$@" --threads 1
}

echo "machine: $(nproc) cores, $(awk -F': ' '/model name/ { print $2; exit }' /proc/cpuinfo), $(awk '/MemTotal/ { printf "%.0f GiB", $2 / 1048576 }' /proc/meminfo); $(mpirun --version | head -1)"
echo "command: scripts/mpi-scaling.sh $steps $per_rank"
echo
echo "| kind | particles | ranks | ms/step | speed-up | efficiency | KiB sent/rank/step | collectives/step |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
strong=$((per_rank * 4))
scene "$strong" "$work/strong.toml"
read -r base _ _ < <(measure "$carom" run "$work/strong.toml" --threads 1)
echo "| strong, 1 process 1 thread | $strong | 1 | $base | 1.00 | 100% | - | - |"
read -r ms _ _ < <(measure "$carom" run "$work/strong.toml" --threads 2)
echo "| strong, 1 process 2 threads | $strong | 1 | $ms | $(awk -v a="$base" -v b="$ms" 'BEGIN { printf "%.2f", a / b }') | - | - | - |"
for p in 1 2 4; do
    read -r ms kib coll < <(measure mpi "$p" "$work/strong.toml")
    speed=$(awk -v a="$base" -v b="$ms" 'BEGIN { printf "%.2f", a / b }')
    eff=$(awk -v a="$base" -v b="$ms" -v p="$p" 'BEGIN { printf "%.0f%%", 100 * a / b / p }')
    echo "| strong, mpirun | $strong | $p | $ms | $speed | $eff | $kib | $coll |"
done
for p in 1 2 4; do
    n=$((per_rank * p))
    scene "$n" "$work/weak$p.toml"
    read -r ms kib coll < <(measure mpi "$p" "$work/weak$p.toml")
    if [ "$p" = 1 ]; then weak_base=$ms; fi
    eff=$(awk -v a="$weak_base" -v b="$ms" 'BEGIN { printf "%.0f%%", 100 * a / b }')
    echo "| weak, mpirun | $n | $p | $ms | - | $eff | $kib | $coll |"
done
