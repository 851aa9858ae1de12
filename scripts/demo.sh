#!/usr/bin/env bash
# Installs what is missing, then renders the built-in demo scene to ./rara-demo/*.png.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/setup.sh
cargo run --release --quiet -- demo "$@"
