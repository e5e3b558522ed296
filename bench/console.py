"""Benchmark: the operator console with one browser connected, at 50 Hz telemetry.

The robot moves throughout (a slow torsional dither). Prints JSON: the console's CPU (share of
one core); scene updates per second reaching the browser's WebSocket and the delay from a
telemetry message's arrival at the console to then (p50/p95), read from viser's frames as
Playwright sees them; and the states the page actually drew (a MutationObserver on the status
line, updated in the same atomic batch as the 3D scene), which headless Chromium without a GPU
bounds by its software-WebGL frame rate. Measured after a warm-up: a fresh page first loads
the scene and works off a few seconds of backlog.

Also (issue 10): frames the page renders per second while the arm moves (requestAnimationFrame
callbacks: the browser runs one per frame it draws), how often the pinned status bar updates,
and how long a fresh console takes to show Send at a 3 s round trip.

Issue 27: at the operator's 1366x768, with `--busy N` processes spinning on the CPU meanwhile (a
user's machine is rarely idle) and, with `--baseline-rev REV`, the same frame-rate measurement of
another revision (checked out in a temporary git worktree, its own three processes) in the same
run, so the two figures share the machine's state.

    python -m bench.console [--seconds 10] [--busy 2] [--baseline-rev dbb34ef]
"""

import argparse
import contextlib
import json
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import zstandard
from playwright.sync_api import sync_playwright

from bench.server import cpu_seconds, percentile
from ptwl.launcher import running_console, running_proxy, running_server
from web.browser import launch

VIEWPORT = {"width": 1366, "height": 768}  # the operator's laptop (issue 27)
WARM_UP_S = 8.0  # a fresh page first loads the scene and works off a few seconds of backlog
# The seq and console arrival time of each telemetry state travel in a hidden element sent in
# the same atomic batch as the scene.
STATUS_PATTERN = re.compile(rb'id=\\?"ptwl-scene\\?" data-seq=\\?"(\d+)\\?" data-arrived=\\?"([\d.]+)')


def states_in_frame(payload: bytes) -> list[tuple[int, float]]:
    """(seq, arrival) of the telemetry states in one viser WebSocket frame.

    viser's wire format: 8-byte decompressed size, 8-byte compressed size, zstd msgpack."""
    size = int.from_bytes(payload[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(payload[16 : 16 + size])
    return [(int(seq), float(arrived)) for seq, arrived in STATUS_PATTERN.findall(inner)]


FRAMES = """
() => {
  window.__frames = 0;
  const tick = () => { window.__frames++; requestAnimationFrame(tick); };
  requestAnimationFrame(tick);
  window.__bar = 0;
  new MutationObserver(() => { window.__bar++; }).observe(
    document.querySelector('#ptwl-bar').parentElement, {childList: true, subtree: true});
}
"""

OBSERVER = """
() => {
  window.__updates = [];
  const node = document.querySelector('#ptwl-scene').parentElement;
  new MutationObserver(() => {
    const el = document.querySelector('#ptwl-scene');
    if (el && el.dataset.arrived) {
      window.__updates.push([Date.now() / 1000, Number(el.dataset.seq), Number(el.dataset.arrived)]);
    }
  }).observe(node, {subtree: true, childList: true, attributes: true, characterData: true});
}
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--busy", type=int, default=0, help="processes spinning on the CPU meanwhile")
    parser.add_argument("--baseline-rev", help="also measure this git revision's console, same run")
    parser.add_argument("--rounds", type=int, default=3, help="alternations of this tree and the baseline")
    args = parser.parse_args()
    with spinning(args.busy), sync_playwright() as playwright:
        figures = moving_console(playwright, args.seconds, capture=True)
        if args.baseline_rev:
            figures["frame_rate_against_baseline"] = against_baseline(
                playwright, args.baseline_rev, args.seconds, args.rounds
            )
        figures["fresh_console_send_visible_s_at_3s_rtt_median_of_3_by_scene"] = {
            scene: statistics.median(send_visible_s(scene, playwright, rtt_s=3.0) for _ in range(3))
            for scene in ("surface", "sleeve_on_peg")  # `ptwl up`'s default, and the heaviest
        }
    print(json.dumps({"busy_processes": args.busy, "viewport": VIEWPORT, **figures}))


def against_baseline(playwright: Any, rev: str, seconds: float, rounds: int) -> dict[str, Any]:
    """Frames and states drawn a second, this tree's console and `rev`'s taking turns `rounds`
    times (a busy machine's load drifts: one after the other would compare two loads); medians."""
    figures: dict[str, dict[str, list[float]]] = {"this_tree": {}, rev: {}}
    with checked_out(rev) as tree:
        for _ in range(rounds):
            for name, where in (("this_tree", Path.cwd()), (rev, tree)):
                with contextlib.chdir(where):
                    measured = moving_console(playwright, seconds, capture=False)
                for key in ("frames_per_s_while_moving_software_webgl", "states_drawn_per_s_software_webgl"):
                    figures[name].setdefault(key, []).append(measured[key])
    medians = {name: {key: statistics.median(v) for key, v in runs.items()} for name, runs in figures.items()}
    key = "frames_per_s_while_moving_software_webgl"
    return {
        "runs": figures,
        "medians": medians,
        "frames_per_s_ratio": round(medians["this_tree"][key] / medians[rev][key], 2),
    }


def moving_console(playwright: Any, seconds: float, capture: bool) -> dict[str, Any]:
    """The three processes of the current directory's checkout and one browser, the arm moving.

    With `capture`, every WebSocket frame the page receives is also read here (when states reach
    the browser): Playwright's driver then handles each, which costs the page some frames."""
    with (
        running_server("--scene", "sleeve_on_peg") as robot,
        running_proxy(robot.url) as link,
        running_console(link.url) as console,
    ):
        browser = launch(playwright)
        page = browser.new_page(viewport=VIEWPORT, bypass_csp=True)  # eval in predicates
        frames: list[tuple[float, bytes]] = []
        if capture:
            page.on(
                "websocket",
                lambda ws: ws.on(
                    "framereceived",
                    lambda data: frames.append(
                        (time.time(), data if isinstance(data, bytes) else data.encode())
                    ),
                ),
            )
        page.goto(console.url)
        page.wait_for_function("document.querySelector('#ptwl-telemetry')?.dataset.seq > 0", timeout=60_000)
        time.sleep(WARM_UP_S)
        page.evaluate(OBSERVER)
        page.evaluate(FRAMES)
        # The robot moves throughout: a torsional dither wobbles the sleeve over the peg.
        httpx.post(
            link.url + "/api/commands",
            json={
                "type": "dither",
                "preset": "torsional_push",
                "travel": 0.015,
                "duration": 60.0,
                "watchdog": 120.0,
            },
        ).raise_for_status()
        time.sleep(1.0)
        pid = console.process.pid
        t0, cpu0 = time.monotonic(), cpu_seconds(pid)
        page.wait_for_timeout(seconds * 1000)
        wall, cpu = time.monotonic() - t0, cpu_seconds(pid) - cpu0
        drawn = page.evaluate("window.__updates")
        frames_drawn, bar_updates = page.evaluate("[window.__frames, window.__bar]")
        t_start = time.time() - wall
        browser.close()
    shown = first_sightings(drawn)
    figures: dict[str, Any] = {
        "console_cpu_percent_of_a_core": round(100.0 * cpu / wall, 1),
        "telemetry_hz": 50,
        # Drawn = distinct states the page displayed: bounded by the frame rate of headless
        # Chromium without a GPU (software WebGL).
        "states_drawn_per_s_software_webgl": round(len(shown) / wall, 1),
        "arrival_to_drawn_ms": delay_stats(shown),
        "frames_per_s_while_moving_software_webgl": round(frames_drawn / wall, 1),
        "status_bar_updates_per_s": round(bar_updates / wall, 1),
    }
    if capture:
        received = [
            [t, seq, arrived] for t, data in frames if t >= t_start for seq, arrived in states_in_frame(data)
        ]
        reached = first_sightings(received)
        figures["scene_updates_per_s_reaching_browser"] = round(len(reached) / wall, 1)
        figures["arrival_to_browser_ms"] = delay_stats(reached)
    return figures


@contextlib.contextmanager
def spinning(processes: int) -> Iterator[None]:
    """`processes` busy loops at normal priority: the load of a user's machine doing other work."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(processes)]
    try:
        yield
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


@contextlib.contextmanager
def checked_out(rev: str) -> Iterator[Path]:
    """A temporary git worktree of `rev` (its processes start from there: `python -m` puts the
    working directory first on the path); removed after."""
    with tempfile.TemporaryDirectory(prefix="ptwl-baseline-") as parent:
        tree = Path(parent) / "tree"
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(tree), rev], check=True)
        try:
            yield tree
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], check=False)


def send_visible_s(scene: str, playwright: Any, rtt_s: float) -> float:
    """Seconds from a fresh console serving its page (it has just started to reach a robot in
    `scene` through an `rtt_s` link) until a browser opened then shows Send."""
    half = str(rtt_s / 2.0)
    with (
        running_server("--scene", scene) as robot,
        running_proxy(robot.url, "--uplink", half, "--downlink", half) as link,
    ):
        browser = launch(playwright)
        page = browser.new_page(viewport=VIEWPORT, bypass_csp=True)  # eval in predicates
        with running_console(link.url) as console:
            t0 = time.monotonic()
            page.goto(console.url)
            page.get_by_role("button", name="Send cmd").wait_for(timeout=120_000)
            elapsed = time.monotonic() - t0
            browser.close()
    return round(elapsed, 2)


def first_sightings(rows: list[list[float]]) -> dict[int, tuple[float, float]]:
    """{seq: (first time seen [s], console arrival [s])}."""
    seen: dict[int, tuple[float, float]] = {}
    for t, seq, arrived in rows:
        seen.setdefault(int(seq), (t, arrived))
    return seen


def delay_stats(seen: dict[int, tuple[float, float]]) -> dict[str, float]:
    delays = [1000.0 * (t - arrived) for t, arrived in seen.values()]
    return {
        "p50": round(statistics.median(delays), 1),
        "p95": round(percentile(delays, 0.95), 1),
        "max": round(max(delays), 1),
    }


if __name__ == "__main__":
    main()
