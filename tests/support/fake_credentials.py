#!/usr/bin/env python3
"""Credentials that expire, for the S3 credential sources' tests (issue 42; tiles/s3_credentials.h).

Two loopback servers in one process:

  credentials  hands out the S3 fixture's own keys with a new session token each time, expiring
               LIFETIME seconds later: as STS (POST Action=AssumeRoleWithWebIdentity, the web
               identity token must be the --token-file's contents) or as the container credentials
               endpoint (GET, the Authorization header must be the --token-file's contents).
               GET /stats answers {"issued", "refused", "forwarded"}.
  s3 proxy     forwards every request to --upstream (Swift's s3api) as it came (its Host header and
               signature untouched), unless its x-amz-security-token is not one this process issued,
               or has expired: then 400 ExpiredToken, as AWS answers. With --credentials-file, the
               only token accepted is the aws_session_token the file holds now (a rotated file).

Prints one JSON line, {"credentials": PORT, "s3": PORT}, then serves until killed or until
--max-seconds have passed.
"""
import argparse
import datetime
import http.client
import http.server
import json
import re
import secrets
import sys
import threading
import time
import urllib.parse

HOP_BY_HOP = {"connection", "keep-alive", "proxy-connection", "transfer-encoding", "te", "trailer", "upgrade", "expect"}


class State:
    def __init__(self, args):
        self.args = args
        self.lock = threading.Lock()
        self.tokens = {}  # token -> expiry (time.time())
        self.issued = self.refused = self.forwarded = 0

    def issue(self):
        token = "tok-%d-%s" % (self.issued + 1, secrets.token_hex(8))
        expires = time.time() + self.args.lifetime
        with self.lock:
            self.tokens[token] = expires
            self.issued += 1
        stamp = datetime.datetime.fromtimestamp(expires, datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
        return token, stamp

    def accepts(self, token):
        if self.args.credentials_file:
            with open(self.args.credentials_file) as f:
                m = re.search(r"aws_session_token\s*=\s*(\S+)", f.read())
            return m is not None and token == m.group(1)
        with self.lock:
            expires = self.tokens.get(token)
        return expires is not None and time.time() < expires


def expected_token(args):
    with open(args.token_file) as f:
        return f.read().strip()


def credentials_handler(state):
    class Handler(http.server.BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"

        def log_message(self, *a):
            pass

        def reply(self, status, body, content_type):
            data = body.encode()
            self.send_response(status)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def do_GET(self):
            if self.path == "/stats":
                with state.lock:
                    stats = {"issued": state.issued, "refused": state.refused, "forwarded": state.forwarded}
                return self.reply(200, json.dumps(stats), "application/json")
            if state.args.mode != "container":
                return self.reply(404, "", "text/plain")
            if self.headers.get("Authorization", "") != expected_token(state.args):
                return self.reply(401, '{"message": "bad authorization token"}', "application/json")
            token, stamp = state.issue()
            body = {"AccessKeyId": state.args.key, "SecretAccessKey": state.args.secret, "Token": token, "Expiration": stamp}
            self.reply(200, json.dumps(body), "application/json")

        def do_POST(self):
            length = int(self.headers.get("Content-Length", "0"))
            form = urllib.parse.parse_qs(self.rfile.read(length).decode())
            if state.args.mode != "sts" or form.get("Action") != ["AssumeRoleWithWebIdentity"]:
                return self.reply(400, "<ErrorResponse><Error><Code>InvalidAction</Code></Error></ErrorResponse>", "text/xml")
            if form.get("WebIdentityToken") != [expected_token(state.args)]:
                return self.reply(400, "<ErrorResponse><Error><Code>InvalidIdentityToken</Code>"
                                  "<Message>not the token this test wrote</Message></Error></ErrorResponse>", "text/xml")
            token, stamp = state.issue()
            xml = ("<AssumeRoleWithWebIdentityResponse xmlns=\"https://sts.amazonaws.com/doc/2011-06-15/\">"
                   "<AssumeRoleWithWebIdentityResult><Credentials>"
                   "<AccessKeyId>%s</AccessKeyId><SecretAccessKey>%s</SecretAccessKey>"
                   "<SessionToken>%s</SessionToken><Expiration>%s</Expiration>"
                   "</Credentials></AssumeRoleWithWebIdentityResult></AssumeRoleWithWebIdentityResponse>"
                   % (state.args.key, state.args.secret, token, stamp))
            self.reply(200, xml, "text/xml")

    return Handler


def proxy_handler(state):
    upstream = urllib.parse.urlsplit(state.args.upstream)
    local = threading.local()

    class Handler(http.server.BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"

        def log_message(self, *a):
            pass

        def forward(self):
            length = int(self.headers.get("Content-Length", "0") or 0)
            body = self.rfile.read(length) if length else None
            if not state.accepts(self.headers.get("x-amz-security-token", "")):
                with state.lock:
                    state.refused += 1
                data = (b"<?xml version=\"1.0\" encoding=\"UTF-8\"?><Error><Code>ExpiredToken</Code>"
                        b"<Message>The provided token has expired.</Message></Error>")
                self.send_response(400)
                self.send_header("Content-Type", "application/xml")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                if self.command != "HEAD":
                    self.wfile.write(data)
                return
            for attempt in (1, 2):  # a kept-alive connection the upstream closed: once more, fresh
                conn = getattr(local, "conn", None) or http.client.HTTPConnection(upstream.hostname, upstream.port, timeout=30)
                local.conn = conn
                try:
                    conn.putrequest(self.command, self.path, skip_host=True, skip_accept_encoding=True)
                    for name, value in self.headers.items():
                        if name.lower() not in HOP_BY_HOP:
                            conn.putheader(name, value)
                    conn.endheaders(body)
                    resp = conn.getresponse()
                    data = resp.read()
                    break
                except (http.client.HTTPException, OSError):
                    conn.close()
                    local.conn = None
                    if attempt == 2:
                        raise
            with state.lock:
                state.forwarded += 1
            self.send_response(resp.status)
            for name, value in resp.getheaders():
                # The body is sent whole, with its own length (Swift may have sent it chunked); a
                # HEAD keeps the upstream's, the length of what a GET would send.
                if name.lower() not in HOP_BY_HOP and (name.lower() != "content-length" or self.command == "HEAD"):
                    self.send_header(name, value)
            if self.command != "HEAD":
                self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(data)

        do_GET = do_PUT = do_DELETE = do_HEAD = do_POST = forward

    return Handler


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mode", choices=["sts", "container", "file"], required=True)
    p.add_argument("--upstream", required=True, help="the S3 store the proxy forwards to (http://127.0.0.1:PORT)")
    p.add_argument("--key", required=True)
    p.add_argument("--secret", required=True)
    p.add_argument("--lifetime", type=float, default=10.0, help="seconds a token lasts")
    p.add_argument("--token-file", help="sts, container: the web identity / authorization token expected")
    p.add_argument("--credentials-file", help="file: the shared credentials file whose token alone is accepted")
    p.add_argument("--max-seconds", type=float, default=600.0)
    args = p.parse_args()
    state = State(args)
    servers = [http.server.ThreadingHTTPServer(("127.0.0.1", 0), credentials_handler(state)),
               http.server.ThreadingHTTPServer(("127.0.0.1", 0), proxy_handler(state))]
    for s in servers:
        s.daemon_threads = True
        threading.Thread(target=s.serve_forever, daemon=True).start()
    print(json.dumps({"credentials": servers[0].server_address[1], "s3": servers[1].server_address[1]}), flush=True)
    time.sleep(args.max_seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
