"""Screenshots of the browser viewer for the README: paper experiment C (obstacles) at its last
frame, and the 3D run (scenarios/arm_3d.toml) coloured by twist with the material frame shown.

    python scripts/viewer_screenshots.py [--bin target/release/octoarm] [--out docs/]

Runs both scenarios into a temporary folder, serves them with `octoarm view`, and drives
Debian's headless Chromium with Playwright (pip install playwright; no browser download).
Not run in CI.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[1]
FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
]


def serve(binary: str, folder: Path) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen([binary, "view", str(folder), "--no-open"], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    return proc, proc.stdout.readline().split("octoarm viewer: ")[1].strip()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "octoarm"))
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--chromium", default="/usr/bin/chromium")
    a = ap.parse_args()
    out = Path(a.out)
    with tempfile.TemporaryDirectory() as tmp:
        runs = {
            "viewer-obstacles.png": ("scenarios/paper/obstacles.toml", "plain", False, "xy"),
            "viewer-3d.png": ("scenarios/arm_3d.toml", "twist", True, "3d"),
        }
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=a.chromium, args=FLAGS)
            for name, (scenario, colour, frame, view) in runs.items():
                folder = Path(tmp) / Path(scenario).stem
                subprocess.run([a.bin, "run", str(ROOT / scenario), "--out", str(folder), "-q"], check=True)
                proc, url = serve(a.bin, folder)
                try:
                    page = browser.new_page(viewport={"width": 1400, "height": 860})
                    page.goto(url)
                    page.wait_for_function("window.__octoarm && window.__octoarm.ready", timeout=60_000)
                    page.select_option("#colour", colour)
                    if frame:
                        page.check("#show-frame")
                    page.evaluate(f"window.__octoarm.setView('{view}')")
                    page.focus("#frame")
                    page.keyboard.press("End")
                    page.wait_for_timeout(500)
                    page.screenshot(path=str(out / name))
                    print("wrote", out / name)
                finally:
                    proc.send_signal(signal.SIGINT)
                    proc.wait(timeout=20)
            browser.close()


if __name__ == "__main__":
    main()
