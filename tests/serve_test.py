"""The demo server (scripts/serve.py) serves the page and its wasm package with a strict
Content-Security-Policy and cross-origin isolation, on 127.0.0.1 only, and nothing else
of the repository. Run: python3 -m unittest tests/serve_test.py
"""
import http.client
import os
import socket
import subprocess
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# What the page needs, each checked for the security headers.
SERVED = ["/www/", "/www/index.html", "/www/worker.js", "/www/projector.html"]
for package in ("pkg", "pkg-threads"):
    if os.path.exists(os.path.join(ROOT, package, "stripelight.js")):
        SERVED.append(f"/{package}/stripelight.js")

# Paths that must answer 404, sent exactly as written (no client-side normalization).
FORBIDDEN = [
    "/.git/config",
    "/target/",
    "/Cargo.toml",
    "/scripts/serve.py",
    "/src/",
    "/tests/",
    "/www/../.git/config",
    "/www/%2e%2e/.git/config",
    "/www/%2E%2E/Cargo.toml",
    "/www%2f..%2f.git/config",
    "/pkg/../../../etc/passwd",
    "/www/./index.html",
]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class DemoServer(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.port = free_port()
        cls.server = subprocess.Popen(
            [sys.executable, os.path.join(ROOT, "scripts", "serve.py"), str(cls.port)],
            stdout=subprocess.PIPE, text=True)
        # The URL line comes once the socket listens.
        line = cls.server.stdout.readline()
        if f"http://localhost:{cls.port}/www/" not in line:
            cls.server.kill()
            raise RuntimeError(f"scripts/serve.py printed {line!r}")

    @classmethod
    def tearDownClass(cls):
        cls.server.terminate()
        cls.server.wait(timeout=10)
        cls.server.stdout.close()

    def get(self, path, host="127.0.0.1"):
        conn = http.client.HTTPConnection(host, self.port, timeout=10)
        try:
            conn.request("GET", path)
            res = conn.getresponse()
            res.read()
            return res
        finally:
            conn.close()

    def test_the_page_is_served_isolated_and_with_its_policy(self):
        for path in SERVED:
            with self.subTest(path=path):
                res = self.get(path)
                self.assertEqual(res.status, 200)
                csp = res.getheader("Content-Security-Policy", "")
                self.assertIn("default-src 'none'", csp)
                self.assertIn("script-src 'self' 'wasm-unsafe-eval'", csp)
                self.assertIn("worker-src 'self' blob:", csp)
                self.assertIn("style-src 'self'", csp)
                self.assertNotIn("unsafe-inline", csp)
                self.assertEqual(res.getheader("Cross-Origin-Opener-Policy"), "same-origin")
                self.assertEqual(res.getheader("Cross-Origin-Embedder-Policy"), "require-corp")
                self.assertEqual(res.getheader("X-Content-Type-Options"), "nosniff")

    def test_the_root_leads_to_the_page(self):
        res = self.get("/")
        self.assertIn(res.status, (301, 302, 303, 307, 308))
        self.assertEqual(res.getheader("Location"), "/www/")

    def test_nothing_else_is_served(self):
        for path in FORBIDDEN:
            with self.subTest(path=path):
                res = self.get(path)
                self.assertEqual(res.status, 404)
                # Error answers carry the policy too.
                self.assertIn("default-src 'none'", res.getheader("Content-Security-Policy", ""))

    def test_only_the_loopback_address_listens(self):
        # Bound to 0.0.0.0 it would also answer on 127.0.0.2 (Linux routes all of
        # 127/8 to the loopback interface); bound to 127.0.0.1 it refuses.
        with self.assertRaises(OSError):
            socket.create_connection(("127.0.0.2", self.port), timeout=2).close()


if __name__ == "__main__":
    unittest.main()
