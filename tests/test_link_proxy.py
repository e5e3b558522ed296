"""The link proxy between real processes: per-message delays, order, HTTP, blackouts, versions,
simulated vs real clock, upstream restarts."""

import asyncio
import contextlib
import itertools
import json
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import websockets

from latency.clock import SimulatedLink
from latency.profile import LinkProfile
from ptwl.launcher import ServiceProcess, running_proxy, running_server

# The link releases each message on its own timer, never early and in order (checked exactly).
# How close to its due time is the host's as much as the link's: alone on an idle 2-core machine
# the median is 0.05-0.2 ms and 99 % are within 5 ms, which `python -m bench.link` measures and
# reports (holding_error_at_1s). In a suite that runs two tests at once beside a hogged core the
# whole proxy process waits for a core now and then: measured, medians of 1.2-5.5 ms and a p99
# of 111 ms with a core hogged, 255 ms idle beside a browser test. So here the median is held to
# 10 ms, which still fails a link that waits for the next arrival or for a tick of 20 ms or more
# (planted: a 20 ms tick failed), and the tail to what such a machine does (HOST_STALL_S).
# How long this test process may not be scheduled when it runs beside another test with a core
# hogged (measured: 0.41 s), for timings taken here rather than in the link's record.
HOST_STALL_S = 0.6
MEDIAN_TOLERANCE_S = 0.01
TAIL_TOLERANCE_S = HOST_STALL_S
pytestmark = pytest.mark.usefixtures("no_gc_pauses")  # end-to-end timings are taken in this process


@pytest.fixture(scope="module")
def fast_server() -> Iterator[ServiceProcess]:
    """A robot server sending telemetry at 200 messages/s."""
    with running_server("--scene", "free_space", "--telemetry-hz", "200") as srv:
        yield srv


def ws(url: str) -> str:
    return url.replace("http://", "ws://") + "/api/telemetry"


# The sockets here use max_queue=None: a client that stops reading with more than max_queue
# messages waiting never reads the server's close frame behind them, and its close() waits out
# close_timeout (10 s) and ends 1006. Unbounded, it keeps reading and closes in a round trip.


async def exchange(proxy_url: str, seconds: float, send_hz: float) -> list[tuple[float, dict]]:
    """Send `send_hz` messages/s up and collect telemetry down for `seconds`; (arrival, message)."""
    received: list[tuple[float, dict]] = []
    async with websockets.connect(ws(proxy_url), ping_interval=None, max_queue=None) as conn:

        async def send() -> None:
            # On a schedule, not sleep(1/hz) after each send: that sleep overshoots by a timer
            # slice, and the exchange sent ~half the rate for twice the time.
            start = time.monotonic()
            for i in range(int(seconds * send_hz)):
                await conn.send(json.dumps({"client_seq": i}))
                await asyncio.sleep(max(0.0, start + (i + 1) / send_hz - time.monotonic()))

        async def receive() -> None:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                try:
                    text = await asyncio.wait_for(conn.recv(), 0.5)
                except TimeoutError:
                    continue
                received.append((time.time(), json.loads(text)))

        await asyncio.gather(send(), receive())
    return received


def read_record(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def check_record(records: list[dict], direction: str, n_min: int) -> list[dict]:
    """Every message of `direction` released in order and never before it is due; the median
    within MEDIAN_TOLERANCE_S of it, 99 % within TAIL_TOLERANCE_S.

    Why a percentile for lateness: on a shared 2-core machine the whole proxy process is sometimes
    not scheduled for 10-50 ms (both directions go late at the same instant, with nothing else
    running); that is the host, not the link, and a per-message bound failed half the runs. A
    link that releases on the wrong timer (a tick, or the next arrival) is late on most
    messages against its own schedule (each message due at arrival + delay, never before the one
    ahead of it is due) and fails the median. The tail is judged against the release ahead as it
    really happened, so the messages queued behind one host stall count once, not all late."""
    rows = [
        r for r in records if r["direction"] == direction and r["kind"] in ("ws", "ws_state") and r["release"]
    ]
    assert len(rows) >= n_min
    assert [r["seq"] for r in rows] == sorted(r["seq"] for r in rows)  # FIFO
    previous_release = previous_due = float("-inf")
    behind_release, behind_schedule = [], []
    for r in rows:
        due = max(r["arrival"] + r["configured_delay"], previous_due)
        scheduled = max(due, previous_release)
        assert r["release"] >= scheduled, r  # never early
        behind_release.append(r["release"] - scheduled)
        behind_schedule.append(r["release"] - due)
        previous_release, previous_due = r["release"], due
    assert_mostly_on_time(behind_release, behind_schedule)
    return rows


def assert_mostly_on_time(lateness_s: list[float], schedule_lateness_s: list[float] | None = None) -> None:
    """Never early; 99 % within TAIL_TOLERANCE_S; the median within MEDIAN_TOLERANCE_S of the
    schedule (`schedule_lateness_s`, when the lateness is judged against the release ahead)."""
    ordered = sorted(lateness_s)
    assert ordered[0] >= -1e-9, ordered[0]
    assert ordered[int(0.99 * len(ordered))] <= TAIL_TOLERANCE_S
    on_schedule = sorted(lateness_s if schedule_lateness_s is None else schedule_lateness_s)
    assert on_schedule[len(on_schedule) // 2] <= MEDIAN_TOLERANCE_S


def test_one_second_each_way_200_messages_per_second(fast_server: ServiceProcess, tmp_path: Path) -> None:
    record = tmp_path / "link.jsonl"
    with running_proxy(fast_server.url, "--uplink", "1", "--downlink", "1", "--record", str(record)) as proxy:
        received = asyncio.run(exchange(proxy.url, seconds=7.0, send_hz=200.0))
        time.sleep(1.5)  # the last uplink messages are still in flight
        stats = httpx.get(proxy.url + "/_link/stats").json()
    states = [(t, m) for t, m in received if m["type"] == "state"]
    # ~6 s of telemetry after the first second in flight, carried for all of it, at the robot's
    # rate: 200 per second of its simulated time. Not per second of the wall clock, which a starved
    # robot falls behind (~170 measured with three test workers on 2 cores, 146 in a fresh-clone
    # CI run with a core hogged).
    span_s = states[-1][1]["sent_at"] - states[0][1]["sent_at"]
    sim_span_s = states[-1][1]["sim_time"] - states[0][1]["sim_time"]
    assert span_s >= 5.5, span_s
    assert len(states) - 1 == pytest.approx(200 * sim_span_s, abs=2), (len(states), sim_span_s)
    assert all(
        b["seq"] - a["seq"] == 1 for (_, a), (_, b) in itertools.pairwise(states)
    )  # none lost, in order
    # End to end (server wall clock to this client): never early; typically ~1 ms late idle. The
    # rest is this Python client's own scheduling while it also sends 200 messages/s: the median
    # 7.9 ms late with three test workers on 2 cores, 11.2 and 26.0 ms in hogged CI runs beside the
    # browser files (p99 127 ms with a core hogged and two tests at once, 298 ms beside a browser
    # test). So the median within 50 ms and the tail within HOST_STALL_S; the link's own timing is
    # held to MEDIAN_TOLERANCE_S per message from its record, below.
    ages = sorted(t - m["sent_at"] for t, m in states)
    assert ages[0] >= 1.0 - 0.002
    assert ages[len(ages) // 2] <= 1.0 + 0.05 and ages[int(0.99 * len(ages))] <= 1.0 + HOST_STALL_S
    records = read_record(record)
    down = check_record(records, "downlink", len(states))  # at least what this client received
    up = check_record(records, "uplink", 5 * 200)  # this client's own 200/s
    assert all(r["configured_delay"] == pytest.approx(1.0) for r in down + up)
    for direction in ("uplink", "downlink"):
        s = stats[direction]
        assert s["early_releases"] == 0 and s["reorderings"] == 0
        assert s["holding_error_s"]["p50"] <= MEDIAN_TOLERANCE_S
        assert s["holding_error_s"]["p99"] <= TAIL_TOLERANCE_S
        assert s["realized_delay_s"]["p50"] == pytest.approx(1.0, abs=0.003)


def test_jitter_keeps_order_and_reports_realized_delay(fast_server: ServiceProcess, tmp_path: Path) -> None:
    record = tmp_path / "link.jsonl"
    jitter = {"distribution": "uniform", "amount": 0.3, "seed": 11}
    with running_proxy(fast_server.url, "--uplink", "1", "--downlink", "1", "--record", str(record)) as proxy:
        httpx.put(proxy.url + "/_link/profile", json={"jitter": jitter}).raise_for_status()
        received = asyncio.run(exchange(proxy.url, seconds=4.0, send_hz=200.0))
        time.sleep(1.5)
        stats = httpx.get(proxy.url + "/_link/stats").json()
    states = [m for _, m in received if m["type"] == "state"]
    assert all(b["seq"] - a["seq"] == 1 for a, b in itertools.pairwise(states))
    records = read_record(record)
    down = check_record(records, "downlink", 500)
    drawn = [r["configured_delay"] for r in down]
    assert min(drawn) < 0.8 and max(drawn) > 1.2  # the jitter is there...
    assert stats["downlink"]["reorderings"] == 0 and stats["downlink"]["early_releases"] == 0  # ...order kept
    realized = stats["downlink"]["realized_delay_s"]
    # p99, not max: one host stall (see check_record) made a single release 21 ms late in a full
    # run; each release's lateness against its own drawn delay is checked there, message by message.
    assert 1.0 < realized["p50"] < 1.3 and realized["p99"] <= 1.3 + TAIL_TOLERANCE_S

    # The same arrivals on a simulated clock with the same profile make the same schedule.
    sim = SimulatedLink(LinkProfile(uplink=1.0, downlink=1.0, jitter=jitter), start=records[0]["arrival"] - 1)
    for r in (r for r in records if r["direction"] == "downlink"):
        sim.send(r["arrival"], "downlink", r["size"], r["kind"])
    sim.advance_to(records[-1]["arrival"] + 5.0)
    replay = sim.released
    real = [r for r in records if r["direction"] == "downlink" and r["release"]]
    assert len(replay) == len(real)
    for (_, e), r in zip(replay, real, strict=True):
        assert e.configured_delay == pytest.approx(r["configured_delay"], abs=1e-12)
    # A host stall makes a real release late and those queued behind it too (never before the
    # one ahead): judged like check_record's lateness, against the simulated schedule.
    assert_mostly_on_time([r["release"] - t_sim for (t_sim, _), r in zip(replay, real, strict=True)])


def test_http_round_trip_takes_uplink_plus_downlink_and_control_is_immediate(
    fast_server: ServiceProcess,
) -> None:
    with (
        running_proxy(fast_server.url, "--uplink", "0.6", "--downlink", "0.9") as proxy,
        # Made before the clock starts: a new httpx client costs ~43 ms (its SSL context), which
        # `httpx.get` paid inside each timing, nearly the whole 50 ms allowed (a CI run failed
        # at +55.6 ms). What is timed is the link: +4-8 ms over the 1.5 s here.
        httpx.Client(base_url=proxy.url) as client,
    ):
        # Each round trip is never short of uplink + downlink and within a host stall of it (one
        # took 1.91 s with a core hogged and two tests at once); the best of three is within 50 ms.
        elapsed = []
        for _ in range(3):
            t0 = time.monotonic()
            response = client.get("/api/health")
            elapsed.append(time.monotonic() - t0)
            assert response.status_code == 200 and response.json()["status"] == "ok"
        # The best of three within 0.2 s of 1.5 s: a few ms idle; 0.115 s for all three in a hogged
        # CI run (this client, the link and the robot all starved). Never early is the link's rule.
        assert all(1.5 <= e <= 1.5 + HOST_STALL_S for e in elapsed) and min(elapsed) <= 1.5 + 0.2, elapsed
        control = []
        for _ in range(3):
            t0 = time.monotonic()
            profile = client.get("/_link/profile").json()
            control.append(time.monotonic() - t0)
        assert min(control) < 0.05 and max(control) < HOST_STALL_S, control
        assert profile["uplink"] == 0.6 and profile["downlink"] == 0.9 and profile["version"] == 1
        posted = httpx.post(proxy.url + "/api/commands", json={"type": "rwe", "duration": 0.1}, timeout=10)
        assert posted.status_code == 202  # bodies and methods pass through
        bad = httpx.post(proxy.url + "/api/commands", json={"type": "rwe", "duration": -1}, timeout=10)
        assert bad.status_code == 422 and "duration" in bad.json()["detail"]


def downlink_states(record: Path, version: int) -> list[dict]:
    """The link's record of each state it carried down under profile `version`, in arrival order."""
    return [
        r
        for r in read_record(record)
        if r["direction"] == "downlink" and r["kind"] == "ws_state" and r["profile_version"] == version
    ]


def test_blackout_hold_and_drop_live(fast_server: ServiceProcess, tmp_path: Path) -> None:
    """A second's loss of signal, held then dropped, judged in the link's own record of each
    state's arrival (its clock): not as 200 messages at 200/s, since a starved robot sends fewer
    in a second of the wall clock (146 in a fresh-clone CI run with a core hogged, 207 in
    another), its telemetry following its sim time. The window's exact edges are held on a
    simulated clock in test_delay_line.py."""
    record = tmp_path / "link.jsonl"
    with running_proxy(fast_server.url, "--downlink", "0.1", "--record", str(record)) as proxy:
        hold = {"blackouts": [{"start": 1.0, "duration": 1.0, "mode": "hold"}]}
        hold_version = httpx.put(proxy.url + "/_link/profile", json=hold).raise_for_status().json()["version"]
        t_put = time.time()
        received = asyncio.run(exchange(proxy.url, seconds=3.5, send_hz=1.0))
        states = [(t - t_put, m) for t, m in received if m["type"] == "state"]
        assert all(b["seq"] - a["seq"] == 1 for (_, a), (_, b) in itertools.pairwise(states))  # all, in order
        # Arrival times are this process's: a host stall makes them late (never early), so the
        # window starts a stall after the last message before the loss of signal is due (1.1 s;
        # one arrived at 1.17 s with a core hogged, and at 1.45 s in a fresh-clone CI run with a
        # core hogged and three test workers) and the held burst may come a stall late. The whole
        # window, to its first instant, is judged below on the link's own record.
        in_window = [t for t, _ in states if 1.1 + HOST_STALL_S < t < 2.05]
        assert not in_window  # nothing arrives during the loss of signal...
        burst = [t for t, _ in states if 2.05 <= t < 2.2 + HOST_STALL_S / 2]

        drop = {"blackouts": [{"start": 0.5, "duration": 1.0, "mode": "drop"}]}
        drop_version = httpx.put(proxy.url + "/_link/profile", json=drop).raise_for_status().json()["version"]
        before = httpx.get(proxy.url + "/_link/stats").json()["downlink"]["dropped"]["blackout"]
        received = asyncio.run(exchange(proxy.url, seconds=2.5, send_hz=1.0))
        dropped = httpx.get(proxy.url + "/_link/stats").json()["downlink"]["dropped"]["blackout"] - before

    # Hold: every state that reached the link in the window waited for its end, and no other.
    down = downlink_states(record, hold_version)
    held = [r for r in down if "blackout" in r["why"]]  # the record names only the waits it had
    window_end = held[0]["arrival"] + held[0]["why"]["blackout"]
    assert all(r["arrival"] + r["why"]["blackout"] == pytest.approx(window_end, abs=1e-6) for r in held)
    assert all(r["release"] >= window_end for r in held)
    unheld = [r["arrival"] for r in down if "blackout" not in r["why"]]
    assert not [t for t in unheld if window_end - 1.0 <= t < window_end]
    assert 1.0 - HOST_STALL_S / 2 <= held[-1]["arrival"] - held[0]["arrival"] <= 1.0  # a second of them
    assert len(burst) >= len(held)  # ...then the held second of telemetry arrives at once

    # Drop: whole messages lost in one stretch, as many as the link counted; every state that
    # reached it in the window dropped and none outside, so the dropped arrivals span at most
    # 1 s and the delivered states either side of them at least 1 s apart.
    states = [m for _, m in received if m["type"] == "state"]
    gaps = [b["seq"] - a["seq"] - 1 for a, b in itertools.pairwise(states) if b["seq"] - a["seq"] > 1]
    assert len(gaps) == 1 and dropped == pytest.approx(gaps[0], abs=3)
    down = downlink_states(record, drop_version)
    lost = [r["arrival"] for r in down if r["drop_reason"] == "blackout"]
    assert len(lost) == dropped and lost == sorted(lost)
    kept_before = max(r["arrival"] for r in down if r["release"] is not None and r["arrival"] < lost[0])
    kept_after = min(r["arrival"] for r in down if r["release"] is not None and r["arrival"] > lost[-1])
    assert lost[-1] - lost[0] <= 1.0 <= kept_after - kept_before, (kept_before, lost[0], lost[-1], kept_after)


def test_profile_change_mid_stream_is_versioned(fast_server: ServiceProcess, tmp_path: Path) -> None:
    record = tmp_path / "link.jsonl"
    with running_proxy(fast_server.url, "--downlink", "1.0", "--record", str(record)) as proxy:

        async def run() -> None:
            async with websockets.connect(ws(proxy.url), ping_interval=None, max_queue=None) as conn:
                end = time.monotonic() + 4.0
                changed = False
                while time.monotonic() < end:
                    with contextlib.suppress(TimeoutError):
                        await asyncio.wait_for(conn.recv(), 0.5)
                    if not changed and time.monotonic() > end - 2.5:
                        async with httpx.AsyncClient() as client:
                            r = await client.put(proxy.url + "/_link/profile", json={"downlink": 0.2})
                            assert r.json()["version"] == 2
                        changed = True

        asyncio.run(run())
        time.sleep(1.2)
    rows = [
        r for r in read_record(record) if r["direction"] == "downlink" and r["kind"] in ("ws", "ws_state")
    ]
    v1 = [r for r in rows if r["profile_version"] == 1]
    v2 = [r for r in rows if r["profile_version"] == 2]
    assert v1 and v2
    assert all(r["configured_delay"] == pytest.approx(1.0) for r in v1)
    assert all(r["configured_delay"] == pytest.approx(0.2) for r in v2)
    assert min(r["release"] for r in v2) >= max(r["release"] for r in v1)  # no overtaking
    assert [r["seq"] for r in rows] == sorted(r["seq"] for r in rows)


def test_upstream_restart_gives_502_then_recovers(tmp_path: Path) -> None:
    with running_server("--scene", "free_space") as first:
        port = first.port
        with running_proxy(first.url) as proxy:
            assert httpx.get(proxy.url + "/api/health").status_code == 200

            async def closed_by_upstream_stop() -> tuple[int, str]:
                async with websockets.connect(ws(proxy.url), ping_interval=None, max_queue=None) as conn:
                    await conn.recv()
                    first.stop()
                    with pytest.raises(websockets.ConnectionClosed):
                        while True:
                            await asyncio.wait_for(conn.recv(), 10.0)
                    assert conn.close_code is not None
                    return conn.close_code, conn.close_reason or ""

            code, reason = asyncio.run(closed_by_upstream_stop())
            assert code in (1001, 1012) and "upstream" in reason
            down = httpx.get(proxy.url + "/api/health")
            assert down.status_code == 502
            assert f"upstream http://127.0.0.1:{port} unreachable" in down.json()["detail"]
            with running_server("--scene", "free_space", port=port):
                assert httpx.get(proxy.url + "/api/health").status_code == 200

                async def reconnect() -> list[str]:
                    async with websockets.connect(ws(proxy.url), ping_interval=None, max_queue=None) as conn:
                        texts = [await asyncio.wait_for(conn.recv(), 5.0) for _ in range(2)]
                        return [json.loads(t)["type"] for t in texts]

                assert asyncio.run(reconnect()) == ["frames", "state"]  # the task frames whole, then states
