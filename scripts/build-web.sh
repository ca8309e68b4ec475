#!/usr/bin/env bash
# Builds the wasm package into pkg/ (not committed) for the page in www/.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --lib --target wasm32-unknown-unknown
# No wasm-opt pass: Debian's binaryen rewrote wasm-bindgen's function table into a
# module the browser refuses ("WebAssembly.Table.set(): Argument 1 is invalid"). The
# release build with LTO is what the page loads.
wasm-bindgen --target web --out-dir pkg --no-typescript \
  "${CARGO_TARGET_DIR:-target}/wasm32-unknown-unknown/release/stripelight.wasm"
ls -l pkg/stripelight_bg.wasm >&2
