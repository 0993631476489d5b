#!/usr/bin/env bash
# A web client of the engine render tests (clients/filament-web for tests/filament_render.rs,
# clients/three-web for tests/three_render.rs, clients/khronos-web for tests/khronos_render.rs,
# clients/babylon-web for tests/babylon_render.rs and tests/gltf_render.rs, clients/playcanvas-web
# for tests/playcanvas_render.rs),
# through its own script (scripts/filament-web.sh, scripts/three-web.sh, scripts/khronos-web.sh,
# scripts/babylon-web.sh, scripts/playcanvas-web.sh),
# which passes its folder and port:
#
#   scripts/web-client.sh CLIENT PORT install    npm ci in clients/CLIENT (the packages pinned by its
#                                                package-lock.json; npm's cache first), then prints
#                                                the version of each package installed
#   scripts/web-client.sh CLIENT PORT serve DIR  serves the page on http://127.0.0.1:PORT/app/index.html
#                                                with DIR/job.json as its job (see its render.js) and
#                                                writes what it posts to DIR/results/: to look at a
#                                                render by hand
#
# The tests start their own loopback server and headless Chromium; they need only `install`.
set -euo pipefail
client=${1:?usage: scripts/web-client.sh CLIENT PORT install | serve DIR}
port=${2:?usage: scripts/web-client.sh CLIENT PORT install | serve DIR}
script="scripts/$client.sh"
cd "$(dirname "$0")/../clients/$client"

case "${3:-install}" in
install)
    if ! command -v npm >/dev/null 2>&1; then
        echo "npm is required (Debian: apt-get install nodejs npm)" >&2
        exit 1
    fi
    npm ci --prefer-offline --no-audit --no-fund --loglevel=error
    npm ls --depth=0 >/dev/null
    echo "clients/$client: $(node -p "Object.keys(require('./package.json').dependencies).map(d => d + ' ' + require('./node_modules/' + d + '/package.json').version).join(', ')")"
    ;;
serve)
    dir=$(cd "${4:?usage: $script serve DIR}" && pwd)
    mkdir -p "$dir/results"
    echo "http://127.0.0.1:$port/app/index.html (job: $dir/job.json)"
    exec python3 ../../scripts/serve-web-client.py "$PWD" "$dir" "$port"
    ;;
*)
    echo "usage: $script install | serve DIR" >&2
    exit 2
    ;;
esac
