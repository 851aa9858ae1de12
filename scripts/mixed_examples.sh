#!/usr/bin/env bash
# Renders the mixed-scene examples of examples/scenes (SPEC section 8) into docs/, from the
# first orbit camera of each real scene (materials_plant: its own camera, and its Blender glb
# made first by scripts/blender_assets.sh), and benches each at 640x480. Needs the real scenes
# (RARA_REAL_DATA, else ../shared/data/real). Usage: scripts/mixed_examples.sh [WIDTH] [FRAMES]
set -euo pipefail
cd "$(dirname "$0")/.."
width=${1:-400}
frames=${2:-3}
real=${RARA_REAL_DATA:-../shared/data/real}
cargo build --release --quiet
# The biker's licence (CC BY-NC-ND 4.0) allows no derivative in the repository: its picture
# goes to target/, the others to docs/.
mkdir -p target/mixed_examples
for pair in mirror_plant:plant_capture_sh0 glass_biker:biker_capture_sh0 \
            shadow_skull:skull_mesh2splat_100k_sh0 clipped_mirror:plant_capture_sh0 \
            glass_plant:plant_capture_sh0; do
    name=${pair%%:*}
    stem=${pair#*:}
    out="docs/mixed_$name.png"
    if [ "$name" = glass_biker ]; then out="target/mixed_examples/mixed_$name.png"; fi
    ./target/release/rara render --scene "examples/scenes/$name.json" \
        --cameras "$real/$stem.orbit_cameras.json" --width "$width" -o "$out"
    if [ "$frames" -gt 0 ]; then
        ./target/release/rara bench --scene "examples/scenes/$name.json" \
            --cameras "$real/$stem.orbit_cameras.json" --width 640 --frames "$frames" --warmup 1
    fi
done
scripts/blender_assets.sh
./target/release/rara render --scene examples/scenes/materials_plant.json --width "$width" \
    -o docs/mixed_materials_plant.png
if [ "$frames" -gt 0 ]; then
    ./target/release/rara bench --scene examples/scenes/materials_plant.json --width 640 \
        --frames "$frames" --warmup 1
fi
