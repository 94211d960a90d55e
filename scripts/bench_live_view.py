"""Cost of `octoarm run --view` against a plain `octoarm run`: the stepping loop's wall time
(`loop_seconds` of summary.json: stepping, recording and the live recorder, not preparation or
writing) of the same scenario, alternating the two, with a page connected over the WebSocket
and receiving every frame sent (a Python client, or headless Chromium with --chromium).

    python scripts/bench_live_view.py [--bin target/release/octoarm] [--reps 7]
        [--scenario scenarios/arm_tip_force.toml] [--chromium]

Needs `websockets` (pip install websockets), or Playwright for --chromium. Not run in CI.
Prints the medians, the overhead in percent and the frames received per run.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import signal
import statistics
import subprocess
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def loop_seconds(out: Path) -> float:
    return float(json.loads((out / "summary.json").read_text())["loop_seconds"])


def plain(binary: str, scenario: str, out: Path) -> float:
    subprocess.run([binary, "run", scenario, "--out", str(out), "-q"], check=True)
    return loop_seconds(out)


def client(url: str, counts: dict[str, int]) -> None:
    import websockets

    async def go() -> None:
        async with websockets.connect(url.replace("http", "ws") + "api/live", max_size=None) as ws:
            async for msg in ws:
                if isinstance(msg, bytes):
                    counts["frames"] += 1
                elif json.loads(msg).get("state") == "finished":
                    return

    asyncio.run(go())


def chromium(url: str, counts: dict[str, int], done: threading.Event) -> None:
    from playwright.sync_api import sync_playwright

    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             "--enable-unsafe-swiftshader", "--use-angle=swiftshader"]
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path="/usr/bin/chromium", args=flags)
        page = b.new_page()
        page.goto(url)
        page.wait_for_function("window.__octoarm.status && window.__octoarm.status.state === 'finished'",
                               timeout=600_000)
        counts["frames"] = page.evaluate("window.__octoarm.liveFrames()")
        b.close()
    done.set()


def viewed(binary: str, scenario: str, out: Path, use_chromium: bool) -> tuple[float, int]:
    proc = subprocess.Popen([binary, "run", scenario, "--out", str(out), "-q", "--view", "--no-open"],
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    url = proc.stdout.readline().split("octoarm viewer: ")[1].strip()
    counts = {"frames": 0}
    if use_chromium:
        done = threading.Event()
        chromium(url, counts, done)
    else:
        client(url, counts)
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=60)
    return loop_seconds(out), counts["frames"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "octoarm"))
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "arm_tip_force.toml"))
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--chromium", action="store_true")
    a = ap.parse_args()
    base, view, frames = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.reps):
            for mode in (("plain", "view") if r % 2 == 0 else ("view", "plain")):
                out = Path(tmp) / f"{mode}{r}"
                if mode == "plain":
                    base.append(plain(a.bin, a.scenario, out))
                else:
                    t, f = viewed(a.bin, a.scenario, out, a.chromium)
                    view.append(t)
                    frames.append(f)
    mb, mv = statistics.median(base), statistics.median(view)
    print(f"scenario {a.scenario}, {a.reps} runs each, alternating")
    print(f"plain run      loop_seconds: median {mb:.3f} s  (all: {', '.join(f'{x:.3f}' for x in base)})")
    print(f"run --view     loop_seconds: median {mv:.3f} s  (all: {', '.join(f'{x:.3f}' for x in view)})")
    print(f"frames received per run: {frames}")
    print(f"overhead of --view: {100 * (mv / mb - 1):+.1f} %")


if __name__ == "__main__":
    main()
