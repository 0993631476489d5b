#!/usr/bin/env bash
# The Filament web client (clients/filament-web) that tests/filament_render.rs drives:
#
#   scripts/filament-web.sh install    npm ci in clients/filament-web (filament 1.53.4 and ktx-parse
#                                      2.0.0, pinned by package-lock.json; npm's cache first)
#   scripts/filament-web.sh serve DIR  serves the page on http://127.0.0.1:8765/app/index.html with
#                                      DIR/job.json as its job (see render.js) and writes what it
#                                      posts to DIR/results/: to look at a render by hand
#
# The test starts its own loopback server and headless Chromium; it needs only `install`.
set -euo pipefail
cd "$(dirname "$0")/../clients/filament-web"

case "${1:-install}" in
install)
    if ! command -v npm >/dev/null 2>&1; then
        echo "npm is required (Debian: apt-get install nodejs npm)" >&2
        exit 1
    fi
    npm ci --prefer-offline --no-audit --no-fund --loglevel=error
    ls node_modules/filament/filament.wasm node_modules/ktx-parse/dist/index.mjs >/dev/null
    version() { node -p "require('./node_modules/$1/package.json').version"; }
    echo "clients/filament-web: filament $(version filament), ktx-parse $(version ktx-parse)"
    ;;
serve)
    dir=$(cd "${2:?usage: scripts/filament-web.sh serve DIR}" && pwd)
    mkdir -p "$dir/results"
    echo "http://127.0.0.1:8765/app/index.html (job: $dir/job.json)"
    exec python3 ../../scripts/serve-web-client.py "$PWD" "$dir" 8765
    ;;
*)
    echo "usage: scripts/filament-web.sh install | serve DIR" >&2
    exit 2
    ;;
esac
