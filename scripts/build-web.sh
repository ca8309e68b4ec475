#!/usr/bin/env bash
# Builds the page's two wasm packages (not committed): pkg/, which scans on the worker's
# one thread, and pkg-threads/, with WebAssembly threads (shared memory and a pool of web
# workers; nightly toolchain and flags in scripts/wasm-threads.env). The worker loads
# pkg-threads/ where the page is cross-origin isolated and falls back to pkg/.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/wasm-threads.env
target="${CARGO_TARGET_DIR:-target}"
cargo build --release --locked --lib --target wasm32-unknown-unknown
# No wasm-opt pass: Debian's binaryen rewrote wasm-bindgen's function table into a
# module the browser refuses ("WebAssembly.Table.set(): Argument 1 is invalid"). The
# release build with LTO is what the page loads.
wasm-bindgen --target web --out-dir pkg --no-typescript \
  "$target/wasm32-unknown-unknown/release/stripelight.wasm"
# Its own target folder: other flags and a rebuilt standard library.
RUSTFLAGS="$THREADS_RUSTFLAGS" CARGO_TARGET_DIR="$target/threads" \
  cargo "+$THREADS_TOOLCHAIN" build --release --locked --lib --target wasm32-unknown-unknown \
  --features threads -Z build-std=panic_abort,std
rm -rf pkg-threads
wasm-bindgen --target web --out-dir pkg-threads --no-typescript \
  "$target/threads/wasm32-unknown-unknown/release/stripelight.wasm"
ls -l pkg/stripelight_bg.wasm pkg-threads/stripelight_bg.wasm >&2
