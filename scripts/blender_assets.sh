#!/usr/bin/env bash
# Makes the Blender assets the examples use and the repository does not hold (too large:
# examples/scenes/meshes/materials.glb is about 7.5 MB): Debian's Blender, headless, runs
# tests/blender/materials_glb.py (259,854 triangles: a textured Suzanne of 251,904, a glass, a
# gold and an emissive material). Skips a file that is there already. Usage: scripts/blender_assets.sh
set -euo pipefail
cd "$(dirname "$0")/.."
out=examples/scenes/meshes/materials.glb
if [ -f "$out" ]; then
    echo "blender_assets: $out is there"
    exit 0
fi
if ! command -v blender >/dev/null 2>&1; then
    echo "blender_assets: Blender is not installed (apt-get install blender python3-numpy)" >&2
    exit 1
fi
blender -b --factory-startup --python tests/blender/materials_glb.py -- "$out" 4 \
    | grep -E "TRIANGLES|Error" || true
test -f "$out"
echo "blender_assets: made $out"
