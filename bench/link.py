"""Benchmark: the link proxy on loopback, against a real robot server.

Prints JSON: latency the proxy adds at zero delay compared with a direct connection (p50, p99)
for HTTP and WebSocket; holding error (release time minus scheduled release) p50/p99/max at 1 s
delay for 50 and 500 messages/s, with early releases and reorderings; bytes of memory per held
message.

    python -m bench.link [--seconds 5] [--requests 500]
"""

import argparse
import asyncio
import functools
import json
import statistics
import time
import tracemalloc

import httpx
import websockets

from latency.link import Link
from latency.profile import LinkProfile
from ptwl.launcher import running_proxy, running_server


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def http_times_ms(url: str, n: int) -> list[float]:
    out = []
    with httpx.Client(base_url=url) as client:
        client.get("/api/health")
        for _ in range(n):
            t0 = time.perf_counter()
            client.get("/api/health").raise_for_status()
            out.append((time.perf_counter() - t0) * 1000.0)
    return out


async def ws_ages_ms(url: str, seconds: float) -> list[float]:
    """Arrival time minus the server's sent_at for each state message [ms]."""
    ages = []
    async with websockets.connect(
        url.replace("http://", "ws://") + "/api/telemetry", ping_interval=None
    ) as ws:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            message = json.loads(await ws.recv())
            if message["type"] == "state":
                ages.append((time.time() - message["sent_at"]) * 1000.0)
    return ages[20:]  # skip the connection's first burst


def added(direct: list[float], via: list[float]) -> dict[str, float]:
    return {
        "direct_p50": round(statistics.median(direct), 3),
        "direct_p99": round(percentile(direct, 0.99), 3),
        "proxy_p50": round(statistics.median(via), 3),
        "proxy_p99": round(percentile(via, 0.99), 3),
        "added_p50": round(statistics.median(via) - statistics.median(direct), 3),
        "added_p99": round(percentile(via, 0.99) - percentile(direct, 0.99), 3),
    }


def holding_error(rate_hz: int, seconds: float) -> dict[str, float]:
    with (
        running_server("--scene", "free_space", "--telemetry-hz", str(rate_hz)) as server,
        running_proxy(server.url, "--downlink", "1.0") as proxy,
    ):
        asyncio.run(ws_ages_ms(proxy.url, seconds + 1.0))
        stats = httpx.get(proxy.url + "/_link/stats").json()["downlink"]
    err = stats["holding_error_s"]
    return {
        "messages": stats["released"],
        "p50_ms": round(err["p50"] * 1000, 3),
        "p99_ms": round(err["p99"] * 1000, 3),
        "max_ms": round(err["max"] * 1000, 3),
        "early_releases": stats["early_releases"],
        "reorderings": stats["reorderings"],
    }


def bytes_per_held_message(n: int = 100_000) -> float:
    """Memory the link holds per in-flight WebSocket message, excluding the message's own bytes."""
    queue: list[str] = []
    message = "x" * 600  # shared: only the link's own bookkeeping is counted
    link = Link(LinkProfile(downlink=600.0))
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    for _ in range(n):
        link.admit("downlink", len(message), "ws", functools.partial(queue.append, message))
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(stat.size_diff for stat in after.compare_to(before, "filename"))
    return grown / n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--requests", type=int, default=500)
    args = parser.parse_args()
    with (
        running_server("--scene", "free_space", "--telemetry-hz", "200") as server,
        running_proxy(server.url, "--profile", "zero") as proxy,
    ):
        http_direct = http_times_ms(server.url, args.requests)
        http_via = http_times_ms(proxy.url, args.requests)
        ws_direct = asyncio.run(ws_ages_ms(server.url, args.seconds))
        ws_via = asyncio.run(ws_ages_ms(proxy.url, args.seconds))
    result = {
        "zero_delay_added_ms": {"http": added(http_direct, http_via), "ws": added(ws_direct, ws_via)},
        "holding_error_at_1s": {
            "50_msg_per_s": holding_error(50, args.seconds),
            "500_msg_per_s": holding_error(500, args.seconds),
        },
        "bytes_per_held_message": round(bytes_per_held_message()),
    }
    print(json.dumps(result))


if __name__ == "__main__":
    main()
