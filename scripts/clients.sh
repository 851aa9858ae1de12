#!/usr/bin/env bash
# Installs the real clients the tests drive, where they are missing: Debian's Blender (with
# python3-numpy, which its glTF importer needs) and ffmpeg (the MP4s of sweep and
# render-sequence), from npm (into target/clients) the Khronos
# glTF validator and PlayCanvas' splat-transform (the scene formats' reference tool), and from
# PyPI (into a virtual environment, target/clients/pycolmap) COLMAP's Python bindings, which
# write the COLMAP models tests/colmap.rs reads. Sourced by scripts/test.sh after setup.sh; a client that cannot be
# installed is reported, and the tests that need it say TEST SKIPPED.

client_packages=(blender python3-numpy python3-venv ffmpeg)
missing=()
for p in "${client_packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if ((${#missing[@]})); then
  if [ "$(id -u)" -eq 0 ]; then
    echo "clients: installing ${missing[*]}" >&2
    apt-get update -qq &&
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null ||
      echo "clients: could not install ${missing[*]}; the Blender tests will be skipped" >&2
  else
    echo "clients: ${missing[*]} missing and not root; the Blender tests will be skipped" >&2
  fi
fi

validator_version=2.0.0-dev.3.10
if [ ! -d target/clients/node_modules/gltf-validator ]; then
  if command -v npm >/dev/null 2>&1; then
    echo "clients: installing gltf-validator@$validator_version from npm into target/clients" >&2
    mkdir -p target/clients
    npm install --silent --no-audit --no-fund --prefix target/clients "gltf-validator@$validator_version" >/dev/null ||
      echo "clients: npm install gltf-validator failed; the validator test will be skipped" >&2
  else
    echo "clients: npm not found; the glTF validator test will be skipped" >&2
  fi
fi

# 3.10.2 declares node >= 22 but runs its readers and writers on Debian's node 20 (npm warns).
splat_transform_version=3.10.2
if ! grep -qs "\"version\": \"$splat_transform_version\"" \
  target/clients/node_modules/@playcanvas/splat-transform/package.json; then
  if command -v npm >/dev/null 2>&1; then
    echo "clients: installing @playcanvas/splat-transform@$splat_transform_version from npm into target/clients" >&2
    mkdir -p target/clients
    npm install --silent --no-audit --no-fund --prefix target/clients \
      "@playcanvas/splat-transform@$splat_transform_version" >/dev/null 2>&1 ||
      echo "clients: npm install splat-transform failed; the format cross-checks will be skipped" >&2
  else
    echo "clients: npm not found; the splat-transform cross-checks will be skipped" >&2
  fi
fi

pycolmap_version=4.2.1
if ! target/clients/pycolmap/bin/python -c "import pycolmap" >/dev/null 2>&1; then
  echo "clients: installing pycolmap==$pycolmap_version from PyPI into target/clients/pycolmap" >&2
  { python3 -m venv target/clients/pycolmap &&
    target/clients/pycolmap/bin/pip install --quiet --disable-pip-version-check \
      "pycolmap==$pycolmap_version"; } >/dev/null 2>&1 ||
    echo "clients: could not install pycolmap; the COLMAP cross-check will be skipped" >&2
fi
