#!/usr/bin/env python3
"""Soak: `panelbass serve` with the full chain (band-pass, LQ feedforward, neural feedback) on the
virtual transducer for a set time, while a bounded loopback client issues mixed API traffic — status
polls, config changes, uploads, activations, small jobs, and bad requests (which must be refused with a
4xx, never a 5xx). Reports xruns, faults, per-buffer time (p50/p99/max), request latencies, failed valid
requests and memory (RSS at start, every minute, and at the end).

    python3 bench/soak.py [--minutes 10] [--rate 50] [--seed 1] [--bin build/bin/panelbass] [--no-uploads]
                          [--realtime-priority N]   (SCHED_FIFO for the audio thread; the report says if granted)

Exits 1 if a valid request failed, a bad request got anything but a 4xx, an xrun happened, or the drive
left [-1, 1].
"""
import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request


def start_server(binary, store, seed, realtime_priority=0):
    proc = subprocess.Popen(
        [binary, "serve", "--port", "0", "--no-demo", "--store", store, "--web", "", "--seed", str(seed),
         "--realtime-priority", str(realtime_priority)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    line = proc.stdout.readline()
    if "serving http://" not in line:
        proc.kill()
        raise RuntimeError("server did not start: " + line)
    return proc, line.split("serving ")[1].split(" ")[0].rstrip("/")


def call(address, method, path, body=None, raw=None, timeout=60):
    data = raw if raw is not None else (json.dumps(body).encode() if body is not None else None)
    req = urllib.request.Request(address + path, data=data, method=method,
                                 headers={"Content-Type": "application/json"})
    t0 = time.perf_counter()
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            payload = r.read()
            status = r.status
    except urllib.error.HTTPError as e:
        payload = e.read()
        status = e.code
    ms = (time.perf_counter() - t0) * 1e3
    try:
        parsed = json.loads(payload) if payload else None
    except ValueError:
        parsed = None
    return status, parsed, ms


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def wait_job(address, job_id, timeout=600):
    until = time.time() + timeout
    while time.time() < until:
        status, job, _ = call(address, "GET", f"/api/jobs/{job_id}")
        if status == 200 and job["state"] in ("succeeded", "failed", "cancelled"):
            return job
        time.sleep(0.2)
    raise RuntimeError(f"job {job_id} did not end")


def numbered_model(k):
    return {"format": "panelbass.model/1", "kind": "linear", "fs": 3000.0, "method": "oe",
            "meta": {"soak": k}, "params": {"a": [-1.7196, 0.81], "b": [0.05 + 1e-6 * k, 0.02], "nk": 1},
            "scaling": {"u_offset": 0.0, "u_scale": 1.0, "y_offset": 0.0, "y_scale": 1.0}}


def percentile(values, p):
    if not values:
        return None
    v = sorted(values)
    return v[min(len(v) - 1, int(p * len(v)))]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--rate", type=float, default=50.0, help="requests per second (bounded client)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--bin", default="build/bin/panelbass")
    parser.add_argument("--realtime-priority", type=int, default=0,
                        help="SCHED_FIFO priority of the engine's audio thread (0: normal scheduling)")
    parser.add_argument("--no-uploads", action="store_true",
                        help="no new models during the soak (memory then has no stored data to grow with)")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    store = tempfile.mkdtemp(prefix="panelbass-soak-")
    proc, address = start_server(args.bin, store, args.seed, args.realtime_priority)
    report = {"minutes": args.minutes, "rate_target": args.rate}
    try:
        # The full chain: a linear model and its LQ feedforward, a NARX model and the neural feedback on it.
        print("soak: building the chain (identify, design LQ, identify NARX, design NN)", file=sys.stderr)
        setup = []
        for kind, params in (("identify-linear", {"excite": {"samples": 6000, "seed": args.seed}, "order": 8}),):
            _, r, _ = call(address, "POST", "/api/jobs", {"kind": kind, "params": params})
            setup.append(wait_job(address, r["id"]))
        linear = setup[0]["result"]["model_id"]
        _, r, _ = call(address, "POST", "/api/jobs", {"kind": "design-lq", "params": {"plant_model": linear}, "activate": True})
        lq = wait_job(address, r["id"])["result"]["model_id"]
        _, r, _ = call(address, "POST", "/api/jobs", {"kind": "identify-narx", "params": {
            "excite": {"samples": 6000, "seed": args.seed + 1}, "hidden": [6], "max_iterations": 20}})
        narx = wait_job(address, r["id"])["result"]["model_id"]
        _, r, _ = call(address, "POST", "/api/jobs", {"kind": "design-nn", "params": {
            "plant_model": narx, "feedforward_model": lq, "samples": 2000, "max_iterations": 5}, "activate": True})
        nn_job = wait_job(address, r["id"])
        if nn_job["state"] != "succeeded":
            raise RuntimeError("design-nn failed: " + str(nn_job.get("error")))
        _, status, _ = call(address, "GET", "/api/status")
        report["chain"] = status["active_models"]
        print(f"soak: chain {status['active_models']}; soaking {args.minutes} min at {args.rate} req/s",
              file=sys.stderr)

        _, start_status, _ = call(address, "GET", "/api/status")
        rss = [(0.0, rss_kib(proc.pid))]
        latencies, failed_valid, bad_not_4xx, counts = [], [], [], {}
        uploads = 0
        t_start = time.time()
        t_end = t_start + 60.0 * args.minutes
        next_rss = t_start + 60.0
        k = 0
        while time.time() < t_end:
            k += 1
            pick = rng.random()
            bad = False
            if pick < 0.45:
                kind, (status, _, ms) = "status", call(address, "GET", "/api/status")
            elif pick < 0.55:
                kind, (status, _, ms) = "models", call(address, "GET", "/api/models")
            elif pick < 0.62:
                kind, (status, _, ms) = "metrics", call(address, "GET", "/metrics")
            elif pick < 0.70 and args.no_uploads:
                kind, (status, _, ms) = "status", call(address, "GET", "/api/status")
            elif pick < 0.70:
                uploads += 1
                kind, (status, _, ms) = "upload", call(address, "POST", "/api/models", numbered_model(uploads))
            elif pick < 0.76:
                kind, (status, _, ms) = "activate", call(address, "POST", f"/api/models/{lq}/activate", {})
            elif pick < 0.82:
                low = rng.choice([20, 25, 30])
                kind, (status, _, ms) = "config", call(address, "PATCH", "/api/config", {"band_pass": {"low_hz": low}})
            elif pick < 0.84:
                kind, (status, _, ms) = "job", call(address, "POST", "/api/jobs", {
                    "kind": "excite", "params": {"samples": 1000, "validation_samples": 500, "seed": k}})
            else:
                bad = True
                kind, (status, _, ms) = "bad", rng.choice([
                    lambda: call(address, "POST", "/api/models", raw=b"{\"kind\":"),
                    lambda: call(address, "PATCH", "/api/config", {"band_pass": {"high_hz": 9000}}),
                    lambda: call(address, "GET", "/api/models/..%2F..%2Fetc"),
                    lambda: call(address, "POST", "/api/jobs", {"kind": "teleport"}),
                    lambda: call(address, "DELETE", "/api/jobs/j999999"),
                ])()
            counts[kind] = counts.get(kind, 0) + 1
            latencies.append(ms)
            if bad and not (400 <= status < 500):
                bad_not_4xx.append(status)
            if not bad and status >= 300 and not (kind == "upload" and status == 200):
                failed_valid.append((kind, status))
            if time.time() >= next_rss:
                rss.append((round(time.time() - t_start, 1), rss_kib(proc.pid)))
                next_rss += 60.0
            time.sleep(max(0.0, 1.0 / args.rate - ms / 1e3))
        rss.append((round(time.time() - t_start, 1), rss_kib(proc.pid)))
        _, end_status, _ = call(address, "GET", "/api/status")
        m0, m1 = start_status["metrics"], end_status["metrics"]
        report.update({
            "requests": len(latencies), "by_kind": counts,
            "failed_valid_requests": len(failed_valid), "failed_examples": failed_valid[:5],
            "bad_requests_not_4xx": len(bad_not_4xx),
            "latency_ms": {"p50": percentile(latencies, 0.5), "p99": percentile(latencies, 0.99),
                           "max": max(latencies)},
            "engine": {"blocks": m1["blocks"] - m0["blocks"], "xruns": m1["xruns"] - m0["xruns"],
                       "faults": m1["faults"] - m0["faults"], "last_fault": m1["last_fault"],
                       "peak_drive": m1["peak_drive"], "p50_block_ns": m1["p50_block_ns"],
                       "p99_block_ns": m1["p99_block_ns"], "max_block_ns": m1["max_block_ns"],
                       "max_late_ns": m1["max_late_ns"], "realtime": end_status["engine"]["realtime"],
                       "load": m1["load"]},
            "rss_kib": rss, "rss_growth_kib": rss[-1][1] - rss[0][1],
        })
    finally:
        proc.terminate()
        proc.wait(timeout=60)
        shutil.rmtree(store, ignore_errors=True)
    print(json.dumps(report, indent=2))
    ok = (report.get("failed_valid_requests", 1) == 0 and report.get("bad_requests_not_4xx", 1) == 0
          and report["engine"]["xruns"] == 0 and report["engine"]["peak_drive"] <= 1.0)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
