#!/usr/bin/env python3
"""ctest view.access: who gets into the live view (docs/reliability.md, "Threat model: the live view").

Starts the real server (`modal-rt view --port 0` on the lattice fixture), reads the address with the
token from what it prints, and sends it, over loopback, what a DNS-rebinding page, a cross-origin page
and a client without the token would send:
  - a page or API request with Host: attacker.example:PORT is refused (403), even with the token;
  - a WebSocket upgrade on /ws with Origin: http://attacker.example is refused (403, no 101);
  - GET /api/basis and /api/report without the token are refused (401), with a wrong one too (403);
    with the token (query or X-Modal-RT-Token header) /api/basis is served whole;
  - a same-origin WebSocket upgrade with the token is accepted (101), without it refused;
  - the page carries a Content-Security-Policy with script-src 'self' and X-Content-Type-Options:
    nosniff, has no inline script, and its load with the token sets a SameSite=Strict, HttpOnly cookie;
  - the token is 64 hex digits, new each run.
Usage: test_view_access.py MODAL_RT FIXTURE_MAKER WORK_DIR
"""
import base64
import os
import re
import socket
import subprocess
import sys

failures = 0


def check(ok, what):
    global failures
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures += 1


def start_view(modal_rt, basis):
    """Starts `modal-rt view`; returns the process and the address with the token it printed."""
    server = subprocess.Popen([modal_rt, "view", "--basis", basis, "--port", "0", "--duration", "60"],
                              stdout=subprocess.PIPE, text=True)
    line = server.stdout.readline()
    match = re.search(r"http://127\.0\.0\.1:(\d+)/\?token=([0-9a-f]+)", line)
    if not match:
        server.kill()
        sys.exit(f"modal-rt view printed no address with a token: {line!r}")
    return server, int(match.group(1)), match.group(2)


def request(port, target, headers):
    """One raw HTTP/1.1 request over loopback; returns (status, headers as a lower-case dict, body)."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        headers = {"Connection": "close", **headers}
        lines = [f"GET {target} HTTP/1.1"] + [f"{k}: {v}" for k, v in headers.items()] + ["", ""]
        s.sendall("\r\n".join(lines).encode())
        data = b""
        while b"\r\n\r\n" not in data:
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
        head, _, body = data.partition(b"\r\n\r\n")
        head_lines = head.decode("latin-1").split("\r\n")
        fields = {}
        for field in head_lines[1:]:
            name, _, value = field.partition(":")
            fields[name.strip().lower()] = value.strip()
        length = int(fields.get("content-length", 0))  # an accepted WebSocket has none and stays open
        while len(body) < length:
            chunk = s.recv(65536)
            if not chunk:
                break
            body += chunk
    return int(head_lines[0].split()[1]), fields, body


def upgrade_headers(host, origin):
    headers = {"Host": host, "Upgrade": "websocket", "Connection": "Upgrade", "Sec-WebSocket-Version": "13",
               "Sec-WebSocket-Key": base64.b64encode(os.urandom(16)).decode()}
    if origin:
        headers["Origin"] = origin
    return headers


def main():
    modal_rt, maker, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    basis = os.path.join(work, "view_access_lattice.mrt")
    subprocess.run([maker, "lattice", basis], check=True, stdout=subprocess.DEVNULL)
    with open(os.path.join(work, "report.json"), "w") as report:
        report.write('{"spaces": []}')
    server, port, token = start_view(modal_rt, basis)
    try:
        run_checks(port, token)
    finally:
        server.terminate()
        server.wait(timeout=20)
    second, _, other_token = start_view(modal_rt, basis)
    second.terminate()
    second.wait(timeout=20)
    check(len(token) == 64 and other_token != token, f"the token is 64 hex digits and new each run")
    print(f"{failures} check(s) failed" if failures else "all checks passed")
    sys.exit(1 if failures else 0)


def run_checks(port, token):
    own = f"127.0.0.1:{port}"
    attacker = f"attacker.example:{port}"
    with_token = f"?token={token}"

    status, _, body = request(port, "/", {"Host": attacker})
    check(status == 403 and b"Host" in body, f"the page with Host: {attacker}: {status} {body.strip()!r}")
    status, _, _ = request(port, "/api/basis" + with_token, {"Host": attacker})
    check(status == 403, f"/api/basis with the token and Host: {attacker}: {status}")
    status, _, _ = request(port, "/api/report" + with_token, {"Host": attacker})
    check(status == 403, f"/api/report with the token and Host: {attacker}: {status}")

    status, _, _ = request(port, "/ws" + with_token, upgrade_headers(own, "http://attacker.example"))
    check(status == 403, f"a WebSocket upgrade with the token and Origin: http://attacker.example: {status}")
    status, _, _ = request(port, "/ws" + with_token, upgrade_headers(attacker, f"http://{attacker}"))
    check(status == 403, f"a WebSocket upgrade from a DNS-rebinding page (Host and Origin {attacker}): {status}")
    status, _, _ = request(port, "/ws", upgrade_headers(own, f"http://{own}"))
    check(status == 401, f"a same-origin WebSocket upgrade without the token: {status}")
    status, fields, _ = request(port, "/ws" + with_token, upgrade_headers(own, f"http://{own}"))
    check(status == 101 and fields.get("upgrade", "").lower() == "websocket",
          f"a same-origin WebSocket upgrade with the token: {status}")

    for route in ("/api/basis", "/api/report", "/api/info", "/api/state"):
        status, _, _ = request(port, route, {"Host": own})
        check(status == 401, f"{route} without the token: {status}")
    status, _, _ = request(port, "/api/basis?token=" + "0" * 64, {"Host": own})
    check(status == 403, f"/api/basis with a wrong token: {status}")
    status, _, _ = request(port, "/api/basis?token=" + token[:-1], {"Host": own})
    check(status == 403, f"/api/basis with the token less its last digit: {status}")
    status, _, _ = request(port, "/api/basis" + with_token, {"Host": own, "Origin": "http://127.0.0.1:1"})
    check(status == 403, f"/api/basis with the token from another origin (port 1): {status}")
    status, _, _ = request(port, "/api/basis" + with_token, {"Host": own, "Sec-Fetch-Site": "same-site"})
    check(status == 403, f"/api/basis with the token, Sec-Fetch-Site: same-site: {status}")

    status, fields, body = request(port, "/api/basis" + with_token, {"Host": own})
    check(status == 200 and len(body) == int(fields.get("content-length", -1)) and body[:8] == b"MRTVIEW1",
          f"/api/basis with the token in the query: {status}, {len(body)} bytes")
    status, _, body = request(port, "/api/basis", {"Host": f"localhost:{port}", "X-Modal-RT-Token": token,
                                                   "Origin": f"http://localhost:{port}"})
    check(status == 200 and body[:8] == b"MRTVIEW1", f"/api/basis same-origin (localhost) with the token header: {status}")

    status, fields, body = request(port, "/" + with_token, {"Host": own})
    csp = fields.get("content-security-policy", "")
    cookie = fields.get("set-cookie", "")
    check(status == 200 and "script-src 'self'" in csp and "unsafe-inline" not in csp.split("script-src")[1].split(";")[0],
          f"the page's Content-Security-Policy: {csp}")
    check(fields.get("x-content-type-options") == "nosniff", "the page is sent with X-Content-Type-Options: nosniff")
    check(re.search(rb"<script(?![^>]*\bsrc=)[^>]*>", body) is None, "the page has no inline script")
    check(f"={token}" in cookie and "SameSite=Strict" in cookie and "HttpOnly" in cookie,
          f"the page's load with the token sets the cookie: {cookie.replace(token, 'TOKEN')}")
    name = cookie.split("=")[0]
    status, _, _ = request(port, "/api/info", {"Host": own, "Cookie": f"{name}={token}", "Sec-Fetch-Site": "same-origin"})
    check(status == 200, f"/api/info with the cookie from the page itself (Sec-Fetch-Site: same-origin): {status}")
    status, _, _ = request(port, "/api/info", {"Host": own, "Cookie": f"{name}={token}"})
    check(status == 401, f"/api/info with the cookie but no sign of the page's origin: {status}")
    status, fields, _ = request(port, "/view.js", {"Host": own})
    check(status == 200 and fields.get("x-content-type-options") == "nosniff", f"/view.js: {status}, nosniff")


if __name__ == "__main__":
    main()
