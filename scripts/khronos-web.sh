#!/usr/bin/env bash
# The Khronos web client (clients/khronos-web) that tests/khronos_render.rs drives:
#
#   scripts/khronos-web.sh install    npm ci in clients/khronos-web (@khronosgroup/gltf-viewer
#                                     1.1.0, the glTF Sample Viewer's renderer, and ktx-parse
#                                     2.0.0, pinned by package-lock.json; npm's cache first)
#   scripts/khronos-web.sh serve DIR  serves the page on http://127.0.0.1:8767/app/index.html with
#                                     DIR/job.json as its job (see render.js) and writes what it
#                                     posts to DIR/results/: to look at a render by hand
#
# The test starts its own loopback server and headless Chromium; it needs only `install`.
exec bash "$(dirname "$0")/web-client.sh" khronos-web 8767 "$@"
