#!/usr/bin/env python3
"""Attacks a running `panelbass serve` as issue #57 describes, from loopback only, each bounded in time and size,
and prints one line per attack: the request and the answer. Used for the before/after table in docs/server.md.

    python3 bench/security/attack.py http://127.0.0.1:PORT [--pid PID] [--heavy]

--pid reads the server's resident size before and after the body attacks; --heavy adds the deep-nesting
attack of 50 000 levels (it killed the server before the fix)."""
import argparse, json, os, socket, struct, sys, time, urllib.parse

def rss_mib(pid):
    if not pid:
        return None
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return None

class Conn:
    def __init__(self, host, port, timeout=10):
        self.s = socket.create_connection((host, port), timeout=timeout)
    def send(self, data):
        self.s.sendall(data)
    def response(self):
        data = b""
        try:
            while True:
                chunk = self.s.recv(65536)
                if not chunk:
                    break
                data += chunk
                head, sep, body = data.partition(b"\r\n\r\n")
                if sep:
                    length = None
                    for line in head.split(b"\r\n")[1:]:
                        k, _, v = line.partition(b":")
                        if k.strip().lower() == b"content-length":
                            length = int(v.strip())
                    if length is not None and len(body) >= length:
                        break
        except (socket.timeout, ConnectionResetError, BrokenPipeError):
            pass
        self.s.close()
        if not data:
            return None, ""
        head, _, body = data.partition(b"\r\n\r\n")
        status = int(head.split(b" ")[1])
        return status, body.decode("utf-8", "replace")

def request(addr, method, path, body=b"", headers=None, timeout=10):
    host, port = addr
    h = {"Host": f"{host}:{port}", "Connection": "close"}
    h.update(headers or {})
    if body and "Transfer-Encoding" not in h:
        h["Content-Length"] = str(len(body))
    raw = f"{method} {path} HTTP/1.1\r\n".encode() + b"".join(f"{k}: {v}\r\n".encode() for k, v in h.items()) + b"\r\n"
    try:
        c = Conn(host, port, timeout)
        c.send(raw + body)
        return c.response()
    except OSError as e:
        return None, f"transport error: {e}"

def short(text, n=150):
    text = text.replace("\n", " ")
    return text if len(text) <= n else text[:n] + "…"

def show(name, what, result):
    status, body = result
    print(f"{name:<16} {what:<70} -> {status} {short(body)}", flush=True)

def wav_bytes(frames_claimed, frames_present, channels=2, fs=3000):
    data = struct.pack("<" + "h" * (frames_present * channels), *([1000] * frames_present * channels))
    fmt = struct.pack("<HHIIHH", 1, channels, fs, fs * 2 * channels, 2 * channels, 16)
    data_size = frames_claimed * 2 * channels
    return (b"RIFF" + struct.pack("<I", 4 + 8 + len(fmt) + 8 + data_size) + b"WAVE" + b"fmt " + struct.pack("<I", len(fmt)) +
            fmt + b"data" + struct.pack("<I", data_size) + data)

def main():
    p = argparse.ArgumentParser()
    p.add_argument("address")
    p.add_argument("--pid", type=int, default=0)
    p.add_argument("--heavy", action="store_true")
    a = p.parse_args()
    u = urllib.parse.urlparse(a.address)
    addr = (u.hostname, u.port)
    evil = {"Origin": "http://evil.example", "Content-Type": "text/plain"}

    # A model to activate and upload: a small linear identification on the virtual transducer.
    s, b = request(addr, "POST", "/api/jobs", json.dumps({"kind": "identify-linear", "params": {"excite": {"samples": 3000}, "order": 4}}).encode(),
                   {"Content-Type": "application/json"})
    job = json.loads(b)["id"]
    for _ in range(300):
        s, b = request(addr, "GET", f"/api/jobs/{job}")
        if json.loads(b).get("state") in ("succeeded", "failed"):
            break
        time.sleep(0.2)
    model_id = json.loads(b)["result"]["model_id"]
    model = json.loads(request(addr, "GET", f"/api/models/{model_id}")[1])["model"]
    model_text = json.dumps(model).encode()

    print("== cross-origin (CSRF)")
    show("csrf", "POST /api/models text/plain, Origin evil", request(addr, "POST", "/api/models?name=csrf", model_text, evil))
    show("csrf", f"POST /api/models/{model_id}/activate, Origin evil", request(addr, "POST", f"/api/models/{model_id}/activate", b"", {"Origin": "http://evil.example"}))
    show("csrf", "POST /api/jobs excite text/plain, Origin evil",
         request(addr, "POST", "/api/jobs", json.dumps({"kind": "excite", "params": {"samples": 1000}}).encode(), evil))
    show("csrf", "POST /api/records WAV, Origin evil", request(addr, "POST", "/api/records?input=0&output=1", wav_bytes(1000, 1000), {"Origin": "http://evil.example", "Content-Type": "audio/wav"}))
    show("csrf", "POST /api/jobs text/plain, Sec-Fetch-Site: cross-site",
         request(addr, "POST", "/api/jobs", json.dumps({"kind": "excite", "params": {"samples": 1000}}).encode(), {"Sec-Fetch-Site": "cross-site", "Content-Type": "text/plain"}))
    show("csrf", "POST /api/jobs text/plain, no Origin (curl)",
         request(addr, "POST", "/api/jobs", json.dumps({"kind": "excite", "params": {"samples": 1000}}).encode(), {"Content-Type": "text/plain"}))
    show("csrf", "OPTIONS /api/jobs, Origin evil (preflight)", request(addr, "OPTIONS", "/api/jobs", b"", {"Origin": "http://evil.example", "Access-Control-Request-Method": "POST"}))
    show("csrf", "OPTIONS /api/jobs, no Origin", request(addr, "OPTIONS", "/api/jobs"))

    print("== DNS rebinding (Host)")
    host_evil = {"Host": f"evil.example:{addr[1]}"}
    show("host", "GET /api/config, Host evil.example", request(addr, "GET", "/api/config", b"", host_evil))
    show("host", "PATCH /api/config, Host evil.example", request(addr, "PATCH", "/api/config", b'{"band_pass":{"low_hz":31}}', {**host_evil, "Content-Type": "application/json"}))
    show("host", "DELETE /api/records/r0, Host evil.example", request(addr, "DELETE", "/api/records/r0", b"", host_evil))
    show("host", "GET / (the UI), Host evil.example", request(addr, "GET", "/", b"", host_evil))

    print("== bodies")
    before = rss_mib(a.pid)
    total = 64 << 20
    try:
        c = Conn(*addr, timeout=30)
        c.send(f"POST /api/records?fs=3000 HTTP/1.1\r\nHost: {addr[0]}:{addr[1]}\r\nTransfer-Encoding: chunked\r\nContent-Type: text/csv\r\nConnection: close\r\n\r\n".encode())
        piece = b"u,y\n" + b"0.1,0.2\n" * 8191
        sent = 0
        t0 = time.time()
        try:
            while sent < total:
                c.send(b"%x\r\n" % len(piece) + piece + b"\r\n")
                sent += len(piece)
            c.send(b"0\r\n\r\n")
        except OSError:
            pass
        st = c.response()
        show("chunked", f"POST /api/records chunked, {sent >> 20} MiB sent of 64 ({time.time() - t0:.1f} s)", st)
    except OSError as e:
        print("chunked: transport error", e)
    print(f"{'':<16} server RSS {before} -> {rss_mib(a.pid)} MiB")
    show("length", "POST /api/records Content-Length: 1 GiB (no body sent)",
         request(addr, "POST", "/api/records", b"", {"Content-Length": str(1 << 30), "Content-Type": "text/csv"}, timeout=5))
    deep_meta = json.dumps({k: v for k, v in model.items() if k != "meta"}).encode()[:-1] + b',"meta":' + b'{"a":' * 2000 + b'1' + b'}' * 2001
    show("nesting", "POST /api/models, meta nested 2000 levels", request(addr, "POST", "/api/models", deep_meta, {"Content-Type": "application/json"}))
    show("nesting", "POST /api/jobs, params nested 100 levels", request(addr, "POST", "/api/jobs", (b'{"kind":"excite","params":' + b'{"a":' * 100 + b'1' + b'}' * 101), {"Content-Type": "application/json"}))
    show("meta", "POST /api/models, meta of 4 MiB", request(addr, "POST", "/api/models", json.dumps(dict(model, meta={"note": "x" * (4 << 20)})).encode(), {"Content-Type": "application/json"}, timeout=30))

    print("== slow clients")
    held = []
    for _ in range(40):
        try:
            c = socket.create_connection(addr, timeout=5)
            c.sendall(f"GET /api/health HTTP/1.1\r\nHost: {addr[0]}".encode())  # part of a head, never ended
            held.append(c)
        except OSError:
            break
    time.sleep(0.5)
    t0 = time.time()
    st = request(addr, "GET", "/api/health", timeout=3)
    show("slowloris", f"GET /api/health beside {len(held)} half-sent heads (answered in {time.time() - t0:.2f} s)", st)
    for c in held:
        c.close()
    streams = []
    for _ in range(20):
        try:
            c = socket.create_connection(addr, timeout=5)
            c.sendall(f"GET /api/jobs/{job}x/events HTTP/1.1\r\nHost: {addr[0]}:{addr[1]}\r\n\r\n".encode())
            streams.append(c)
        except OSError:
            break
    time.sleep(0.3)
    t0 = time.time()
    st = request(addr, "GET", "/api/health", timeout=3)
    show("slowloris", f"GET /api/health beside 20 idle connections (answered in {time.time() - t0:.2f} s)", st)
    for c in streams:
        c.close()

    print("== safety limits")
    show("limits", 'PATCH /api/config {"limiter":{"pinned_level":1e308}}', request(addr, "PATCH", "/api/config", b'{"limiter":{"pinned_level":1e308}}', {"Content-Type": "application/json"}))
    show("limits", 'PATCH /api/config {"limiter":{"max_pinned_ms":60000}}', request(addr, "PATCH", "/api/config", b'{"limiter":{"max_pinned_ms":60000}}', {"Content-Type": "application/json"}))

    print("== bounds")
    ids, last = [], None
    for k in range(200):
        s, b = request(addr, "POST", "/api/jobs", json.dumps({"kind": "excite", "params": {"samples": 1000}}).encode(), {"Content-Type": "application/json"})
        last = (s, b)
        if s != 202:
            break
        ids.append(json.loads(b)["id"])
    show("queue", f"200 x POST /api/jobs at once: {len(ids)} accepted, then", last)
    for i in ids:
        request(addr, "DELETE", f"/api/jobs/{i}")
    s, b = request(addr, "GET", "/api/jobs?limit=2")
    show("paging", "GET /api/jobs?limit=2", (s, f"{len(json.loads(b).get('jobs', []))} jobs, total {json.loads(b).get('total')}"))
    s, b = request(addr, "GET", "/api/status")
    show("status", "GET /api/status .store", (s, json.dumps(json.loads(b).get("store"))))

    print("== bad input")
    show("wav", "POST /api/records WAV: header 1000 frames, 497 present", request(addr, "POST", "/api/records?name=short&input=0&output=1", wav_bytes(1000, 497), {"Content-Type": "audio/wav"}))
    broken = bytearray(wav_bytes(1000, 1000))
    broken[40:44] = struct.pack("<I", 0xFFFFFFFE)
    show("wav", "POST /api/records WAV: data size 0xFFFFFFFE", request(addr, "POST", "/api/records?name=huge&input=0&output=1", bytes(broken), {"Content-Type": "audio/wav"}))
    show("duplicate", 'POST /api/jobs {"kind":"teleport","kind":"excite",…}', request(addr, "POST", "/api/jobs", b'{"kind":"teleport","kind":"excite","params":{"samples":1000}}', {"Content-Type": "application/json"}))
    show("utf8", "POST /api/models?name=%FF%FE (a valid model)", request(addr, "POST", "/api/models?name=%FF%FE", model_text, {"Content-Type": "application/json"}))
    show("health", "GET /api/health after all", request(addr, "GET", "/api/health"))
    print(f"{'':<16} server RSS at the end {rss_mib(a.pid)} MiB")
    if a.heavy:
        show("nesting", "POST /api/models, 50 000 x {\"a\": (300 KB)", request(addr, "POST", "/api/models", b'{"a":' * 50000, {"Content-Type": "application/json"}, timeout=60))
        show("health", "GET /api/health after it", request(addr, "GET", "/api/health"))

main()
