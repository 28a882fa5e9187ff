#!/usr/bin/env bash
# How `embertrace merge` scales with the number of parts and with the image
# size: renders sample-range shards of the Cornell box (one sample per pixel
# each), then times merges of 4, 16 and 64 parts of a 1920 x 1080 frame and
# of 16 parts at 960 x 540, 1920 x 1080 and 3840 x 2160, and prints a
# Markdown table (median of REPS merges; peak memory from the merge's
# --report, the kernel's VmHWM).
#
#   benches/farm/scale.sh [WORK_DIR]      # REPS=3, EMBERTRACE=target/release/embertrace
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
bin="${EMBERTRACE:-$root/target/release/embertrace}"
work="${1:-/tmp/embertrace-farm-scale}"
reps="${REPS:-3}"
scene="$root/scenes/cornell-box.toml"
mkdir -p "$work"

parts() { # W H N: render N shards of a W x H frame at N spp (1 spp each)
    local w=$1 h=$2 n=$3 d="$work/$1x$2-$3"
    mkdir -p "$d"
    for ((k = 1; k <= n; k++)); do
        [[ -f "$d/part-$k.exr" ]] || "$bin" render "$scene" -q -r "$w" "$h" -s "$n" \
            --shard "$k/$n" -o "$d/part-$k.exr"
    done
}

measure() { # DIR COUNT LABEL: median seconds and peak MB of merging COUNT parts
    local d=$1 count=$2 label=$3 secs=() mem=0 files=()
    for ((k = 1; k <= count; k++)); do files+=("$d/part-$k.exr"); done
    for ((r = 0; r < reps; r++)); do
        "$bin" merge "${files[@]}" -o "$work/out.exr" --accumulation --report "$work/r.json" 2>/dev/null
        secs+=("$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["seconds"])' "$work/r.json")")
        mem="$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["peak_memory_bytes"])' "$work/r.json")"
    done
    local med
    med="$(printf '%s\n' "${secs[@]}" | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}')"
    local size
    size="$(du -cm "${files[@]}" | tail -1 | cut -f1)"
    printf '| %s | %d | %d MB | %.2f s | %d MB |\n' "$label" "$count" "$size" "$med" "$((mem / 1048576))"
}

parts 1920 1080 64
parts 960 540 16
parts 3840 2160 16
echo "| frame | parts | parts on disk | merge time (median of $reps) | peak memory |"
echo "|---|---:|---:|---:|---:|"
for n in 4 16 64; do measure "$work/1920x1080-64" "$n" "1920 x 1080"; done
measure "$work/960x540-16" 16 "960 x 540"
measure "$work/1920x1080-64" 16 "1920 x 1080"
measure "$work/3840x2160-16" 16 "3840 x 2160"
