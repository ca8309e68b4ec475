"""Serves the web demo on 127.0.0.1 and prints its URL.

Only the folders the page needs are served: www/ (the page, its scripts, the worker and
the projector page), pkg/ and pkg-threads/ (the wasm packages the worker imports as
../pkg/ and, with WebAssembly threads, ../pkg-threads/), plus the stored frame the end-to-end test fetches from the page. Everything else in the
repository (.git/, target/, sources, scripts) answers 404, and so does any path with a
`.` or `..` segment, encoded or not. No directory is listed.

Every response carries a Content-Security-Policy that allows the page's own scripts,
workers and WebAssembly and nothing else, and is cross-origin isolated (COOP + COEP), so
that the page may use SharedArrayBuffer.
"""
import http.server
import os
import sys
import urllib.parse
from http import HTTPStatus

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Repository folders served under the same URL path. tests/e2e/fixtures/ is not used by
# the page; the end-to-end test (tests/e2e/run.mjs) fetches its stored frame from it.
SERVED = ("www", "pkg", "pkg-threads", "tests/e2e/fixtures")

CONTENT_SECURITY_POLICY = "; ".join([
    "default-src 'none'",
    # Module scripts from this origin; WebAssembly compilation (no JS eval).
    "script-src 'self' 'wasm-unsafe-eval'",
    # The decoder workers (module workers from this origin), and the thread pool's
    # workers, which wasm-bindgen-rayon starts from a blob: copy of its own script.
    "worker-src 'self' blob:",
    # The worker fetches pkg/stripelight_bg.wasm (or pkg-threads/'s).
    "connect-src 'self'",
    # The favicon is `data:,`. (The camera reaches its <video> as a MediaStream object,
    # which media-src does not govern; downloads are blob: navigations, not loads.)
    "img-src 'self' data:",
    # Stylesheets only; setting element.style from a script is allowed.
    "style-src 'self'",
    "object-src 'none'",
    "base-uri 'none'",
    "frame-ancestors 'none'",
    "form-action 'none'",
])

SECURITY_HEADERS = {
    "Content-Security-Policy": CONTENT_SECURITY_POLICY,
    "Cross-Origin-Opener-Policy": "same-origin",
    "Cross-Origin-Embedder-Policy": "require-corp",
    "Cross-Origin-Resource-Policy": "same-origin",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
}


def served_path(url_path):
    """The file or folder that `url_path` names inside a served folder, or None."""
    try:
        path = urllib.parse.unquote(url_path, errors="strict")
    except UnicodeDecodeError:
        return None
    if not path.startswith("/"):
        return None
    parts = path[1:].split("/")
    if any(p in (".", "..") or "\\" in p or "\0" in p for p in parts):
        return None
    for folder in SERVED:
        prefix = folder.split("/")
        if parts[:len(prefix)] != prefix:
            continue
        # Resolve symbolic links too: the result must stay inside the served folder.
        base = os.path.realpath(os.path.join(ROOT, *prefix))
        full = os.path.realpath(os.path.join(ROOT, *parts))
        if full == base or full.startswith(base + os.sep):
            return full
    return None


class Handler(http.server.SimpleHTTPRequestHandler):
    extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map,
                      ".wasm": "application/wasm", ".js": "text/javascript",
                      ".mjs": "text/javascript", ".json": "application/json"}

    def send_head(self):
        url_path = urllib.parse.urlsplit(self.path).path
        if url_path == "/":
            self.send_response(HTTPStatus.FOUND)
            self.send_header("Location", "/www/")
            self.send_header("Content-Length", "0")
            self.end_headers()
            return None
        if served_path(url_path) is None:
            self.send_error(HTTPStatus.NOT_FOUND)
            return None
        return super().send_head()

    def translate_path(self, path):
        # Only reached for paths send_head has accepted.
        return served_path(urllib.parse.urlsplit(path).path) or ""

    def list_directory(self, path):
        self.send_error(HTTPStatus.NOT_FOUND)
        return None

    def end_headers(self):
        for name, value in SECURITY_HEADERS.items():
            self.send_header(name, value)
        super().end_headers()

    def log_message(self, *args):
        pass


def main():
    port = int(sys.argv[1]) if len(sys.argv) > 1 else 8080
    with http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler) as server:
        print(f"stripelight demo: http://localhost:{port}/www/", flush=True)
        server.serve_forever()


if __name__ == "__main__":
    main()
