"""Robot display benchmark: the 3D head against the 2D face (the baseline, same run, same
browser, same frames) in Chromium at 1280x800.

``python -m bench.display_bench [--quick] [--seconds 20] [--width 1280 --height 800]
[--json FILE]``

The app runs in this process on a fresh SQLite file; one headless Chromium with software
WebGL (SwiftShader through ANGLE: ``--use-angle=swiftshader``; no GPU is used even where
one exists, so the figures are a floor for a booth PC with a GPU) opens the booth's display
link with ``?renderer=2d`` and then ``?renderer=3d`` (first, an empty page that only counts
animation frames shows what the browser manages here at all). For each, the server's
display channel gets what a worker sends while the robot copies a face: face frames at
25 Hz (jaw, smile, blink, brows moving) and head pose at 125 Hz (yaw and pitch swaying).
Figures, from the page's own once-a-second telemetry (``protocol.py``) and the Chromium
processes' CPU time:

- **frame time**: the time ``draw()`` takes per painted frame on the page's thread (p50 of
  the per-second medians, the largest per-second p95; WebGL rasterises after it, in the GPU
  process), and the **frame interval** between painted frames (p50, p95);
- **frames painted / dropped** per second (a frame interval of n refreshes drops n - 1);
- **arrival -> pixels**: from a face frame's arrival at the page to the end of the paint
  that first shows it in full (p50; this includes the interpolation delay that keeps motion
  smooth, reported beside it, and the draw);
- **CPU**: CPU seconds of all Chromium processes per wall second (1.0 = one core), the
  WebGL rasterisation in SwiftShader included.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import queue
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from playwright.sync_api import sync_playwright

from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.protocol import Message, face_message, head_message
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES
from tests.support.head3d import display_server, launch_webgl, open_head

BOOTH = "booth-1"
FACE_HZ, HEAD_HZ = 25.0, 125.0


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    found.add_argument("--quick", action="store_true", help="A smoke run (a few seconds each).")
    found.add_argument("--seconds", type=float, default=20.0, help="Measured seconds per face.")
    found.add_argument("--width", type=int, default=1280)
    found.add_argument("--height", type=int, default=800)
    found.add_argument("--json", type=Path, help="Write the figures here.")
    return found


def feed(channel: Any, stop: threading.Event) -> None:
    """A copying robot's stream: face frames at 25 Hz, head pose at 125 Hz, on time."""
    start = time.monotonic()
    next_face, tick = start, 0
    while not stop.is_set():
        now = start + tick / HEAD_HZ
        t = now - start
        channel.publish(BOOTH, head_message([20 * math.sin(0.7 * t), 8 * math.sin(1.1 * t),
                                             3 * math.sin(0.5 * t)], sent=now))  # fmt: skip
        if now >= next_face:
            shapes = [0.0] * N_BLENDSHAPES
            shapes[BLENDSHAPE_INDEX["jawOpen"]] = 0.5 + 0.5 * math.sin(9 * t)
            shapes[BLENDSHAPE_INDEX["mouthSmileLeft"]] = 0.5 + 0.5 * math.sin(0.9 * t)
            shapes[BLENDSHAPE_INDEX["mouthSmileRight"]] = 0.5 + 0.5 * math.sin(0.9 * t)
            shapes[BLENDSHAPE_INDEX["browInnerUp"]] = 0.5 + 0.5 * math.sin(1.3 * t)
            blink = 1.0 if (t % 3.0) < 0.15 else 0.0
            for eye in ("eyeBlinkLeft", "eyeBlinkRight"):
                shapes[BLENDSHAPE_INDEX[eye]] = blink
            channel.publish(BOOTH, face_message(shapes, sent=now))
            next_face += 1 / FACE_HZ
        tick += 1
        stop.wait(max(0.0, start + tick / HEAD_HZ - time.monotonic()))


def chromium_cpu_seconds() -> float | None:
    """CPU seconds (user + system) of every Chromium process under this one (Linux /proc)."""
    if not Path("/proc/self/stat").exists():
        return None
    children: dict[int, list[int]] = {}
    times: dict[int, tuple[str, float]] = {}
    tick = os.sysconf("SC_CLK_TCK")
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        name = stat[stat.index("(") + 1 : stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2 :].split()
        children.setdefault(int(fields[1]), []).append(int(entry.name))
        times[int(entry.name)] = (name, (int(fields[11]) + int(fields[12])) / tick)
    total, stack = 0.0, [os.getpid()]
    while stack:
        pid = stack.pop()
        stack.extend(children.get(pid, []))
        name, seconds = times.get(pid, ("", 0.0))
        if "chrom" in name.lower():
            total += seconds
    return total


def measure(page: Any, channel: Any, url: str, seconds: float) -> dict[str, Any]:
    reports: queue.Queue[Message] = queue.Queue()

    def listener(_booth: str, message: Message) -> None:
        if message.get("type") == "telemetry":
            reports.put(message)

    open_head(page, url)
    stop = threading.Event()
    feeder = threading.Thread(target=feed, args=(channel, stop), daemon=True)
    feeder.start()
    channel.add_listener(listener)
    try:
        page.wait_for_timeout(2500)  # warm-up: shaders, textures, the jitter buffer
        while not reports.empty():
            reports.get()
        cpu0, wall0 = chromium_cpu_seconds(), time.monotonic()
        page.wait_for_timeout(seconds * 1000)
        cpu1, wall1 = chromium_cpu_seconds(), time.monotonic()
    finally:
        stop.set()
        feeder.join(timeout=5)
        channel.remove_listener(listener)
    seconds_seen = []
    while not reports.empty():
        seconds_seen.append(reports.get())
    cpu = None if cpu0 is None or cpu1 is None else (cpu1 - cpu0) / (wall1 - wall0)
    return summarise(seconds_seen, page.evaluate("window.robotDisplay.renderer().kind"), cpu)


def summarise(reports: list[Message], kind: str, cpu: float | None) -> dict[str, Any]:
    def values(path: tuple[str, ...]) -> list[float]:
        found = []
        for r in reports:
            value: Any = r
            for key in path:
                value = value.get(key) if isinstance(value, dict) else None
            if isinstance(value, int | float):
                found.append(float(value))
        return found

    def median(path: tuple[str, ...]) -> float | None:
        got = values(path)
        return round(statistics.median(got), 2) if got else None

    p95 = values(("frame_ms", "p95"))
    return {
        "renderer": kind, "seconds": len(reports),
        "fps": median(("fps",)), "frames_in_per_s": median(("frames_in",)),
        "frame_ms_p50": median(("frame_ms", "p50")), "frame_ms_p95_max": max(p95) if p95 else None,
        "interval_ms_p50": median(("interval_ms", "p50")),
        "interval_ms_p95": median(("interval_ms", "p95")),
        "dropped_per_s": round(sum(values(("dropped_frames",))) / max(1, len(reports)), 2),
        "arrival_to_pixels_p50_ms": median(("paint_latency_ms", "p50")),
        "arrival_to_pixels_p95_ms": median(("paint_latency_ms", "p95")),
        "interpolation_delay_ms": median(("interp_delay_ms",)),
        "cpu_cores": None if cpu is None else round(cpu, 3),
    }  # fmt: skip


BARE_LOOP = """(seconds) => new Promise((done) => {
  const gaps = []; let last = null; const end = performance.now() + seconds * 1000;
  const tick = (now) => {
    if (last !== null) gaps.push(now - last);
    last = now;
    if (now < end) requestAnimationFrame(tick);
    else { gaps.sort((a, b) => a - b);
           done({ fps: gaps.length / seconds, p50: gaps[Math.floor(gaps.length / 2)],
                  p95: gaps[Math.floor(gaps.length * 0.95)] }); }
  };
  requestAnimationFrame(tick);
})"""


def bare_frames(page: Any, seconds: float) -> dict[str, Any]:
    """The browser's own frame rate here: an empty page that only counts animation frames
    (what this machine and its load allow any page)."""
    page.set_content("<!doctype html><title>bare</title><body style='margin:0'></body>")
    cpu0, wall0 = chromium_cpu_seconds(), time.monotonic()
    got: dict[str, Any] = page.evaluate(BARE_LOOP, seconds)
    cpu1, wall1 = chromium_cpu_seconds(), time.monotonic()
    cpu = None if cpu0 is None or cpu1 is None else (cpu1 - cpu0) / (wall1 - wall0)
    return {
        "fps": round(got["fps"], 1),
        "interval_ms_p50": round(got["p50"], 1),
        "interval_ms_p95": round(got["p95"], 1),
        "cpu_cores": None if cpu is None else round(cpu, 3),
    }


def ratios(three: dict[str, Any], two: dict[str, Any]) -> dict[str, float | None]:
    def ratio(key: str) -> float | None:
        a, b = three.get(key), two.get(key)
        return round(a / b, 2) if isinstance(a, float) and isinstance(b, float) and b else None

    keys = ("frame_ms_p50", "interval_ms_p50", "fps", "arrival_to_pixels_p50_ms", "cpu_cores")
    return {f"{key}_x_2d": ratio(key) for key in keys}


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    seconds = 3.0 if args.quick else args.seconds
    results: dict[str, Any] = {
        "viewport": f"{args.width}x{args.height}",
        "webgl": "software (SwiftShader via ANGLE)",
        "seconds": seconds,
    }
    with tempfile.TemporaryDirectory() as tmp, display_server(Path(tmp)) as (url, app), \
            sync_playwright() as playwright:  # fmt: skip
        channel = get_display_channel(app)
        browser = launch_webgl(playwright)
        try:
            page = browser.new_page(viewport={"width": args.width, "height": args.height})
            results["bare"] = bare_frames(page, seconds)
            page.close()
            for kind in ("2d", "3d"):
                page = browser.new_page(viewport={"width": args.width, "height": args.height})
                results[kind] = measure(page, channel, f"{url}?renderer={kind}", seconds)
                page.close()
        finally:
            browser.close()
    results["3d_vs_2d"] = ratios(results["3d"], results["2d"])
    print(f"Robot display at {results['viewport']}, {results['webgl']}, {seconds:g} s each")
    bare = results["bare"]
    print(
        f"  a bare page's animation frames: {bare['fps']} /s, every {bare['interval_ms_p50']} ms"
        f" (p95 {bare['interval_ms_p95']}), CPU {bare['cpu_cores']}"
    )
    for key in ("fps", "interval_ms_p50", "interval_ms_p95", "frame_ms_p50", "frame_ms_p95_max",
                "dropped_per_s",
                "arrival_to_pixels_p50_ms", "interpolation_delay_ms", "cpu_cores"):  # fmt: skip
        print(f"  {key:28} 2d {results['2d'][key]!s:>8}   3d {results['3d'][key]!s:>8}")
    print("  3d / 2d:", ", ".join(f"{k} {v}" for k, v in results["3d_vs_2d"].items()))
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))
    ok = results["3d"]["renderer"] == "3d" and results["2d"]["renderer"] == "2d"
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
