#!/usr/bin/env python3
"""A stand-in for a zoomwarp replica behind nginx, for tests/deploy/manifests_test.py's checks of
nginx.conf's retry policy: HTTP/1.1 with keep-alive, like the server, and three kinds of answer.

    GET /poison...  the process exits at once, answering nothing (a request that crashes a replica)
    GET /busy...    503 with Retry-After: 1, at once (the server's answers past a deadline or when full)
    GET anything    200 "ok"

    python3 tests/deploy/standin_upstream.py   # prints the loopback port it listens on, then serves

Listens on 127.0.0.1, on a port the kernel picks; ends on SIGTERM, on /poison, or when its parent
(the test) closes its stdin.
"""
import http.server
import os
import sys
import threading


class Handler(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def do_GET(self):
        if self.path.startswith("/poison"):
            os._exit(3)  # no answer, no clean-up: what a crash looks like to nginx
        status, body = (503, b'{"error":{"code":"deadline_exceeded"}}\n') if self.path.startswith("/busy") else (200, b"ok\n")
        self.send_response(status)
        if status == 503:
            self.send_header("Retry-After", "1")
        self.send_header("Content-Type", "application/json" if status == 503 else "text/plain")
        self.send_header("Cache-Control", "no-store")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass  # the test reads nginx's access log instead


def exit_when_stdin_closes():
    sys.stdin.read()
    os._exit(0)


def main():
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    print(server.server_address[1], flush=True)
    threading.Thread(target=exit_when_stdin_closes, daemon=True).start()
    server.serve_forever()


if __name__ == "__main__":
    main()
