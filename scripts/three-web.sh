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
exec bash "$(dirname "$0")/web-client.sh" three-web 8766 "$@"
