#!/usr/bin/env bash
# Installs what is missing, then runs the whole test suite in release mode (the GPU tests run
# on lavapipe, the CPU reference is the oracle, the validation layer is on). Real scenes come
# from $RARA_REAL_DATA or ../shared/data/real when present; --show-output prints which
# real-scene cases ran and their PSNR.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/setup.sh
# Blender and the glTF validator, for the tests of the mesh export (RARA_NO_CLIENTS=1 skips).
if [ -z "${RARA_NO_CLIENTS:-}" ]; then . scripts/clients.sh; fi
data="${RARA_REAL_DATA:-../shared/data/real}"
if [ -d "$data" ]; then echo "real scenes: $data"; else echo "real scenes: none at $data (those cases are skipped)"; fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# A test binary killed by a signal (a crash inside the Vulkan driver, say) dumps core in the
# repository root, its working directory; crash_report below prints where it died.
ulimit -c unlimited 2>/dev/null || true
rm -f core core.[0-9]*
status=0
cargo test --release "$@" -- --show-output 2>&1 | tee "$log" || status=$?
. scripts/crash_report.sh
crash_report "$log"
# One closing line over all test binaries (cargo prints one summary per binary). libtest has no
# runtime skip: a test that found none of its real scenes passes having checked nothing, so a
# test whose output (--show-output prints it under "---- NAME stdout ----") holds "TEST SKIPPED:"
# counts as skipped, not passed; real-scene cases skipped inside other tests are counted too.
awk '
  /^     Running / { bin = $2 }
  /^---- .* stdout ----$/ { test = bin " " $2 }
  /^TEST SKIPPED:/ && test != "" && !(test in skipped) { skipped[test] = 1; s++ }
  /^real-scene case .* SKIPPED/ { cases++ }
  /^test result:/ { p += $4; f += $6; i += $8 }
  END {
    printf "real-scene cases skipped: %d\n", cases
    printf "summary: %d passed, %d failed, %d skipped\n", p - s, f, i + s
  }' "$log"
exit "$status"
