#!/usr/bin/env bash
# Installs what is missing, then runs the whole test suite in release mode (the GPU tests run
# on lavapipe, the CPU reference is the oracle, the validation layer is on). Real scenes come
# from $RARA_REAL_DATA or ../shared/data/real when present; --show-output prints which
# real-scene cases ran and their PSNR.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/setup.sh
data="${RARA_REAL_DATA:-../shared/data/real}"
if [ -d "$data" ]; then echo "real scenes: $data"; else echo "real scenes: none at $data (those cases are skipped)"; fi
cargo test --release "$@" -- --show-output
