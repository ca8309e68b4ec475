#!/usr/bin/env bash
# Builds the wasm package into pkg/ (not committed) for the page in www/.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --lib --target wasm32-unknown-unknown
wasm-bindgen --target web --out-dir pkg --no-typescript \
  target/wasm32-unknown-unknown/release/stripelight.wasm
# Shrink with wasm-opt where the installed binaryen understands the module; the
# unoptimized module works as well, so a refusal here is not fatal.
if command -v wasm-opt >/dev/null; then
  if wasm-opt -O3 --enable-bulk-memory --enable-nontrapping-float-to-int --enable-sign-ext \
       --enable-mutable-globals --enable-reference-types --enable-multivalue \
       pkg/stripelight_bg.wasm -o pkg/stripelight_bg.opt.wasm 2>/dev/null; then
    mv pkg/stripelight_bg.opt.wasm pkg/stripelight_bg.wasm
  else
    rm -f pkg/stripelight_bg.opt.wasm
    echo "build-web: wasm-opt could not read the module; keeping it unoptimized" >&2
  fi
fi
ls -l pkg/stripelight_bg.wasm >&2
