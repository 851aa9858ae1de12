#!/usr/bin/env bash
# Packs what the GPU check (scripts/gpu_check.sh, issue 37's first GPU numbers) needs into .gpu/
# (git-ignored through .git/info/exclude) for the `device` tool, which carries at most 64 MiB
# and whose machine has no toolchain and no network: the CLI and every test binary of this
# build, stripped, in one tar.xz (about 14 MB); the Debian packages of the Vulkan loader and of
# glvnd (a bare machine may lack them); the real scenes the benches and the real-scene tests
# read (plant and biker as PLY, playbot as its published SOG, 8 MB against the PLY's 82 MB).
# Then, on a lent machine: run(command="bash scripts/gpu_check.sh", carry=[".gpu"],
# timeout_s=540).
# Usage: scripts/gpu_bundle.sh (RARA_REAL_DATA, else ../shared/data/real).
set -euo pipefail
cd "$(dirname "$0")/.."
real=${RARA_REAL_DATA:-../shared/data/real}
out=.gpu
grep -qx '/.gpu/' .git/info/exclude 2>/dev/null || echo '/.gpu/' >> .git/info/exclude
rm -rf "$out"
mkdir -p "$out/bin" "$out/data"

cargo build --release --quiet
# Every test binary of the release build (cargo's JSON names them), stripped, under its
# target's name; the crate's unit tests as rara_lib and rara_bin.
cargo test --release --no-run --message-format=json 2>/dev/null | python3 -c '
import json, sys
for line in sys.stdin:
    try:
        m = json.loads(line)
    except ValueError:
        continue
    exe = m.get("executable")
    if not exe or m["target"]["kind"] == ["example"]:
        continue
    kind = m["target"]["kind"][0]
    name = m["target"]["name"]
    if m["profile"]["test"] and kind in ("lib", "bin"):
        name += "_" + kind
    elif kind == "bin":
        continue
    print(name, exe)
' | while read -r name exe; do
    strip -o "$out/bin/$name" "$exe"
done
strip -o "$out/bin/rara" target/release/rara
# The test binaries look for the crate (fixtures, the CLI) where it was built.
pwd > "$out/built_in"
git rev-parse --short HEAD > "$out/commit"
tar -C "$out" -cf - bin | xz -9 -T0 > "$out/bin.tar.xz"
rm -rf "$out/bin"

for stem in plant_capture_sh0 biker_capture_sh0; do
    cp "$real/$stem.ply" "$real/$stem.orbit_cameras.json" "$out/data/"
done
cp "$real/playbot_lod0_500k_sh2.orbit_cameras.json" "$out/data/"
cp -r "$real/originals/playbot_lod0_sog" "$out/data/"

# The Vulkan loader, and glvnd's libraries, without which NVIDIA's driver gives the loader no
# vkCreateInstance ("Found no drivers"; the device tool's recipe carries the same packages).
(cd "$out" && apt-get download -qq libvulkan1 libglvnd0 libglx0 libgl1 libegl1 libopengl0 \
    libgles2)
du -sh "$out"
echo "ready: run(command=\"bash scripts/gpu_check.sh\", carry=[\".gpu\"], timeout_s=540)"
