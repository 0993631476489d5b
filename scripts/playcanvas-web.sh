#!/usr/bin/env bash
# The PlayCanvas web client (clients/playcanvas-web) that tests/playcanvas_render.rs drives:
#
#   scripts/playcanvas-web.sh install    npm ci in clients/playcanvas-web (playcanvas 2.23.3,
#                                        pinned by package-lock.json; npm's cache first)
#   scripts/playcanvas-web.sh serve DIR  serves the page on http://127.0.0.1:8769/app/index.html with
#                                        DIR/job.json as its job (see render.js) and writes what it
#                                        posts to DIR/results/: to look at a render by hand
#
# The test starts its own loopback server and headless Chromium; it needs only `install`.
exec bash "$(dirname "$0")/web-client.sh" playcanvas-web 8769 "$@"
