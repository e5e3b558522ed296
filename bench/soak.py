"""Soak: many short commands through the real server (optionally through the link), checking
that every accepted command reaches exactly one terminal state and that memory stays flat.

Mixed traffic: PTWL, RWE and Dither of a few milliseconds each, kept up to 32 deep in the
queue, and every 97th submission a STOP (so some commands end `dropped by stop`). Each
accepted id is followed on the telemetry socket; at the end every one must have exactly one
`done` event and a `done` record. RSS is the server process's, from /proc.

Prints JSON: commands accepted, terminal states seen once / twice / never, RSS at start (after
a 500-command warm-up) and end with the growth in %, throughput over the first and last tenth
and their ratio (the baseline is the same run's first tenth).

    python -m bench.soak [--commands 10000] [--through-link]
"""

import argparse
import json
import threading
import time
from collections import Counter
from typing import Any

import httpx

from ptwl.launcher import running_proxy, running_server
from server.client import RobotClient

WARM_UP = 500
QUEUE_DEPTH = 32
STOP_EVERY = 97
COMMANDS: tuple[dict[str, Any], ...] = (
    {"type": "rwe", "duration": 0.004},
    {"type": "ptwl", "translation": [0.0, 0.0, 0.0], "duration": 0.004},
    {"type": "dither", "mode": "translational", "amplitude": 0.001, "travel": 0.0, "duration": 0.006},
)


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS")


def soak(url: str, server_pid: int, n: int, warm_up: int = WARM_UP) -> dict[str, Any]:
    """Run `warm_up` + `n` commands against `url`; the figures above."""
    done_events: Counter[int] = Counter()
    lock = threading.Lock()
    stop_listening = threading.Event()
    robot = RobotClient(url, timeout=60.0)

    def listen() -> None:
        for message in robot.telemetry():
            if message["type"] == "command" and message["status"] == "done":
                with lock:
                    done_events[int(message["id"])] += 1
            if stop_listening.is_set():
                return

    threading.Thread(target=listen, daemon=True).start()
    time.sleep(0.5)
    accepted: list[int] = []
    stamps: list[float] = []
    rss_start = 0.0
    http = httpx.Client(base_url=url, timeout=60.0)
    for i in range(warm_up + n):
        if i == warm_up:
            rss_start = rss_mb(server_pid)
        if i % STOP_EVERY == STOP_EVERY - 1:
            http.post("/api/stop").raise_for_status()
        while True:
            response = http.post("/api/commands", json=COMMANDS[i % len(COMMANDS)])
            if response.status_code == 202:
                break
            assert response.status_code == 429, response.text
            time.sleep(0.005)
        accepted.append(int(response.json()["id"]))
        stamps.append(time.monotonic())
        if i % 16 == 0:
            while robot.health().queued >= QUEUE_DEPTH:
                time.sleep(0.01)
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        with lock:
            if all(done_events[c] >= 1 for c in accepted):
                break
        time.sleep(0.1)
    time.sleep(0.5)  # a duplicate would arrive after the first
    stop_listening.set()
    records = {c.id: c for c in robot.commands(limit=1000)}
    rss_end = rss_mb(server_pid)
    with lock:
        counts = Counter(done_events[c] for c in accepted)
    tenth = max(1, n // 10)
    measured = stamps[warm_up:]
    first = tenth / max(1e-9, measured[tenth - 1] - measured[0]) if len(measured) > tenth else 0.0
    last = tenth / max(1e-9, measured[-1] - measured[-tenth]) if len(measured) > tenth else 0.0
    recent = accepted[-min(len(accepted), 900) :]
    robot.close()
    http.close()
    return {
        "commands_accepted": len(accepted),
        "terminal_once": counts.get(1, 0),
        "terminal_more_than_once": sum(v for k, v in counts.items() if k > 1),
        "terminal_never": counts.get(0, 0),
        "recent_records_done": sum(1 for c in recent if c in records and records[c].status == "done"),
        "recent_records_checked": len(recent),
        "ids_unique": len(set(accepted)) == len(accepted),
        "rss_mb_start": round(rss_start, 1),
        "rss_mb_end": round(rss_end, 1),
        "rss_growth_pct": round(100.0 * (rss_end - rss_start) / rss_start, 2),
        "commands_per_s_first_tenth": round(first, 1),
        "commands_per_s_last_tenth": round(last, 1),
        "throughput_ratio_last_to_first": round(last / first, 3) if first else None,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--commands", type=int, default=10_000)
    parser.add_argument("--through-link", action="store_true", help="via the proxy at zero delay")
    args = parser.parse_args()
    started = time.monotonic()
    with running_server("--scene", "free_space") as robot:
        if args.through_link:
            with running_proxy(robot.url) as link:
                figures = soak(link.url, robot.process.pid, args.commands)
        else:
            figures = soak(robot.url, robot.process.pid, args.commands)
    figures["wall_s"] = round(time.monotonic() - started, 1)
    figures["through_link"] = args.through_link
    print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
