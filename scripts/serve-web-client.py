"""Serves a web client's render page by hand, as the render tests' loopback server does
(tests/common/server.rs): GET /app/PATH from the client's folder, GET /common/PATH from the
clients' shared folder (clients/web-common, beside it), GET /work/PATH from a job folder (job.json,
the bakes), POST /result/NAME into the job folder's results/.

    python3 scripts/serve-web-client.py APP_DIR JOB_DIR PORT

scripts/web-client.sh (scripts/filament-web.sh, scripts/three-web.sh) calls it for `serve`.
"""
import http.server
import os
import sys

app, work, port = sys.argv[1], sys.argv[2], int(sys.argv[3])
types = {".js": "text/javascript", ".mjs": "text/javascript", ".wasm": "application/wasm"}


class Handler(http.server.SimpleHTTPRequestHandler):
    extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map, **types}

    def translate_path(self, path):
        path = path.split("?")[0]
        common = os.path.join(os.path.dirname(os.path.abspath(app)), "web-common")
        for prefix, root in (("/app/", app), ("/common/", common), ("/work/", work)):
            if path.startswith(prefix) and ".." not in path:
                return os.path.join(root, path[len(prefix):])
        return "/nonexistent"

    def do_POST(self):
        name = os.path.basename(self.path.split("/result/")[-1])
        data = self.rfile.read(int(self.headers["Content-Length"]))
        with open(os.path.join(work, "results", name), "wb") as f:
            f.write(data)
        self.send_response(200)
        self.end_headers()


http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler).serve_forever()
