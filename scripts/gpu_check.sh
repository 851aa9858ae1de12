#!/usr/bin/env bash
# Issue 37's GPU check, on a machine the `device` tool lends (scripts/gpu_bundle.sh packed
# .gpu/ first): `bench` on plant and playbot at 1920x1080, 1280x960 and 640x480
# (GPU_CHECK_SIZES), plant at 1920x1080 again with RARA_CUTOFF_TILES=splats and (with
# playbot) with RARA_CUTOFF_TILES=off, plant at 640x480 with it too, `bench --sort
# 2000000` (and with RARA_SORT=own, as playbot at 1920x1080) and a mixed scene's ray-traced
# `bench --scene`, then every test binary until GPU_CHECK_DEADLINE seconds (480) have passed,
# on the machine's Vulkan device. Everything goes to $OUT/gpu_check.log (OUT: the device
# tool's folder, else /tmp/gpu_check), and the whole output of up to six failing test
# binaries beside it.
# GPU_CHECK_QUICK=1 runs one test binary and short benches, to try the script itself (on
# lavapipe, say) without spending device time; GPU_CHECK_BENCH=0 runs the tests alone.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-/tmp/gpu_check}
mkdir -p "$out"
exec > >(tee "$out/gpu_check.log") 2>&1
g=$PWD/.gpu
quick=${GPU_CHECK_QUICK:-0}
[ -f "$g/bin.tar.xz" ] || { echo "no .gpu/bin.tar.xz: run scripts/gpu_bundle.sh first"; exit 2; }
echo "gpu_check: build $(cat "$g/commit"), $(date -u)"

# A bare machine may have no Vulkan loader, and NVIDIA's Vulkan driver (libGLX_nvidia, under
# /usr/local/nvidia on the lent machines) gives the loader no vkCreateInstance without glvnd's
# libraries: unpack the carried packages where one of their libraries is missing (not over a
# system that has them all, such as this one when the script is tried here).
for lib in libvulkan.so.1 libGLdispatch.so.0 libGLX.so.0 libGL.so.1 libEGL.so.1 \
    libOpenGL.so.0 libGLESv2.so.2; do
    if ! ldconfig -p | grep -q "^[[:space:]]*$lib "; then
        for f in "$g"/*.deb; do dpkg -x "$f" /; done
        ldconfig
        break
    fi
done
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$icd" ]; then
    export VK_DRIVER_FILES=$icd
fi
nvidia-smi -L 2>/dev/null || echo "(no nvidia-smi)"

# Unpacked outside the checkout: .gpu/ must stay small enough to travel (64 MiB) when the
# script was tried here first.
unpacked=$(mktemp -d)
trap 'rm -rf "$unpacked"' EXIT
tar -xJf "$g/bin.tar.xz" -C "$unpacked"
bin=$unpacked/bin
# The test binaries find the crate, its fixtures and the CLI where they were built.
built=$(cat "$g/built_in")
if [ "$built" != "$PWD" ] && [ ! -e "$built" ]; then
    mkdir -p "$(dirname "$built")"
    ln -s "$PWD" "$built"
fi
mkdir -p "$built/target/release"
[ -e "$built/target/release/rara" ] || cp "$bin/rara" "$built/target/release/rara"
rara="$bin/rara"
export RARA_REAL_DATA=$g/data
# A submission that has not finished after 20 s says so (RARA_GPU_WARN_S), so a test that
# hangs shows whether the GPU or the host holds it up (the tests one at a time: --nocapture).
export RARA_GPU_WARN_S=${RARA_GPU_WARN_S:-20}
real=$RARA_REAL_DATA

if [ "${GPU_CHECK_BENCH:-1}" = 1 ]; then
    frames=30
    sizes=${GPU_CHECK_SIZES:-"1920x1080 1280x960 640x480"}
    [ "$quick" = 1 ] && { frames=2; sizes=640x480; }
    for size in $sizes; do
        w=${size%x*}
        h=${size#*x}
        echo "=== bench plant $size"
        "$rara" bench "$real/plant_capture_sh0.ply" \
            --cameras "$real/plant_capture_sh0.orbit_cameras.json" \
            --width "$w" --height "$h" --frames "$frames"
        echo "=== bench playbot (SOG) $size"
        "$rara" bench "$real/playbot_lod0_sog/meta.json" \
            --cameras "$real/playbot_lod0_500k_sh2.orbit_cameras.json" \
            --width "$w" --height "$h" --frames "$frames"
    done
    # The GPU layout's cutoff tiles, pairs shared over the workgroup (the default) against
    # whole splats per invocation, where the pass was longest (plant at 1920x1080).
    # Then no per-tile classes at all (RARA_CUTOFF_TILES=off): the frame of the paper's
    # CUDA renderer, hard clipping's passes only, project writing the cutoff records and the
    # rasterizer weighting every pair of a cutoff splat; rara / hard <= 1.02 is issue 37's
    # goal on a GPU.
    if [ "$quick" != 1 ]; then
        echo "=== bench plant 1920x1080, RARA_CUTOFF_TILES=splats"
        RARA_CUTOFF_TILES=splats "$rara" bench "$real/plant_capture_sh0.ply" \
            --cameras "$real/plant_capture_sh0.orbit_cameras.json" \
            --width 1920 --height 1080 --frames "$frames"
        for size in 1920x1080 640x480; do
            echo "=== bench plant $size, RARA_CUTOFF_TILES=off"
            RARA_CUTOFF_TILES=off "$rara" bench "$real/plant_capture_sh0.ply" \
                --cameras "$real/plant_capture_sh0.orbit_cameras.json" \
                --width "${size%x*}" --height "${size#*x}" --frames "$frames" --modes hard,rara
        done
        echo "=== bench playbot (SOG) 1920x1080, RARA_CUTOFF_TILES=off"
        RARA_CUTOFF_TILES=off "$rara" bench "$real/playbot_lod0_sog/meta.json" \
            --cameras "$real/playbot_lod0_500k_sh2.orbit_cameras.json" \
            --width 1920 --height 1080 --frames "$frames" --modes hard,rara
    fi
    echo "=== bench --sort 2000000"
    "$rara" bench --sort 2000000
    # The CPU layout's sort (8-bit digits: 4 passes where the GPU layout takes 8) on the GPU:
    # the depth sort's 8 passes are most of the GPU frames' floor.
    if [ "$quick" != 1 ]; then
        echo "=== bench --sort 2000000, RARA_SORT=own"
        RARA_SORT=own "$rara" bench --sort 2000000
        echo "=== bench playbot (SOG) 1920x1080, RARA_SORT=own"
        RARA_SORT=own "$rara" bench "$real/playbot_lod0_sog/meta.json" \
            --cameras "$real/playbot_lod0_500k_sh2.orbit_cameras.json" \
            --width 1920 --height 1080 --frames "$frames"
    fi
    echo "=== bench --scene mirror_plant (ray traced) 640x480"
    "$rara" bench --scene examples/scenes/mirror_plant.json \
        --cameras "$real/plant_capture_sh0.orbit_cameras.json" --width 640 --frames 3 --warmup 1
fi
echo "=== tests"
# Each binary's output stays on the machine (the tool brings back 8 files at most); the log
# gets its counts, its failures and which real-scene cases ran.
logs=$(mktemp -d)
deadline=${GPU_CHECK_DEADLINE:-480}
# No binary took more than 53 s on an H200 (scale): one past this is stopped and its tests
# are run one at a time.
binary_limit=${GPU_CHECK_BINARY_LIMIT:-120}
passed=0
failed=0
binaries=("$bin"/*)
[ "$quick" = 1 ] && binaries=("$bin/sort")
for t in "${binaries[@]}"; do
    name=$(basename "$t")
    [ "$name" = rara ] && continue
    # The device tool's call ends at its timeout: leave the rest untested rather than lose the log.
    if [ "$SECONDS" -gt "$deadline" ]; then
        echo "$name: not run (past $deadline s)"
        continue
    fi
    start=$(date +%s)
    limit=$((deadline + 40 - SECONDS))
    [ "$limit" -gt "$binary_limit" ] && limit=$binary_limit
    (cd "$built" && timeout "$limit" "$t" 2>&1) > "$logs/$name.log"
    rc=$?
    p=$(grep -o '[0-9]* passed' "$logs/$name.log" | awk '{s += $1} END {print s + 0}')
    f=$(grep -o '[0-9]* failed' "$logs/$name.log" | awk '{s += $1} END {print s + 0}')
    passed=$((passed + p))
    failed=$((failed + f))
    echo "$name: rc $rc, $p passed, $f failed, $(($(date +%s) - start)) s"
    if [ "$rc" != 0 ]; then
        grep -E "^test .* FAILED|panicked" "$logs/$name.log" | head -5
        [ "$(ls "$out" | wc -l)" -le 6 ] && cp "$logs/$name.log" "$out/test_$name.log"
    fi
    grep -h "real-scene case" "$logs/$name.log" | sort | uniq -c | sed 's/^/  /'
    # Timed out (the trace binary did once on an H200, every test of it unreported after
    # 136 s): its tests one at a time, so the log names the one that does not end.
    if [ "$rc" = 124 ]; then
        # A GPU fault (an Xid) would show here; a hung process, in the compute apps.
        dmesg 2>/dev/null | grep -i -E 'xid|nvrm' | tail -5 | sed 's/^/  dmesg: /'
        nvidia-smi --query-compute-apps=pid,used_memory --format=csv,noheader 2>/dev/null \
            | sed 's/^/  still on the GPU: /'
        # A bare machine compiles every kernel cold: the driver's shader cache growing between
        # the first run and the reruns below points at compile time rather than a hang.
        du -sh "$HOME/.nv" "${XDG_CACHE_HOME:-$HOME/.cache}/nvidia" 2>/dev/null \
            | sed 's/^/  driver shader cache: /'
        tests=$(cd "$built" && "$t" --list --format terse 2>/dev/null | sed -n 's/: test$//p')
        for test in $tests; do
            [ "$SECONDS" -gt "$deadline" ] && break
            one=$(date +%s)
            (cd "$built" && timeout 60 "$t" --exact "$test" --nocapture 2>&1) \
                > "$logs/$name.$test.log"
            echo "  $test alone: rc $?, $(($(date +%s) - one)) s"
            grep -v '^$' "$logs/$name.$test.log" | tail -2 | sed 's/^/    /'
        done
        du -sh "$HOME/.nv" "${XDG_CACHE_HOME:-$HOME/.cache}/nvidia" 2>/dev/null \
            | sed 's/^/  driver shader cache after the reruns: /'
    fi
done
echo "tests: $passed passed, $failed failed"

echo "gpu_check: done, $(date -u)"
