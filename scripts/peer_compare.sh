#!/usr/bin/env bash
# Unclipped frame time of rara against web-splat (the peer renderer), measured in one window:
# for each scene and size, ROUNDS rounds of web-splat then `rara bench`, and the median of the
# per-round ratios rara / web-splat (wall medians: both include submission and the wait; rara's
# includes its readback). docs/PERFORMANCE.md explains the method.
#
#   bash scripts/peer_compare.sh [SCENE...]        (default: plant playbot)
#
# Environment: RARA_REAL_DATA (../shared/data/real), PEER (../shared/peer, the harness),
# PEER_DIR (where its setup.sh built web-splat; /tmp/peer), SIZES ("640x480 1280x960"),
# ROUNDS (3), FRAMES (10), WARMUP (2), RARA (target/release/rara), LP_NUM_THREADS (passed to
# both; unset = lavapipe's default, where web-splat's sort races: see the peer's README).
# Prints one line per round and a summary per scene and size. Needs the peer harness built:
# without it, says so and exits 0 having measured nothing.
set -euo pipefail
cd "$(dirname "$0")/.."
data="${RARA_REAL_DATA:-../shared/data/real}"
peer="${PEER:-../shared/peer}"
rara="${RARA:-target/release/rara}"
rounds="${ROUNDS:-3}"
frames="${FRAMES:-10}"
warmup="${WARMUP:-2}"
sizes="${SIZES:-640x480 1280x960}"
bin="${PEER_HARNESS_BIN:-${PEER_DIR:-/tmp/peer}/harness/target/release/peer_harness}"
if [ ! -x "$bin" ] || [ ! -x "$peer/peer_bench.sh" ]; then
  echo "peer_compare: SKIPPED, no web-splat harness at $bin (build it with $peer/setup.sh)"
  exit 0
fi
[ -x "$rara" ] || cargo build --release --bin rara
declare -A file=([plant]=plant_capture_sh0 [playbot]=playbot_lod0_500k_sh2 [biker]=biker_capture_sh0
  [skull]=skull_mesh2splat_100k_sh0 [guitar]=guitar_capture_sh0_anisotropic)
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(plant playbot)
echo "rara: $(git rev-parse --short HEAD); LP_NUM_THREADS=${LP_NUM_THREADS:-default}; $rounds rounds of $frames frames after $warmup"
for s in "${scenes[@]}"; do
  ply="$data/${file[$s]}.ply"
  cams="$data/${file[$s]}.orbit_cameras.json"
  [ -f "$ply" ] || { echo "$s: SKIPPED, no $ply"; continue; }
  for size in $sizes; do
    w=${size%x*}
    h=${size#*x}
    ratios=()
    for r in $(seq 1 "$rounds"); do
      peer_ms=$(PEER_HARNESS_BIN="$bin" PEER_FRAMES="$frames" PEER_WARMUP="$warmup" \
        "$peer/peer_bench.sh" "$ply" "$cams" 0 "$w" "$h")
      json=$(mktemp --suffix=.json)
      "$rara" bench "$ply" --cameras "$cams" --camera 0 --width "$w" --height "$h" \
        --modes original --frames "$frames" --warmup "$warmup" --json "$json" >/dev/null
      rara_ms=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['modes']['original']['wall_median_ms'])" "$json")
      rm -f "$json"
      ratio=$(python3 -c "print(f'{$rara_ms / $peer_ms:.3f}')")
      ratios+=("$ratio")
      printf '%s %s round %d: web-splat %.1f ms, rara %.1f ms, rara / web-splat %s\n' \
        "$s" "$size" "$r" "$peer_ms" "$rara_ms" "$ratio"
    done
    median=$(printf '%s\n' "${ratios[@]}" | sort -n | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}')
    echo "$s $size: median of the per-round ratios rara / web-splat = $median (${ratios[*]})"
  done
done
