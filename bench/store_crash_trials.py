#!/usr/bin/env python3
"""kill -9 `panelbass serve` at random moments while models and job records are being written, restart
it on the same store, and check that nothing is torn or lost.

Each trial: start the server (no demo) on the store; clients upload new models and submit small
excitation jobs as fast as they can; after a random 50-600 ms the server gets SIGKILL; it is started
again on the same store and must come up; then every file in the store must be a whole JSON document
of the right format (old or new, never a mix), the server must have skipped none of them, and every
model whose upload was acknowledged (2xx) before the kill must be listed.

    python3 bench/store_crash_trials.py [--trials 100] [--seed 1] [--bin build/bin/panelbass]

Prints a JSON summary; exits 1 if any trial found a torn file, a lost model or a failed restart.
"""
import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request


def numbered_model(k):
    """A stable second-order linear model file whose numerator depends on k (a new id per k)."""
    # Poles at 0.9·e^{±j0.3}: a = [-2·0.9·cos 0.3, 0.81].
    return {
        "format": "panelbass.model/1",
        "kind": "linear",
        "fs": 3000.0,
        "method": "oe",
        "meta": {"trial_model": k},
        "params": {"a": [-1.7196, 0.81], "b": [0.05 + 1e-6 * k, 0.02], "nk": 1},
        "scaling": {"u_offset": 0.0, "u_scale": 1.0, "y_offset": 0.0, "y_scale": 1.0},
    }


def start_server(binary, store):
    proc = subprocess.Popen(
        [binary, "serve", "--port", "0", "--no-demo", "--store", store, "--web", ""],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    if "serving http://" not in line:
        proc.kill()
        err = proc.stderr.read()
        raise RuntimeError("server did not start: " + line + err)
    address = line.split("serving ")[1].split(" ")[0].rstrip("/")
    stderr_lines = []
    threading.Thread(target=lambda: stderr_lines.extend(proc.stderr), daemon=True).start()
    return proc, address, stderr_lines


def request(address, method, path, body=None, timeout=5):
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(address + path, data=data, method=method,
                                 headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, json.loads(r.read() or b"null")
    except urllib.error.HTTPError as e:
        return e.code, None


def check_store(store):
    """Every file parses and carries its format tag: returns the list of problems."""
    problems = []
    for folder, tag in (("models", "panelbass.stored-model/1"), ("jobs", "panelbass.job/1")):
        path = os.path.join(store, folder)
        if not os.path.isdir(path):
            continue
        for name in os.listdir(path):
            if not name.endswith(".json") or name.startswith("."):
                continue  # temporary files are the server's to clean
            try:
                with open(os.path.join(path, name)) as f:
                    doc = json.load(f)
                if doc.get("format") != tag:
                    problems.append(f"{folder}/{name}: format {doc.get('format')!r}")
            except (ValueError, OSError) as e:
                problems.append(f"{folder}/{name}: {e}")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--bin", default="build/bin/panelbass")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    store = tempfile.mkdtemp(prefix="panelbass-crash-")
    counter = [0]
    summary = {"trials": 0, "torn_files": 0, "lost_models": 0, "failed_restarts": 0, "skipped_at_start": 0,
               "acknowledged_uploads": 0, "jobs_submitted": 0, "problems": []}
    acknowledged = set()
    try:
        for trial in range(args.trials):
            proc, address, _ = start_server(args.bin, store)
            stop = threading.Event()

            def client(kind):
                while not stop.is_set():
                    try:
                        if kind == "upload":
                            counter[0] += 1
                            status, body = request(address, "POST", "/api/models", numbered_model(counter[0]))
                            if status in (200, 201):
                                acknowledged.add(body["id"])
                                summary["acknowledged_uploads"] += 1
                        else:
                            status, _ = request(address, "POST", "/api/jobs",
                                                {"kind": "excite", "params": {"samples": 500, "validation_samples": 200}})
                            if status == 202:
                                summary["jobs_submitted"] += 1
                    except (OSError, ValueError):
                        return  # the server is gone

            threads = [threading.Thread(target=client, args=(k,)) for k in ("upload", "upload", "job")]
            for t in threads:
                t.start()
            time.sleep(rng.uniform(0.05, 0.6))
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            stop.set()
            for t in threads:
                t.join()
            summary["trials"] += 1

            problems = check_store(store)
            summary["torn_files"] += len(problems)
            summary["problems"] += [f"trial {trial}: {p}" for p in problems][:5]
            try:
                proc, address, stderr_lines = start_server(args.bin, store)
            except RuntimeError as e:
                summary["failed_restarts"] += 1
                summary["problems"].append(f"trial {trial}: {e}")
                continue
            status, listing = request(address, "GET", "/api/models")
            listed = {m["id"] for m in listing["models"]} if status == 200 else set()
            lost = acknowledged - listed
            summary["lost_models"] += len(lost)
            if lost:
                summary["problems"].append(f"trial {trial}: lost {sorted(lost)[:3]}")
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=30)
            time.sleep(0.1)
            summary["skipped_at_start"] += sum(1 for l in stderr_lines if "skipped" in l)
            print(f"trial {trial + 1}/{args.trials}: {len(acknowledged)} models acknowledged, "
                  f"{summary['torn_files']} torn, {summary['lost_models']} lost", file=sys.stderr)
    finally:
        shutil.rmtree(store, ignore_errors=True)
    print(json.dumps(summary, indent=2))
    bad = summary["torn_files"] + summary["lost_models"] + summary["failed_restarts"] + summary["skipped_at_start"]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
