#!/usr/bin/env bash
# The scene formats on one real scene (default playbot, 500k Gaussians, SH degree 2): the scene
# written in each format (rara convert for PLY, SPZ v4 and v3, glb and .splat; splat-transform
# for compressed PLY; the published SOG as it is), then for each file its size, its load time
# (the median of three loads, from `rara render`'s "loaded" line) and the PSNR of its render
# against the PLY's render from the same camera. Prints a Markdown table; files go to
# target/format_table/.
#
#   bash scripts/format_table.sh [SCENE_STEM] [WIDTH]
set -euo pipefail
cd "$(dirname "$0")/.."
stem="${1:-playbot_lod0_500k_sh2}"
width="${2:-640}"
real="${RARA_REAL_DATA:-../shared/data/real}"
ply="$real/$stem.ply"
cams="$real/$stem.orbit_cameras.json"
[ -f "$ply" ] || { echo "format_table: $ply is not here (set RARA_REAL_DATA)" >&2; exit 1; }
. scripts/clients.sh
cargo build --release --quiet --bin rara
rara=target/release/rara
st=target/clients/node_modules/.bin/splat-transform
out=target/format_table
mkdir -p "$out"

# The files, one line each: label, path, extra flags for rara.
files=("PLY|$ply|")
"$rara" convert "$ply" -o "$out/$stem.spz" 2>/dev/null
files+=("SPZ v4 (rara)|$out/$stem.spz|")
"$rara" convert "$ply" --spz-version 3 -o "$out/${stem}_v3.spz" 2>/dev/null
files+=("SPZ v3 (rara)|$out/${stem}_v3.spz|")
"$rara" convert "$ply" -o "$out/$stem.glb" 2>/dev/null
files+=("glb KHR_gaussian_splatting (rara)|$out/$stem.glb|")
"$rara" convert "$ply" -o "$out/$stem.splat" 2>/dev/null
files+=(".splat (rara; SH dropped)|$out/$stem.splat|")
if [ -x "$st" ]; then
  "$st" -q -w "$ply" "$out/$stem.compressed.ply"
  files+=("compressed PLY (splat-transform)|$out/$stem.compressed.ply|")
  "$st" -q -w --spz-version 4 "$ply" "$out/${stem}_st.spz"
  files+=("SPZ v4 (splat-transform)|$out/${stem}_st.spz|--spz-axes as-stored")
else
  echo "format_table: splat-transform is not installed; its rows are left out" >&2
fi
case "$stem" in
  playbot_lod0_500k_sh2) [ -d "$real/originals/playbot_lod0_sog" ] &&
    files+=("SOG v2 (published, a folder)|$real/originals/playbot_lod0_sog|") ;;
esac

render() { # FILE FLAGS OUT -> prints the load time in ms
  # shellcheck disable=SC2086
  "$rara" render "$1" $2 --cameras "$cams" --camera 0 --width "$width" -o "$3" 2>&1 |
    sed -n 's/^loaded .*(\([0-9]*\) ms)$/\1/p'
}

echo "| format | file MB | load ms (median of 3) | PSNR against the PLY's render |"
echo "|---|---|---|---|"
for entry in "${files[@]}"; do
  IFS='|' read -r label file flags <<<"$entry"
  bytes=$(du -sb "$file" | cut -f1)
  times=()
  for k in 1 2 3; do
    times+=("$(render "$file" "$flags" "$out/render_$k.png")")
  done
  median=$(printf '%s\n' "${times[@]}" | sort -n | sed -n 2p)
  if [ "$label" = "PLY" ]; then
    cp "$out/render_1.png" "$out/reference.png"
    psnr="(reference)"
  else
    psnr=$("$rara" compare "$out/reference.png" "$out/render_1.png" --json |
      python3 -c 'import json,sys; p = json.load(sys.stdin)["psnr"]; print("identical" if p is None else "%.2f dB" % p)')
  fi
  printf '| %s | %.1f | %s | %s |\n' "$label" "$(echo "$bytes / 1000000" | bc -l)" "$median" "$psnr"
done
