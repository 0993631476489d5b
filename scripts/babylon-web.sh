#!/usr/bin/env bash
# The Babylon.js web client (clients/babylon-web) that tests/babylon_render.rs and
# tests/gltf_render.rs drive:
#
#   scripts/babylon-web.sh install    npm ci in clients/babylon-web (@babylonjs/core 9.37.1,
#                                     @babylonjs/loaders 9.28.0, gltf-validator 2.0.0-dev.3.10,
#                                     pinned by package-lock.json; npm's cache first)
#   scripts/babylon-web.sh serve DIR  serves the page on http://127.0.0.1:8768/app/index.html with
#                                     DIR/job.json as its job (see render.js) and writes what it
#                                     posts to DIR/results/: to look at a render by hand
#
# The test starts its own loopback server and headless Chromium; it needs only `install`.
exec bash "$(dirname "$0")/web-client.sh" babylon-web 8768 "$@"
