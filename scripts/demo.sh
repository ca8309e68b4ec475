#!/usr/bin/env bash
# Installs what is missing, builds the wasm packages (pkg/ and pkg-threads/) and serves
# the web demo.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build-web.sh
port=${PORT:-8080}
exec python3 scripts/serve.py "$port"
