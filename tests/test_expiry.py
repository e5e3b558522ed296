"""Commands that expire (issue 14): a command whose `max_age` (after the sender's `sent_at`) or
`valid_until_sim_time` has passed when its turn comes ends `expired` without moving the robot."""

import json
import threading
import time
from collections.abc import Iterator

import httpx
import numpy as np
import pytest

from ptwl.launcher import ServiceProcess, running_proxy, running_server
from robot_sim.params import PtwlParams, RweParams
from server.client import RobotClient
from server.commands import CommandBook


def started_by(book: CommandBook, sim_time_s: float) -> list[int]:
    """Start what is due at `sim_time_s`; the ids `start` was called for."""
    calls: list[int] = []
    with book.held() as held:
        held.start_next(lambda record: calls.append(record.id), sim_time_s)  # type: ignore[func-returns-value]
    return calls


def test_valid_until_sim_time_is_judged_at_the_start_on_the_robots_clock() -> None:
    book = CommandBook(8, 16)
    late = book.submit(PtwlParams(valid_until_sim_time=1.0))
    on_time = book.submit(RweParams(valid_until_sim_time=2.0))
    # At sim time 1.5 the first has expired: it ends unstarted and the next starts at once.
    assert started_by(book, 1.5) == [on_time.id]
    expired = book.get(late.id)
    assert expired is not None and expired.status == "done" and expired.exit == "expired"
    assert expired.started_at is None and "past valid_until_sim_time 1 s" in expired.detail
    assert book.running is not None and book.running.id == on_time.id


def test_valid_until_sim_time_equal_is_still_valid() -> None:
    book = CommandBook(8, 16)
    record = book.submit(PtwlParams(valid_until_sim_time=2.0))
    assert started_by(book, 2.0) == [record.id]


def test_max_age_is_the_senders_age_at_the_start() -> None:
    book = CommandBook(8, 16)
    now = time.time()
    stale = book.submit(PtwlParams(sent_at=now - 5.0, max_age=4.0))
    fresh = book.submit(PtwlParams(sent_at=now - 5.0, max_age=6.0))
    assert started_by(book, 0.0) == [fresh.id]
    expired = book.get(stale.id)
    assert expired is not None and expired.exit == "expired" and expired.started_at is None
    assert "over its max_age 4 s" in expired.detail
    # Without max_age, sent_at alone never expires a command.
    assert PtwlParams(sent_at=0.0).expiry_reason(now, 1e9) is None


def test_the_client_stamps_sent_at() -> None:
    sent: list[dict] = []

    def handler(request: httpx.Request) -> httpx.Response:
        sent.append(json.loads(request.content))
        return httpx.Response(202, json={"id": 1, "instance": "x", "status": "queued", "warnings": []})

    client = RobotClient("http://robot.test")
    client._http = httpx.Client(base_url="http://robot.test", transport=httpx.MockTransport(handler))
    before = time.time()
    client.ptwl(max_age=3.0)
    assert before <= sent[0]["sent_at"] <= time.time() and sent[0]["max_age"] == 3.0
    client.ptwl(sent_at=12.5)  # a stamp given is kept
    assert sent[1]["sent_at"] == 12.5


@pytest.fixture(scope="module")
def robot_behind_link() -> Iterator[tuple[ServiceProcess, ServiceProcess]]:
    with running_server("--scene", "free_space") as robot, running_proxy(robot.url) as link:
        yield robot, link


def test_a_command_held_in_a_blackout_past_its_age_expires_without_moving_the_robot(
    robot_behind_link: tuple[ServiceProcess, ServiceProcess],
) -> None:
    """Through the real proxy: a 2 s hold blackout on the uplink. Of two commands sent into it at
    once, the one with max_age 1 s ends `expired` (its 30 mm move never made), the one with
    max_age 10 s runs."""
    robot, link = robot_behind_link
    with RobotClient(robot.url) as direct:
        start = np.array(direct.state().port.position)
    httpx.put(
        link.url + "/_link/profile",
        json={"uplink": 0.0, "downlink": 0.0, "blackouts": [{"start": 0.0, "duration": 2.0, "mode": "hold"}]},
    ).raise_for_status()
    ids: dict[str, int] = {}

    def send(name: str, **params: object) -> None:
        with RobotClient(link.url, timeout=10.0) as client:
            ids[name] = client.ptwl(**params).id

    short = threading.Thread(
        target=send, args=("short",), kwargs={"translation": [0, 0.03, 0], "max_age": 1.0}
    )
    long = threading.Thread(target=send, args=("long",), kwargs={"duration": 0.5, "max_age": 10.0})
    t0 = time.monotonic()
    short.start(), long.start()
    short.join(), long.join()
    held_s = time.monotonic() - t0
    try:
        with RobotClient(robot.url) as direct:
            expired = direct.wait(ids["short"], timeout=5.0)
            ran = direct.wait(ids["long"], timeout=10.0)
    finally:
        httpx.put(link.url + "/_link/profile", json={"blackouts": []}).raise_for_status()
    assert held_s >= 1.9  # the link held both
    assert expired.exit == "expired" and expired.started_at is None
    assert "over its max_age 1 s" in expired.detail
    assert ran.exit == "goal_reached"
    assert ran.final_port is not None
    moved_mm = 1000.0 * np.linalg.norm(np.array(ran.final_port.position) - start)
    assert moved_mm < 1.0  # the 30 mm move was never made
