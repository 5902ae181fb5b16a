#!/usr/bin/env bash
# Builds the page's WebAssembly module (crates/motion-web) into web/pkg/, installing the
# wasm-bindgen CLI at the exact version Cargo.lock pins when it is missing. Then serve web/ with
# any static server (`npm ci` first, for three.js) and open index.html.
set -euo pipefail
cd "$(dirname "$0")/.."
version=$(grep -A1 '^name = "wasm-bindgen"$' Cargo.lock | sed -n 's/^version = "\(.*\)"$/\1/p')
if ! wasm-bindgen --version 2>/dev/null | grep -qF "$version"; then
  echo "installing wasm-bindgen-cli $version (once)"
  cargo install wasm-bindgen-cli --version "$version"
fi
rustup target add wasm32-unknown-unknown >/dev/null 2>&1 || true
cargo build --release --target wasm32-unknown-unknown -p motion-web
wasm-bindgen --target web --out-dir web/pkg target/wasm32-unknown-unknown/release/motion_web.wasm
# The skinned character the page draws (CC0, assets/README.md).
cp assets/mannequin.glb web/pkg/mannequin.glb
echo "built web/pkg ($(du -k web/pkg/motion_web_bg.wasm | cut -f1) KiB of wasm)"
