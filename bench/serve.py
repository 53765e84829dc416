"""robocal serve over loopback: latency of sequential requests, of 4 clients at once, and a
load and fault run (50,000 requests, 10 % malformed, clients that vanish mid-line or send
slowly), every well-formed answer checked against the first answer to the same request.

    python bench/serve.py MODEL.json TARGETS.csv            # --quick: 10x fewer requests
    python bench/serve.py MODEL.json --poses MEASUREMENTS.csv

TARGETS.csv is a targets file (x, y, z, rx, ry, rz[, q1..qN]); with --poses, the targets are
the model's own FK of the first 200 joint readings of a measurement file (held-out poses,
say), each with its reading as posture hint.  Its reachable targets are asked in turn.  The
server runs as its own process (python -m robocal serve --port 0) on 127.0.0.1.  For example:

    robocal dataset ur5-tsinghua --out ur5 --split 0.5
    robocal calibrate ur5.toml ur5_train.csv --method kinematic --out ur5_kin.json
    python bench/serve.py ur5_kin.json --poses ur5_test.csv

On a machine shared with other work the tail is the machine's: run it with raised priority
(nice -n -15 python bench/serve.py ..., the server inherits it; and -15 in /proc/PID/autogroup)
and quote the load average it prints beside the figures.
"""
import argparse
import csv
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np

WAIT = 30.0
# The server as the robocal script starts it (robocal.entry.main: one BLAS thread, numpy's
# floating-point warnings off); the typer app alone would leave OpenBLAS its default threads.
SERVE = [sys.executable, "-m", "robocal", "serve"]
MALFORMED = [b"", b"garbage", b'{"x": 1}', b'{"x":1e999,"y":0,"z":0,"rx":0,"ry":0,"rz":0}',
             b'{"x":1e12,"y":0,"z":0,"rx":0,"ry":0,"rz":0}', b'{"x":0,"y":0,"z":0,"rx":0,"ry":0,"rz":0,"q":[1]}',
             b"\xff\xfe", b"[" * 20000, b"z" * 70000, b'{"x":"a","y":0,"z":0,"rx":0,"ry":0,"rz":0}']


def start(model):
    process = subprocess.Popen(SERVE + [model, "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    ready, _, _ = select.select([process.stdout], [], [], 120)
    if not ready:
        process.kill()
        sys.exit("the server did not start")
    port = int(process.stdout.readline().decode().rsplit(":", 1)[1].split(",")[0])
    return process, port


def connect(port):
    sock = socket.create_connection(("127.0.0.1", port), timeout=WAIT)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock, sock.makefile("rb")


def requests_of(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    out = []
    for row in rows:
        fields = {k: float(row[k]) for k in ("x", "y", "z", "rx", "ry", "rz")}
        hints = sorted((k for k in row if k.startswith("q") and k[1:].isdigit()), key=lambda k: int(k[1:]))
        if hints and all(row[k] for k in hints):
            fields["q"] = [float(row[k]) for k in hints]
        out.append(json.dumps(fields).encode())
    return out


def requests_of_poses(model, path, count=200):
    """Requests for the model's FK of the first ``count`` joint readings of a measurement file."""
    from robocal.interfaces.jobs import load_fitted
    from robocal.io.tables import read_measurements
    from robocal.spatial import pose_to_xyz_rpy

    loaded, fitted = load_fitted(model)
    readings = read_measurements(path).joints[:count]
    xyz, rpy = pose_to_xyz_rpy(fitted.compensator_.chain.fk(loaded.kinematics.joints_from_file(readings)))
    return [json.dumps({**dict(zip(("x", "y", "z", "rx", "ry", "rz"), p.tolist() + np.degrees(r).tolist())),
                        "q": h.tolist()}).encode() for p, r, h in zip(xyz, rpy, readings)]


def percentiles(latencies):
    ms = np.percentile(np.array(latencies) * 1e3, [50, 90, 99, 100])
    # The tail is the machine's as much as the server's: other processes' share of the cores.
    return "median {:.3f} ms, p90 {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms (load average {:.2f})".format(
        *ms, os.getloadavg()[0])


def sequential(port, lines, count):
    sock, reader = connect(port)
    latencies, answers = [], {}
    with sock:
        for k in range(count):
            line = lines[k % len(lines)]
            t0 = time.perf_counter()
            sock.sendall(line + b"\n")
            answer = reader.readline()
            latencies.append(time.perf_counter() - t0)
            answers.setdefault(line, answer)
    return latencies, answers


def parallel(port, lines, clients, per_client):
    results = [None] * clients

    def run(i):
        results[i] = sequential(port, lines[i:] + lines[:i], per_client)[0]

    threads = [threading.Thread(target=run, args=(i,)) for i in range(clients)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join(600)
    wall = time.perf_counter() - t0
    return [x for r in results if r for x in r], wall


def load_and_faults(port, good, expected, total, rng):
    """``total`` requests, 10 % malformed, on 4 connections in turn, with a vanishing and a
    slow client every 1,000 requests.  Returns (wrong answers, malformed answered, count)."""
    wrong = answered_bad = 0
    connections = [connect(port) for _ in range(4)]
    for k in range(total):
        sock, reader = connections[k % 4]
        if rng.random() < 0.1:
            sock.sendall(MALFORMED[k % len(MALFORMED)] + b"\n")
            answered_bad += set(json.loads(reader.readline())) == {"error"}
        else:
            line = good[k % len(good)]
            sock.sendall(line + b"\n")
            wrong += reader.readline() != expected[line]
        if k % 1000 == 999:
            vanish, _ = connect(port)
            vanish.sendall(good[0][: len(good[0]) // 2])
            vanish.close()
            slow, slow_reader = connect(port)
            with slow:
                for byte in good[1] + b"\n":
                    slow.sendall(bytes([byte]))
                wrong += slow_reader.readline() != expected[good[1]]
    for sock, _ in connections:
        sock.close()
    return wrong, answered_bad


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model")
    parser.add_argument("targets", nargs="?")
    parser.add_argument("--poses", help="a measurement CSV whose joint readings give the targets")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    if (args.targets is None) == (args.poses is None):
        parser.error("give a targets file or --poses, not both")
    scale = 10 if args.quick else 1
    lines = requests_of(args.targets) if args.poses is None else requests_of_poses(args.model, args.poses)
    process, port = start(args.model)
    try:
        _, answers = sequential(port, lines, len(lines))
        good = [line for line in lines if b"error" not in answers[line]]
        print(f"{args.model}: {len(good)} of {len(lines)} targets reachable; {os.cpu_count()} cores, load average "
              f"{os.getloadavg()[0]:.2f}; server pid {process.pid}", flush=True)
        latencies, _ = sequential(port, good, 2000 // scale)
        print(f"sequential, {len(latencies)} requests: {percentiles(latencies)}")
        latencies, wall = parallel(port, good, 4, 500 // scale)
        print(f"4 clients at once, {len(latencies)} requests in {wall:.2f} s: {percentiles(latencies)}")
        total = 50000 // scale
        t0 = time.perf_counter()
        wrong, answered_bad = load_and_faults(port, good, answers, total, np.random.default_rng(0))
        print(f"load and faults: {total} requests ({answered_bad} malformed, each answered with an error line) "
              f"+ {total // 1000} vanishing and {total // 1000} slow clients in {time.perf_counter() - t0:.1f} s; "
              f"wrong or missing answers: {wrong}; server up: {process.poll() is None}")
    finally:
        process.send_signal(signal.SIGTERM)
        try:
            _, err = process.communicate(timeout=WAIT)
        except subprocess.TimeoutExpired:
            process.kill()
            raise
    summary = [line for line in err.decode().splitlines() if "stopped;" in line]
    print(f"server exit code {process.returncode}; {summary[-1] if summary else 'no summary'}")


if __name__ == "__main__":
    main()
