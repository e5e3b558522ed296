"""One command lifecycle (issue 28): the same script of commands run through the real server in
real time and through the sweeps' virtual robot in virtual time ends with the same records:
statuses, exits, details (their numbers aside: times differ) and order. Both run the rule of
robot_sim/command_book.py; a second copy of any part of it (expiry, STOP, the cap) would show
here as a difference."""

import functools
import math
import re
import time
from collections.abc import Callable
from typing import Any

import httpx

from ptwl.experiments.sweep.robot import Post, VirtualRobot
from ptwl.launcher import running_server
from robot_sim.command_book import CommandRecord, QueueFullError
from robot_sim.command_request import COMMAND
from robot_sim.executor import CommandParams
from robot_sim.limits import COMMAND_QUEUE_MAX
from robot_sim.task_frames import FrameInUseError
from server.commands import status_model
from tests.helpers import wait_until

SCENE = "free_space"
# (what to send, as the API's JSON; whether it carries sent_at and a max_age of 0.3 s)
MOVE = {"type": "ptwl", "translation": [0.0, 0.0, 0.01], "duration": 0.5}
LONG = {"type": "rwe", "duration": 4.0}
STALE_AFTER_S = 0.3  # the second command waits behind the first's 0.5 s: expired at its start

Row = tuple[str, str, str | None, str]


def normalized(detail: str) -> str:
    return re.sub(r"-?\d+(\.\d+)?(e[-+]?\d+)?", "#", detail)


def rows(records: list[dict[str, Any]]) -> list[Row]:
    """(type, status, exit, detail) in the order the commands were sent (ids only grow)."""
    in_order = sorted(records, key=lambda r: r["id"])
    return [(r["type"], r["status"], r["exit"], normalized(r["detail"])) for r in in_order]


class Script:
    """The script, written once against two robots."""

    def __init__(
        self,
        post: Callable[[dict[str, Any]], bool],  # False: refused as the queue was full
        now_unix_s: Callable[[], float],
        wait_until: Callable[[Callable[[], bool]], None],
        statuses: Callable[[], list[tuple[int, str]]],  # (id, status) of every command so far
        stop: Callable[[], None],
        frame: Callable[[str, str], bool],  # ("add" at the tool | "remove", name): done, not refused
        fault: Callable[[], None],  # the physics faults: the scene reloads, its frames with it
    ) -> None:
        self.post, self.now, self.wait_until = post, now_unix_s, wait_until
        self.statuses, self.stop, self.frame, self.fault = statuses, stop, frame, fault

    def run(self) -> int:
        """The script; how many posts the full queue refused."""
        refused = 0
        assert self.post(MOVE)
        assert self.post({**MOVE, "sent_at": self.now(), "max_age": STALE_AFTER_S})
        self.wait_until(lambda: all(s == "done" for _, s in self.statuses()))
        assert self.post(LONG) and self.post(MOVE)
        self.wait_until(lambda: "running" in [s for _, s in self.statuses()])
        self.stop()
        self.wait_until(lambda: all(s == "done" for _, s in self.statuses()))
        assert self.post(LONG)
        self.wait_until(lambda: "running" in [s for _, s in self.statuses()])
        for _ in range(COMMAND_QUEUE_MAX + 1):
            refused += not self.post(MOVE)
        self.stop()
        self.wait_until(lambda: all(s == "done" for _, s in self.statuses()))
        # A frame that vanishes under a queued command: deleting it is refused while a command
        # names it, but a fault reloads the scene (and its frames); the command ends at its start.
        assert self.frame("add", "jig")
        assert self.post(LONG) and self.post({**MOVE, "frame": "jig"})
        assert not self.frame("remove", "jig")
        self.wait_until(lambda: "running" in [s for _, s in self.statuses()])
        self.fault()
        self.wait_until(lambda: all(s == "done" for _, s in self.statuses()))
        return refused


def through_the_server() -> tuple[list[Row], int]:
    with (
        running_server("--scene", SCENE, "--fault-injection") as robot,
        httpx.Client(base_url=robot.url, timeout=10.0) as http,
    ):

        def post(body: dict[str, Any]) -> bool:
            answer = http.post("/api/commands", json=body)
            if answer.status_code == 429:
                return False
            answer.raise_for_status()
            return True

        def statuses() -> list[tuple[int, str]]:
            return [(c["id"], c["status"]) for c in http.get("/api/commands", params={"limit": 1000}).json()]

        def stop() -> None:
            http.post("/api/stop").raise_for_status()

        def frame(action: str, name: str) -> bool:
            if action == "add":
                answer = http.post("/api/frames", json={"name": name, "pose": "tool"})
            else:
                answer = http.delete(f"/api/frames/{name}")
            return answer.is_success

        def fault() -> None:
            http.post("/api/_debug/fault").raise_for_status()

        server_wait = functools.partial(wait_until, timeout_s=30.0)
        refused = Script(post, time.time, server_wait, statuses, stop, frame, fault).run()
        return rows(http.get("/api/commands", params={"limit": 1000}).json()), refused


def through_the_virtual_robot() -> tuple[list[Row], int]:
    robot = VirtualRobot(SCENE, 0)
    tags = iter(range(10**6))

    def post(body: dict[str, Any]) -> bool:
        params: CommandParams = COMMAND.validate_python(body)
        try:
            robot.handle(Post(f"script-{next(tags)}", params))
        except QueueFullError:
            return False
        return True

    def wait_until(done: Callable[[], bool]) -> None:
        while not done():
            assert robot.sim.time < 60.0, "the virtual robot's commands never got there"
            robot.tick()

    def statuses() -> list[tuple[int, str]]:
        return [(r.id, r.status) for r in robot.submitted.values()]

    def frame(action: str, name: str) -> bool:
        try:
            robot.add_frame(name) if action == "add" else robot.remove_frame(name)
        except FrameInUseError:
            return False
        return True

    def fault() -> None:
        robot.sim.data.qvel[0] = math.nan  # as the server's fault hook (server/runner.py)

    refused = Script(post, robot.unix_time_s, wait_until, statuses, robot.stop, frame, fault).run()
    return rows([as_api(r) for r in robot.submitted.values()]), refused


def as_api(record: CommandRecord) -> dict[str, Any]:
    return status_model(record).model_dump()


def test_the_server_and_the_sweeps_virtual_robot_keep_the_same_records() -> None:
    virtual, virtual_refused = through_the_virtual_robot()
    real, real_refused = through_the_server()
    assert virtual_refused == real_refused == 1
    assert len(real) == 2 + 2 + 1 + COMMAND_QUEUE_MAX + 2
    assert virtual == real
    assert [row[2] for row in real[:6]] == ["goal_reached", "expired", *["aborted"] * 4]
    assert real[1][3] == "# s old at its start, over its max_age # s"
    assert real[2][3] == real[4][3] == "stopped"
    assert real[3][3] == real[-3][3] == "dropped by stop"
    assert [row[2] for row in real[-2:]] == ["fault", "aborted"]
    assert real[-1][3] == "its task frame is gone (frame 'jig'): deleted, or the scene was reset"
