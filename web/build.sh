#!/usr/bin/env bash
# Builds the page into web/dist/: static files only, which any static file server serves
# (`python3 -m http.server -d web/dist`). Needs Rust's wasm32 target and wasm-bindgen-cli
# of exactly the version of the wasm-bindgen crate in web/Cargo.lock (the two must agree on
# the glue they generate); wasm-opt (binaryen) shrinks the module further where installed.
set -euo pipefail
cd "$(dirname "$0")"

version=$(awk '/^name = "wasm-bindgen"$/ { getline; gsub(/version = |"/, ""); print }' Cargo.lock)
missing=()
if [ ! -d "$(rustc --print target-libdir --target wasm32-unknown-unknown 2>/dev/null)" ]; then
  missing+=("Rust's wasm32 target: rustup target add wasm32-unknown-unknown")
fi
found=$(wasm-bindgen --version 2>/dev/null | awk '{ print $2 }' || true)
if [ "$found" != "$version" ]; then
  missing+=("wasm-bindgen-cli $version (found: ${found:-none}): cargo install wasm-bindgen-cli --version $version")
fi
if [ ${#missing[@]} -gt 0 ]; then
  printf 'web/build.sh: missing %s\n' "${missing[@]}" >&2
  exit 1
fi

target_dir=${CARGO_TARGET_DIR:-../target/web}
cargo build --release --target wasm32-unknown-unknown --target-dir "$target_dir"
rm -rf dist
mkdir -p dist/scenes
wasm-bindgen --target web --no-typescript --out-dir dist "$target_dir/wasm32-unknown-unknown/release/raycaster_web.wasm"
if command -v wasm-opt >/dev/null; then
  wasm-opt -O2 dist/raycaster_web_bg.wasm -o dist/raycaster_web_bg.wasm
fi
cp index.html page.js style.css dist/

# The examples of scenes/ (its top folder: the hard cases are too large for a page) with
# their meshes, and the list the page offers them from.
cp ../scenes/*.txt ../scenes/*.obj dist/scenes/
(
  cd dist/scenes
  printf '['
  separator=
  for scene in *.txt; do
    printf '%s"%s"' "$separator" "$scene"
    separator=,
  done
  printf ']\n'
) >dist/scenes/index.json
echo "web/build.sh: built web/dist ($(du -k dist/raycaster_web_bg.wasm | cut -f1) KiB of wasm)"
