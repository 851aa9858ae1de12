#!/usr/bin/env bash
# Installs what is missing, then runs the whole test suite in release mode on two Vulkan
# drivers: every test on Mesa's lavapipe, then the GPU-against-CPU tiers again on Google's
# SwiftShader (Debian's chromium-common ships it), a second conformant implementation with
# another compiler, another subgroup size (4) and no shaderInt64. The CPU reference is the
# oracle and the validation layer is on. Real scenes come from $RARA_REAL_DATA or
# ../shared/data/real when present; --show-output prints which real-scene cases ran and their
# PSNR. RARA_TEST_DRIVERS picks the drivers (default "lavapipe swiftshader"); arguments go to
# the lavapipe run's `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/setup.sh
# Blender and the glTF validator, for the tests of the mesh export (RARA_NO_CLIENTS=1 skips).
if [ -z "${RARA_NO_CLIENTS:-}" ]; then . scripts/clients.sh; fi
drivers=${RARA_TEST_DRIVERS:-lavapipe swiftshader}
swiftshader_icd=/usr/lib/chromium/vk_swiftshader_icd.json
if [[ " $drivers " == *" swiftshader "* ]] && [ ! -f "$swiftshader_icd" ]; then
  echo "setup: installing chromium-common (SwiftShader's Vulkan driver)" >&2
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: run as root, or RARA_TEST_DRIVERS=lavapipe to test on lavapipe alone" >&2
    exit 1
  fi
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium-common >/dev/null
fi
data="${RARA_REAL_DATA:-../shared/data/real}"
if [ -d "$data" ]; then echo "real scenes: $data"; else echo "real scenes: none at $data (those cases are skipped)"; fi
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
# A test binary killed by a signal (a crash inside the Vulkan driver, say) dumps core in the
# repository root, its working directory; crash_report below prints where it died.
ulimit -c unlimited 2>/dev/null || true
rm -f core core.[0-9]*
. scripts/crash_report.sh
# The test binaries of the tiers that run on the GPU and check it against the CPU reference
# (docs/TESTING.md, "Two drivers"): what SwiftShader runs.
gpu_tiers=(drivers render clip raytrace trace mixed objects flat depth bvh sort engine cli)

status=0
# run DRIVER ICD EXPECTED_DEVICE CARGO_TEST_ARGS...: the suite on one driver, alone (the
# loader reads VK_DRIVER_FILES, older loaders VK_ICD_FILENAMES); tests/drivers.rs checks
# that the device found is EXPECTED_DEVICE.
run() {
  local driver=$1 icd=$2 expect=$3
  shift 3
  echo "=== driver: $driver ($icd)"
  local t0=$SECONDS
  VK_DRIVER_FILES=$icd VK_ICD_FILENAMES=$icd RARA_EXPECT_DEVICE=$expect \
    RARA_VALIDATION=${RARA_VALIDATION:-} cargo test --release "$@" -- --show-output 2>&1 \
    | tee "$logs/$driver.log" || status=1
  crash_report "$logs/$driver.log"
  echo "=== driver: $driver: $((SECONDS - t0)) s"
}
for driver in $drivers; do
  case $driver in
    lavapipe)
      icd=$(ls /usr/share/vulkan/icd.d/lvp_icd.*.json 2>/dev/null | head -1)
      [ -n "$icd" ] || { echo "no lavapipe ICD in /usr/share/vulkan/icd.d" >&2; exit 1; }
      run lavapipe "$icd" llvmpipe "$@" ;;
    swiftshader)
      # The binary's commands (tests/cli.rs) with the validation layer on too: a message fails
      # the test (common::assert_success).
      RARA_VALIDATION=1 run swiftshader "$swiftshader_icd" SwiftShader "${gpu_tiers[@]/#/--test=}" ;;
    *) echo "RARA_TEST_DRIVERS: unknown driver '$driver' (lavapipe, swiftshader)" >&2; exit 1 ;;
  esac
done
# One closing line over all test binaries and drivers (cargo prints one summary per binary),
# after one per driver. libtest has no runtime skip: a test that found none of its real scenes
# passes having checked nothing, so a test whose output (--show-output prints it under
# "---- NAME stdout ----") holds "TEST SKIPPED:" counts as skipped, not passed; real-scene cases
# skipped inside other tests are counted too.
for driver in $drivers; do
  awk -v driver="$driver" '
    /^     Running / { bin = $2 }
    /^---- .* stdout ----$/ { test = bin " " $2 }
    /^TEST SKIPPED:/ && test != "" && !(test in skipped) { skipped[test] = 1; s++ }
    /^real-scene case .* SKIPPED/ { cases++ }
    /^test result:/ { p += $4; f += $6; i += $8 }
    END { printf "%s: %d passed, %d failed, %d skipped, %d real-scene cases skipped\n", driver, p - s, f, i + s, cases }
  ' "$logs/$driver.log"
done | tee "$logs/drivers"
awk '{ p += $2; f += $4; s += $6; c += $8 }
  END {
    printf "real-scene cases skipped: %d\n", c
    printf "summary: %d passed, %d failed, %d skipped\n", p, f, s
  }' "$logs/drivers"
exit "$status"
