#!/usr/bin/env bash
# The three.js web client (clients/three-web) that tests/three_render.rs drives:
#
#   scripts/three-web.sh install    npm ci in clients/three-web (three 0.187.0, pinned by
#                                   package-lock.json; npm's cache first)
#   scripts/three-web.sh serve DIR  serves the page on http://127.0.0.1:8766/app/index.html with
#                                   DIR/job.json as its job (see render.js) and writes what it
#                                   posts to DIR/results/: to look at a render by hand
#
# The test starts its own loopback server and headless Chromium; it needs only `install`.
set -euo pipefail
cd "$(dirname "$0")/../clients/three-web"

case "${1:-install}" in
install)
    if ! command -v npm >/dev/null 2>&1; then
        echo "npm is required (Debian: apt-get install nodejs npm)" >&2
        exit 1
    fi
    npm ci --prefer-offline --no-audit --no-fund --loglevel=error
    ls node_modules/three/build/three.module.js node_modules/three/examples/jsm/loaders/HDRLoader.js >/dev/null
    echo "clients/three-web: three $(node -p "require('./node_modules/three/package.json').version")"
    ;;
serve)
    dir=$(cd "${2:?usage: scripts/three-web.sh serve DIR}" && pwd)
    mkdir -p "$dir/results"
    echo "http://127.0.0.1:8766/app/index.html (job: $dir/job.json)"
    exec python3 ../../scripts/serve-web-client.py "$PWD" "$dir" 8766
    ;;
*)
    echo "usage: scripts/three-web.sh install | serve DIR" >&2
    exit 2
    ;;
esac
