#!/usr/bin/env bash
# Installs whatever stripelight's build, demo and tests need and this machine lacks.
# Idempotent: a second run installs nothing. Used by demo.sh and test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { printf 'setup: %s\n' "$*" >&2; }
as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

# Rust's wasm target.
if ! rustup target list --installed | grep -qx wasm32-unknown-unknown; then
  say "adding the wasm32-unknown-unknown target"
  rustup target add wasm32-unknown-unknown
fi

# The nightly toolchain of the WebAssembly threads build, with the standard library's
# sources (it is rebuilt with atomics).
. scripts/wasm-threads.env
if ! rustup run "$THREADS_TOOLCHAIN" rustc --version >/dev/null 2>&1 ||
   ! rustup component list --toolchain "$THREADS_TOOLCHAIN" --installed | grep -q '^rust-src'; then
  say "installing the $THREADS_TOOLCHAIN toolchain with rust-src (for pkg-threads/)"
  rustup toolchain install "$THREADS_TOOLCHAIN" --profile minimal --component rust-src
fi

# wasm-bindgen-cli at exactly the version Cargo.lock pins for the wasm-bindgen crate
# (the generated JS glue and the runtime crate must match).
want=$(awk '$0 == "name = \"wasm-bindgen\"" { getline; gsub(/"/, "", $3); print $3; exit }' Cargo.lock)
have=$(wasm-bindgen --version 2>/dev/null | awk '{print $2}' || true)
if [ -z "$want" ]; then
  say "Cargo.lock does not pin wasm-bindgen"; exit 1
fi
if [ "$have" != "$want" ]; then
  say "installing wasm-bindgen-cli $want (have: ${have:-none}; takes about 3 minutes)"
  # Not --locked: the CLI's own lock file pins a webpki-roots release the registry no longer serves.
  cargo install wasm-bindgen-cli --version "$want"
fi

# Debian packages: Chromium and its driver for the browser tests.
missing=()
[ -x /usr/bin/chromium ] || missing+=(chromium)
[ -x /usr/bin/chromedriver ] || missing+=(chromium-driver)
if [ ${#missing[@]} -gt 0 ]; then
  say "installing ${missing[*]} from Debian"
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# npm packages for the end-to-end browser test (playwright-core drives Debian's Chromium;
# it downloads no browser of its own).
if [ -f package-lock.json ] && [ ! -d node_modules/playwright-core ]; then
  say "installing npm packages"
  npm ci --no-audit --no-fund --loglevel=error
fi
