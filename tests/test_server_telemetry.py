"""Telemetry: rate with 1 and 10 clients, sequence numbers, sent_at and taken_at, slow clients."""

import asyncio
import itertools
import json
import time

import pytest
import websockets

from ptwl.guard.outbox import EVENT_BACKLOG, GONE, Close, Outbox
from ptwl.launcher import ServiceProcess
from server.telemetry import Broadcaster
from tests.fake_clock import FakeClock

WINDOW_S = 3.0
pytestmark = pytest.mark.usefixtures("no_gc_pauses")  # rates are timed in this process


async def receive_states(url: str, seconds: float) -> list[tuple[float, dict]]:
    """(arrival wall time, message) of state messages over `seconds`, after a 0.5 s warm-up."""
    out: list[tuple[float, dict]] = []
    async with websockets.connect(url, ping_interval=None, max_queue=None) as ws:
        warm_until = time.monotonic() + 0.5
        end = warm_until + seconds
        while time.monotonic() < end:
            message = json.loads(await asyncio.wait_for(ws.recv(), 2.0))
            if message["type"] == "state" and time.monotonic() >= warm_until:
                out.append((time.time(), message))
    return out


def ws_url(server: ServiceProcess) -> str:
    return server.url.replace("http://", "ws://") + "/api/telemetry"


@pytest.mark.parametrize("clients", [1, 10])
def test_rate_within_10_percent_and_sequence_increments_by_one(server: ServiceProcess, clients: int) -> None:
    async def main() -> list[list[tuple[float, dict]]]:
        return await asyncio.gather(*(receive_states(ws_url(server), WINDOW_S) for _ in range(clients)))

    for states in asyncio.run(main()):
        arrivals = [t for t, _ in states]
        rate = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0])
        assert rate == pytest.approx(50.0, rel=0.10)
        seqs = [m["seq"] for _, m in states]
        assert all(b - a == 1 for a, b in itertools.pairwise(seqs))
        sim_times = [m["sim_time"] for _, m in states]
        assert all(b > a for a, b in itertools.pairwise(sim_times))
        # sent_at is the server's wall clock as the message left: ~now on loopback. With 10
        # clients parsing in this one Python process the tail is the test's, so: the median.
        ages = sorted(t - m["sent_at"] for t, m in states)
        assert ages[0] > -0.01 and ages[len(ages) // 2] < 0.01 and ages[-1] < 0.5
        first = states[0][1]
        assert {"port", "attractor", "wrench", "joint_positions", "active_command", "scene"} <= set(first)
        # taken_at is the wall clock at sim_time (the simulation thread's stamp): it never comes
        # after sent_at, and it advances with sim time (the robot runs paced to the wall clock).
        waits = sorted(m["sent_at"] - m["taken_at"] for _, m in states)  # both the server's clock
        assert waits[0] >= 0.0 and waits[len(waits) // 2] < 0.02 and waits[-1] < 0.5
        span_sim = states[-1][1]["sim_time"] - first["sim_time"]
        span_wall = states[-1][1]["taken_at"] - first["taken_at"]
        assert span_wall == pytest.approx(span_sim, abs=0.02)


def test_a_client_that_stops_reading_slows_neither_the_sim_nor_the_others(server: ServiceProcess) -> None:
    async def main() -> tuple[list[tuple[float, dict]], float]:
        # It cannot read the server's close frame behind what it left unread: no need to wait
        # the default 10 s for it.
        stalled = await websockets.connect(ws_url(server), ping_interval=None, max_queue=1, close_timeout=0.5)
        try:
            await asyncio.sleep(0.2)  # never reads again
            t0, sim0 = time.monotonic(), json.loads(await _health(server))["sim_time"]
            states = await receive_states(ws_url(server), WINDOW_S)
            t1, sim1 = time.monotonic(), json.loads(await _health(server))["sim_time"]
            return states, (sim1 - sim0) / (t1 - t0)
        finally:
            await stalled.close()

    states, sim_rate = asyncio.run(main())
    arrivals = [t for t, _ in states]
    assert (len(arrivals) - 1) / (arrivals[-1] - arrivals[0]) == pytest.approx(50.0, rel=0.10)
    assert sim_rate == pytest.approx(1.0, rel=0.05)


async def _health(server: ServiceProcess) -> str:
    import httpx

    async with httpx.AsyncClient() as client:
        return (await client.get(server.url + "/api/health")).text


def test_a_slow_reader_gets_recent_states_and_is_closed_only_past_the_event_backlog() -> None:
    async def main() -> None:
        clock = FakeClock()
        slow, fast = Outbox(clock=clock), Outbox(clock=clock)
        broadcaster = Broadcaster()
        broadcaster._subs = {slow, fast}  # outboxes on a fake clock
        for seq in range(1000):  # 20 s of states at 50 Hz, read by one client only
            broadcaster.publish(f'{{"type": "state", "seq": {seq}}}')
            await fast.get()
            clock.now += 0.02
        # Kept: the states of the last 2 s (those that waited over 2 s went as newer ones came).
        assert len(slow) == 101 and slow.replaced == 899 and not slow.too_slow
        waiting = [await slow.get() for _ in range(101)]
        assert waiting == [f'{{"type": "state", "seq": {seq}}}' for seq in range(899, 1000)]  # in order
        # A burst put at once (the link after a hold blackout) is kept whole, events in place.
        for seq in range(500):
            broadcaster.publish(f'{{"type": "state", "seq": {seq}}}')
            if seq == 250:
                broadcaster.publish('{"type": "command", "id": 1}')
        got = [await slow.get() for _ in range(501)]
        assert got[251] == '{"type": "command", "id": 1}' and got[-1] == '{"type": "state", "seq": 499}'
        assert slow.replaced == 899  # nothing of the burst dropped
        for i in range(EVENT_BACKLOG + 1):
            broadcaster.publish(f'{{"type": "command", "id": {i}}}')
            if i < EVENT_BACKLOG:
                assert not slow.too_slow
            while len(fast):
                await fast.get()  # keeps up
        assert slow.too_slow and not fast.too_slow
        assert len(slow) == 1 and await slow.get() == Close(
            1013, f"client too slow: fell {EVENT_BACKLOG} events behind"
        )
        broadcaster.publish('{"type": "command", "id": -1}')
        assert len(slow) == 0  # nothing more is kept for it
        slow.client_gone()
        assert await slow.get() == GONE  # and a sender waiting on it wakes

    asyncio.run(main())
