"""Realtime worker benchmarks, each against a baseline measured in the same run.

``python -m bench.worker_bench [--quick] [--duration S] [--max-booths N] [--json FILE]``

1. renderer tick-interval jitter (|interval - 8 ms|) p50/p99/max and missed ticks, worker
   with a 60 fps Live Link input stream vs a bare fixed-rate loop doing nothing else, run
   at the same moment in a process of its own (the machine's load is then the same);
2. added latency capture -> driver send, minus the intended delay (the head's FIR group
   delay is pre-compensated by the behaviour stage, so it is part of the intended delay),
   vs one bare pyzmq inproc hop;
3. the copy delay's error (realised delay - 4.000 s) on the head pose and the face;
4. CPU per booth (one worker process with its phone in another process);
5. how many booths (worker processes, each with a phone process) this machine carries
   while every booth's p99 tick jitter stays under 1 ms;
6. one booth with the renderer in a process of its own (``--renderer-process``), and with
   real-time scheduling too (``--realtime``; refused without the privilege, then normal),
   against the in-process booth of 5 (per-second p99 jitter from the heartbeat).
Linux only (reads /proc for per-process CPU).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import zmq

from bench.probes import AMPLITUDE, ProbeWorker, TrianglePhone, delay_errors
from bench.server_load import cpu_seconds
from chameleons.worker.envelope import Message, deserialize, serialize
from chameleons.worker.renderer import RenderLoop
from chameleons.worker.runtime import GIL_SWITCH_INTERVAL, Worker, WorkerConfig

TICK = 1 / 125
WARMUP_BEATS = 2  # heartbeats (seconds) a fresh booth runs before it is measured
NO_SERVER = "inproc://bench-no-server"  # the hub connects; nothing is bound there
Row = dict[str, Any]


def _ms(values: np.ndarray) -> dict[str, float]:
    if not len(values):
        return {"p50": float("nan"), "p99": float("nan"), "max": float("nan")}
    p50, p99 = np.percentile(values, [50, 99])
    return {"p50": p50 * 1e3, "p99": p99 * 1e3, "max": float(np.max(values)) * 1e3}


def _wait_for(condition: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError(f"benchmark: {what} did not happen within {timeout} s")
        time.sleep(0.05)


def free_udp_port() -> int:
    """A UDP port free now, for a worker's Live Link input (no fixed ports: tests run too)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _phone(port: int, duration: float, seed: int = 0) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-m", "bench.phone", "--port", str(port),
                             "--duration", str(duration), "--seed", str(seed)])  # fmt: skip


# --- 1 and 4: jitter and CPU ----------------------------------------------------------------
def bare_loop_jitter(duration: float) -> Row:
    loop = RenderLoop(125.0, lambda due, now: None)
    stop = threading.Event()
    thread = threading.Thread(target=loop.run, args=(stop,))
    thread.start()
    time.sleep(duration)
    stop.set()
    thread.join()
    jitter = np.abs(loop.stats.intervals[1 : loop.stats.count] - TICK)
    return {"jitter_ms": _ms(jitter), "missed": loop.stats.missed, "ticks": loop.stats.count}


def _bare_child(start: Any, results: Any, duration: float) -> None:
    """The bare loop in a process of its own, from the moment the worker is measured."""
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    if start.wait(300):
        results.put(bare_loop_jitter(duration))


def worker_and_bare_loop(duration: float) -> tuple[Row, Row]:
    """Item 1: the worker's jitter and the bare loop's over the same seconds."""
    context = multiprocessing.get_context("spawn")
    start, results = context.Event(), context.Queue()
    child = context.Process(target=_bare_child, args=(start, results, duration), daemon=True)
    child.start()
    try:
        worker = worker_jitter(duration, on_start=start.set)
        bare: Row = results.get(timeout=duration + 120)
    finally:
        child.join(10)
        if child.is_alive():
            child.terminate()
            child.join()
    return worker, bare


def worker_jitter(duration: float, on_start: Callable[[], None] | None = None) -> Row:
    config = WorkerConfig(booth="bench", driver="null", behaviour="copy", livelink_port=0,
                          facecapturex_port=None, capture_host="127.0.0.1",
                          command_endpoint=NO_SERVER, telemetry_endpoint=NO_SERVER)  # fmt: skip
    with Worker(config) as worker:
        phone = _phone(worker.receivers["livelink"].port, duration + 30)
        try:
            _wait_for(lambda: worker.behaviour.frames.count > 60, 30, "phone input")
            assert worker.renderer is not None  # the renderer is a thread of this process
            stats = worker.renderer.loop.stats
            if on_start is not None:
                on_start()
            first, missed0, frames0 = stats.count, stats.missed, worker.behaviour.frames.count
            cpu0, wall0 = time.process_time(), time.monotonic()
            time.sleep(duration)
            last, wall = stats.count, time.monotonic() - wall0
            cpu = (time.process_time() - cpu0) / wall
            frames = worker.behaviour.frames.count - frames0
        finally:
            phone.terminate()
            phone.wait()
    idx = np.arange(first + 1, last) % len(stats.intervals)
    return {"jitter_ms": _ms(np.abs(stats.intervals[idx] - TICK)),
            "missed": stats.missed - missed0, "ticks": last - first,
            "input_fps": frames / wall, "cpu_fraction": cpu}  # fmt: skip


# --- 2 and 3: latency and the copy delay ----------------------------------------------------
def pyzmq_hop(count: int) -> Row:
    """One inproc PUB -> SUB hop between threads with a 61-float envelope (a stage hop)."""
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    pub, sub = context.socket(zmq.PUB), context.socket(zmq.SUB)
    pub.bind("inproc://bench-hop")
    sub.setsockopt(zmq.SUBSCRIBE, b"")
    sub.connect("inproc://bench-hop")
    latencies = np.zeros(count)
    payload = np.zeros(61, dtype="<f4").tobytes()

    def receive() -> None:
        for i in range(count):
            message = deserialize(sub.recv_multipart())
            latencies[i] = time.monotonic() - message.time

    time.sleep(0.2)  # let the subscription arrive
    thread = threading.Thread(target=receive)
    thread.start()
    for i in range(count):
        pub.send_multipart(serialize(Message("f", "face", i, "b", time.monotonic(), {}, payload)))
        time.sleep(0.001)
    thread.join()
    pub.close()
    sub.close()
    context.term()
    return {"latency_ms": _ms(latencies)}


def copy_latency(duration: float, delay: float) -> Row:
    """Realised delay minus ``delay`` for every head pose and face frame sent."""
    # The head as captured (not re-centred on the participant's mean pose): its timing is
    # measured against the phone's triangle wave.
    config = WorkerConfig(booth="probe", driver="null", behaviour="copy", copy_delay=delay,
                          mirror=False, head_recentre=False, livelink_port=0,
                          facecapturex_port=None, capture_host="127.0.0.1",
                          command_endpoint=NO_SERVER,
                          telemetry_endpoint=NO_SERVER)  # fmt: skip
    worker = ProbeWorker(config)
    worker.start()
    try:
        with TrianglePhone(worker.receivers["livelink"].port, duration + delay + 1) as phone:
            _wait_for(lambda: phone.start == phone.start, 30, "the phone's first frame")
            time.sleep(duration + delay)
    finally:
        worker.stop()
    probe = worker.probe
    heads, faces = probe.heads_sent, probe.faces_sent
    head = delay_errors(probe.head_times[:heads], probe.head_yaw[:heads] / AMPLITUDE,
                        phone.start, delay)  # fmt: skip
    face = delay_errors(probe.face_times[:faces], probe.face_jaw[:faces] * 2 - 1,
                        phone.start, delay)  # fmt: skip
    return {"head_ms": _ms(head), "face_ms": _ms(face),
            "head_abs_ms": _ms(np.abs(head)), "face_abs_ms": _ms(np.abs(face)),
            "samples": len(head) + len(face)}  # fmt: skip


# --- 5: booths per machine ------------------------------------------------------------------
def booths(count: int, duration: float, options: tuple[str, ...] = ()) -> Row:
    """``count`` worker processes with a phone each; per-second p99 jitter from telemetry.
    ``options`` go to each worker (``--renderer-process``: then the CPU figure is the
    worker's alone, without its renderer child)."""
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    sub = context.socket(zmq.SUB)
    sub.setsockopt(zmq.SUBSCRIBE, b"telemetry.")
    sub.bind("tcp://127.0.0.1:*")
    telemetry = sub.getsockopt_string(zmq.LAST_ENDPOINT)
    processes: list[subprocess.Popen[bytes]] = []
    ports = [free_udp_port() for _ in range(count)]
    try:
        for i, port in enumerate(ports):
            processes.append(subprocess.Popen(
                [sys.executable, "-m", "chameleons.cli.worker_command", "--booth", f"b{i}",
                 "--driver", "null", "--behaviour", "copy", "--livelink-port", str(port),
                 "--facecapturex-port", "0", "--control", "tcp://127.0.0.1:1",
                 "--telemetry", telemetry, *options], stdout=subprocess.DEVNULL))  # fmt: skip
            processes.append(_phone(port, duration + 120, seed=i))
        beats: dict[str, list[dict[str, Any]]] = {f"b{i}": [] for i in range(count)}
        deadline, started = time.monotonic() + 90, None
        cpu0: list[float] = []
        while started is None or time.monotonic() < started + duration:
            exited = [(p.args, p.returncode) for p in processes if p.poll() is not None]
            if exited:  # a worker or phone died: say so now, not after the 90 s
                raise RuntimeError(f"a booth's process exited early: {exited[0]}")
            if time.monotonic() > deadline:
                heard = {booth: len(v) for booth, v in beats.items()}
                raise RuntimeError(f"{count} booths did not all report within 90 s "
                                   f"(ready heartbeats per booth: {heard})")  # fmt: skip
            if not sub.poll(200):
                continue
            body = deserialize(sub.recv_multipart()).body
            ready = body.get("tick_rate_hz") and body.get("input_fps")
            if started is None and ready:
                beats[body["booth"]].append(body)
                if all(len(v) > WARMUP_BEATS for v in beats.values()):
                    started = time.monotonic()
                    cpu0 = [cpu_seconds(p.pid) for p in processes[::2]]
                    beats = {booth: [] for booth in beats}
            elif started is not None and ready:
                beats[body["booth"]].append(body)
        cpu = [(cpu_seconds(p.pid) - c) / duration for p, c in zip(processes[::2], cpu0,
                                                                    strict=True)]  # fmt: skip
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            process.wait()
        sub.close()
        context.term()
    p99 = {b: [x["jitter_ms"]["p99"] for x in v if x["jitter_ms"]["p99"] is not None]
           for b, v in beats.items()}  # fmt: skip
    worst = max(float(np.median(v)) for v in p99.values())
    return {"booths": count, "worst_booth_median_p99_ms": worst,
            "max_p99_ms": max(max(v) for v in p99.values()),
            "missed_ticks": sum(v[-1]["missed_ticks"] - v[0]["missed_ticks"]
                                for v in beats.values()),
            "cpu_per_booth": float(np.mean(cpu))}  # fmt: skip


# --- the table ------------------------------------------------------------------------------
def run(args: argparse.Namespace) -> dict[str, Any]:
    duration = args.duration
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)  # as in a worker process (runtime.run_worker)
    results: dict[str, Any] = {"load_before": os.getloadavg(), "cpus": os.cpu_count()}
    results["worker"], results["bare_loop"] = worker_and_bare_loop(duration)
    results["hop"] = pyzmq_hop(2000 if not args.quick else 300)
    results["copy_4s"] = copy_latency(duration, 4.0)
    results["live_0s"] = copy_latency(max(3.0, duration / 3), 0.0)
    results["booths"] = []
    for count in range(1, args.max_booths + 1):
        row = booths(count, args.booth_seconds)
        results["booths"].append(row)
        if row["worst_booth_median_p99_ms"] >= 1.0:
            break
    # 6: the renderer (and driver) in a process of its own, then also real-time scheduled.
    # A failure here is reported in its row, not the end of the run.
    for key, options in (("renderer_process", ("--renderer-process",)),
                         ("renderer_realtime", ("--renderer-process", "--realtime"))):  # fmt: skip
        try:
            results[key] = booths(1, args.booth_seconds, options)
        except RuntimeError as error:
            results[key] = {"failed": str(error)}
    results["load_after"] = os.getloadavg()
    return results


def table(r: dict[str, Any]) -> str:
    bare, work, hop = r["bare_loop"], r["worker"], r["hop"]
    c4, c0 = r["copy_4s"], r["live_0s"]

    def ratio(a: float, b: float) -> str:
        return f"{a / b:.2f}x" if b > 0 else "-"

    rows = [("measure", "worker", "baseline", "ratio")]
    for key in ("p50", "p99", "max"):
        rows.append((f"1 tick jitter {key} (ms)", f"{work['jitter_ms'][key]:.3f}",
                     f"{bare['jitter_ms'][key]:.3f}",
                     ratio(work["jitter_ms"][key], bare["jitter_ms"][key])))  # fmt: skip
    rows.append(("1 missed ticks", str(work["missed"]), str(bare["missed"]), ""))
    rows.append(("1 input frame rate (fps)", f"{work['input_fps']:.1f}", "60", ""))
    for name, run_ in (("copy 4 s", c4), ("live 0 s", c0)):
        for key in ("p50", "p99"):
            rows.append((f"2 added latency head {key}, {name} (ms)",
                         f"{run_['head_ms'][key]:.3f}", f"{hop['latency_ms'][key]:.3f}",
                         ratio(run_["head_ms"][key], hop["latency_ms"][key])))  # fmt: skip
    for key in ("p50", "p99", "max"):
        rows.append((f"3 copy delay |error| head {key} (ms)", f"{c4['head_abs_ms'][key]:.3f}",
                     "0", ""))  # fmt: skip
        rows.append((f"3 copy delay |error| face {key} (ms)", f"{c4['face_abs_ms'][key]:.3f}",
                     "0", ""))  # fmt: skip
    rows.append(("4 CPU per booth, in-process (% of a core)",
                 f"{100 * work['cpu_fraction']:.1f}", "", ""))  # fmt: skip
    for row in r["booths"]:
        rows.append((f"5 {row['booths']} booth(s): worst median p99 / max p99 (ms)",
                     f"{row['worst_booth_median_p99_ms']:.3f} / {row['max_p99_ms']:.3f}",
                     "< 1 ms", f"CPU {100 * row['cpu_per_booth']:.1f}%/booth"))  # fmt: skip
    ok = [row["booths"] for row in r["booths"] if row["worst_booth_median_p99_ms"] < 1.0]
    rows.append(("5 booths carried with p99 jitter < 1 ms", str(max(ok, default=0)), "", ""))
    one = r["booths"][0]["worst_booth_median_p99_ms"]
    for name, key in (("renderer process", "renderer_process"),
                      ("renderer process, real-time", "renderer_realtime")):  # fmt: skip
        row = r[key]
        if "failed" in row:
            rows.append((f"6 1 booth, {name}", "FAILED", row["failed"], ""))
            continue
        rows.append((f"6 1 booth, {name}: median p99 / max p99 (ms)",
                     f"{row['worst_booth_median_p99_ms']:.3f} / {row['max_p99_ms']:.3f}",
                     f"{one:.3f} (in-process)",
                     ratio(row["worst_booth_median_p99_ms"], one)))  # fmt: skip
    widths = [max(len(row[i]) for row in rows) for i in range(4)]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)) for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    load = ", ".join(f"{x:.2f}" for x in r["load_before"])
    return "\n".join([*lines, "", f"{r['cpus']} CPUs; load average before the run: {load}"])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="A short smoke run.")
    parser.add_argument("--duration", type=float, default=None, help="Seconds per run [30].")
    parser.add_argument("--booth-seconds", type=float, default=None, help="[10]")
    parser.add_argument("--max-booths", type=int, default=None, help="[8]")
    parser.add_argument("--json", default=None, help="Also write the results to this file.")
    args = parser.parse_args(argv)
    quick = args.quick
    args.duration = args.duration or (3.0 if quick else 30.0)
    args.booth_seconds = args.booth_seconds or (3.0 if quick else 10.0)
    args.max_booths = args.max_booths or (2 if quick else 8)
    results = run(args)
    print(table(results))
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=2, default=float)


if __name__ == "__main__":
    main()
