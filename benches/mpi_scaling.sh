#!/usr/bin/env bash
# Ranks × threads on one machine (docs/design.md §9, README "Beyond one machine"):
# `reduce --method linefit` with 20 reference frequencies (50, 100, …, 1000 Hz) and
# interface = outputs + 5, run as 1 rank × 1 thread, 1 rank × 2 threads and 2 ranks × 1 thread.
# Prints one markdown row per run: wall time, rank 0's phases, each rank's peak RSS.
#
#   cargo build --release --features mpi
#   benches/mpi_scaling.sh MODEL_DIR [MODEL_DIR ...]
#
# Needs OpenMPI's mpirun and GNU time (/usr/bin/time).
set -euo pipefail
bin="$(dirname "$0")/../target/release/sparsemor"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none
freqs=$(seq -s, 50 50 1000)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

echo "| model | N | ranks × threads | wall s | symbolic s | sweep s | gather s | fit + projection s | peak RSS per rank GB |"
echo "|---|---|---|---|---|---|---|---|---|"
for model in "$@"; do
  n=$(grep -m1 -E '^[0-9]+ [0-9]+ [0-9]+' "$model/K.mtx" | cut -d' ' -f1)
  for run in "1 1" "1 2" "2 1"; do
    set -- $run
    ranks=$1 threads=$2
    rm -rf "$out/rom" "$out"/rss.*
    launch=()
    [ "$ranks" -gt 1 ] && launch=(mpirun --oversubscribe -np "$ranks")
    start=$(date +%s%N)
    # each rank under GNU time, writing its peak RSS (KiB) to rss.<its shell's pid>
    "${launch[@]}" sh -c 'exec /usr/bin/time -f %M -o "$0/rss.$$" "$@"' "$out" \
      "$bin" reduce "$model" --method linefit --extra-interface 5 --ref-freqs "$freqs" \
      --threads "$threads" --out "$out/rom" > "$out/log" 2>&1 || { cat "$out/log"; exit 1; }
    wall=$(awk -v a="$start" -v b="$(date +%s%N)" 'BEGIN { print (b - a) / 1e9 }')
    phase() { { grep -m1 "time *$1" "$out/log" || true; } | awk '{print $(NF-1)}'; }
    gather=$(phase "gather"); gather=${gather:-–}
    rss=$(cat "$out"/rss.* 2>/dev/null | awk '{printf "%s%.2f", sep, $1*1024/1e9; sep=" / "}')
    printf "| %s | %s | %s × %s | %.2f | %s | %s | %s | %s | %s |\n" \
      "$(basename "$model")" "$n" "$ranks" "$threads" "$wall" "$(phase symbolic)" \
      "$(phase 'sweep')" "$gather" "$(phase 'fit')" "$rss"
  done
done
