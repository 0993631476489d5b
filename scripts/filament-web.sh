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
exec bash "$(dirname "$0")/web-client.sh" filament-web 8765 "$@"
