#!/usr/bin/env bash
# Remakes tests/fixtures/formats/: a scene the crate generates (so its licence is the crate's),
# written by PlayCanvas' splat-transform, the reference tool, in each format it writes. The
# tests read these files and check them against source.ply within each format's quantisation
# (tests/formats.rs). Run it from anywhere; it needs node and npm (scripts/clients.sh installs
# the registry's @playcanvas/splat-transform, at the version it pins, into target/clients).
set -euo pipefail
cd "$(dirname "$0")/.."

# splat-transform at the version the tests pin, installed by the same step they use.
. scripts/clients.sh
version=$splat_transform_version
grep -q "\"version\": \"$version\"" target/clients/node_modules/@playcanvas/splat-transform/package.json
st=target/clients/node_modules/.bin/splat-transform
out=tests/fixtures/formats
cargo build --release --quiet --bin rara
rara=target/release/rara

rm -rf "$out"
mkdir -p "$out"
# 1,000 needle-like Gaussians (strands of hair: every rotation, scales 30:1) with SH degree 3.
"$rara" synth --kind hair --count 1000 --sh-degree 3 --seed 34 -o "$out/source.ply"
rm -f "$out/source.cameras.json"

# splat-transform's progress goes to stderr; -w overwrites, -q keeps it short.
"$st" -q -w "$out/source.ply" "$out/st.compressed.ply"
"$st" -q -w --spz-version 4 "$out/source.ply" "$out/st_v4.spz"
"$st" -q -w --spz-version 3 "$out/source.ply" "$out/st_v3.spz"
"$st" -q -w "$out/source.ply" "$out/st.glb"
# SOG's k-means runs on the CPU here (no WebGPU adapter on a server).
"$st" -q -w -g cpu "$out/source.ply" "$out/st.sog"

cat >"$out/README.md" <<EOF
# Format fixtures

Made by \`scripts/format_fixtures.sh\`: \`source.ply\` is \`rara synth --kind hair --count 1000
--sh-degree 3 --seed 34\` (the crate's own generated scene), and each \`st*\` file is that scene
written by \`@playcanvas/splat-transform@$version\` from the npm registry:

| file | format |
|---|---|
| st.compressed.ply | PlayCanvas compressed PLY |
| st_v4.spz | SPZ version 4 (splat-transform writes SPZ in the PLY's own axes) |
| st_v3.spz | SPZ version 3 |
| st.glb | glTF 2.0 binary, \`KHR_gaussian_splatting\` |
| st.sog | SOG version 2, bundled (zip) |

\`tests/formats.rs\` reads each one and checks it against \`source.ply\` within the format's
quantisation, property by property. Same licence as the crate.
EOF
ls -l "$out"
