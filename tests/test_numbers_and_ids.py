"""Issue 26: numbers that mean what they say, ids that never repeat, /api/state that never 500s.

Each defect found from outside has a test that replays it: GET /api/state after a PTWL with
`gains_frame` naming a task frame (500 on main), a quaternion of 1e200 (stored as [0, 0, 0, 0] on
main), tolerances of 1e308 and a `sent_at` an hour ahead (accepted on main), and ids after the
clock stepped back across a restart (repeated on main)."""

import json
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from pydantic import BaseModel, ValidationError

import server.commands
from ptwl.cli import main as ptwl_main
from ptwl.launcher import ServiceProcess, running_server
from robot_sim.command_book import FutureSentAtError
from robot_sim.command_request import field_errors
from robot_sim.machines.command import StateMachineParams
from robot_sim.params import (
    DitherParams,
    GripperParams,
    MonitorSpec,
    PtwlParams,
    RweParams,
)
from robot_sim.task_frames import unit_quaternion
from server.client import RobotClient
from server.commands import ID_BLOCK, CommandBook, CommandIds
from server.models import ActiveGainsModel, FrameRequest, SceneRequest, TypedPose
from tests.fake_clock import FakeClock

Own = tuple[RobotClient, ServiceProcess, Path]


@pytest.fixture(scope="module")
def own(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Own]:
    """A server of this module's own, with its data dir where the tests can read it."""
    data_dir = tmp_path_factory.mktemp("data")
    with (
        running_server("--scene", "free_space", "--data-dir", str(data_dir)) as srv,
        RobotClient(srv.url) as robot,
    ):
        yield robot, srv, data_dir


# --------------------------------------------------------------------- defect 4: gains_frame


def test_state_answers_after_a_ptwl_with_gains_in_a_task_frame(
    robot: RobotClient, server: ServiceProcess
) -> None:
    """The reported sequence: on main the second request answered 500, and kept answering 500
    after a scene reset, so RobotClient.state() failed too."""
    robot.reset_scene("surface")
    medium = robot.presets()["medium"]
    with httpx.Client(base_url=server.url) as http:
        body = {"type": "ptwl", "gains_frame": "plate_normal", "preset": "medium", "duration": 0.5}
        accepted = http.post("/api/commands", json=body)
        assert accepted.status_code == 202, accepted.text
        robot.wait(accepted.json()["id"], timeout=15)
        answer = next_state(http)
        assert answer.status_code == 200, answer.text
        gains = answer.json()["gains"]
        assert gains == {
            "stiffness": medium["stiffness"],
            "damping": medium["damping"],
            "frame": "plate_normal",
        }
        assert robot.state().gains == ActiveGainsModel(**gains)

        # Reset to the same scene: its plate_normal is back, and the gains stay in it.
        robot.reset_scene("surface")
        assert http.get("/api/state").json()["gains"]["frame"] == "plate_normal"
        # A scene without that frame: the diagonal stays, in base axes (the name would be a frame
        # GET /api/frames does not list).
        robot.reset_scene("free_space")
        answer = http.get("/api/state")
        assert answer.status_code == 200, answer.text
        assert answer.json()["gains"] == {**gains, "frame": "base"}
        assert [f["name"] for f in http.get("/api/frames").json()] == []
    assert robot.state().scene == "free_space"


def test_an_operator_frame_gone_with_a_reset_leaves_the_gains_in_base_axes(robot: RobotClient) -> None:
    robot.add_frame("tilted", {"position": [0.4, 0.0, 0.3], "quaternion": [0.9, 0.3, 0.0, 0.0]})
    robot.run("ptwl", gains_frame="tilted", preset="soft", duration=0.2, timeout=15)
    assert gains_frame(robot, fresh=True) == "tilted"
    robot.reset_scene("free_space")  # drops operators' frames
    assert gains_frame(robot) == "base"


def next_state(http: httpx.Client) -> httpx.Response:
    """GET /api/state once the robot has published a state since this call (it answers the
    latest telemetry state, up to one period old: from before a command that just ended)."""
    first = http.get("/api/state")
    answer = first
    while answer.status_code == 200 and answer.json()["sim_time"] == first.json()["sim_time"]:
        answer = http.get("/api/state")
    return answer


def gains_frame(robot: RobotClient, fresh: bool = False) -> str:
    with httpx.Client(base_url=robot.base_url) as http:
        state = next_state(http).json() if fresh else robot.state().model_dump()
    assert state["gains"] is not None
    return str(state["gains"]["frame"])


def test_the_state_model_takes_every_frame_name_a_command_can_give() -> None:
    """The model and what the robot reports agree: any name gains_frame passes is a valid
    state; on main only base and tool were."""
    for name in ("base", "tool", "plate_normal", "A" + "b" * 31):
        PtwlParams(gains_frame=name)  # a command may name it
        assert ActiveGainsModel(stiffness=[1.0] * 6, damping=[1.0] * 6, frame=name).frame == name
    with pytest.raises(ValidationError):
        ActiveGainsModel(stiffness=[1.0] * 6, damping=[1.0] * 6, frame="9lives")


# --------------------------------------------------------------------- defect 9: quaternions


@pytest.mark.parametrize(
    ("quaternion", "unit"),
    [
        ([1e200, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]),  # main: [0, 0, 0, 0] (the square overflows)
        ([1e308, 0.0, 1e308, 0.0], [2**-0.5, 0.0, 2**-0.5, 0.0]),
        ([-1e-300, 0.0, 0.0, 1e-300], [-(2**-0.5), 0.0, 0.0, 2**-0.5]),  # main: the identity
        ([5e-324, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]),  # the smallest double
        ([2.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]),
    ],
)
def test_quaternions_of_any_size_normalize_without_overflow(
    quaternion: list[float], unit: list[float]
) -> None:
    np.testing.assert_allclose(unit_quaternion(quaternion), unit, rtol=0, atol=1e-15)
    typed = FrameRequest.model_validate(
        {"name": "q", "pose": {"position": [0.4, 0, 0.3], "quaternion": quaternion}}
    )
    assert not isinstance(typed.pose, str)
    np.testing.assert_allclose(typed.pose.quaternion, unit, rtol=0, atol=1e-15)


@pytest.mark.parametrize("quaternion", [[0.0, 0.0, 0.0, 0.0], [math.nan, 0.0, 0.0, 1.0], [math.inf, 0, 0, 0]])
def test_a_quaternion_without_a_direction_is_refused(quaternion: list[float]) -> None:
    with pytest.raises(ValueError, match="quaternion must be"):
        unit_quaternion(quaternion)


def test_an_overflowing_quaternion_makes_a_frame_moves_go_along(
    robot: RobotClient, server: ServiceProcess
) -> None:
    """The reported attack: 201 with [0, 0, 0, 0], then a 1 cm PTWL in that frame ended
    goal_reached without moving (its axes were all zero)."""
    with httpx.Client(base_url=server.url) as http:
        body = {"name": "qbig", "pose": {"position": [0.4, 0, 0.3], "quaternion": [1e200, 0, 0, 0]}}
        made = http.post("/api/frames", json=body)
        assert made.status_code == 201, made.text
        assert made.json()["pose"]["quaternion"] == [1.0, 0.0, 0.0, 0.0]
        before = np.asarray(robot.state().port.position)
        done = robot.run("ptwl", translation=[0.0, 0.0, 0.01], frame="qbig", duration=0.5, timeout=15)
        assert done.exit == "goal_reached"
        moved = np.asarray(robot.state().port.position) - before
        np.testing.assert_allclose(moved, [0.0, 0.0, 0.01], atol=0.0025)  # the frame's z is base z

        zero = {"name": "qzero", "pose": {"position": [0.4, 0, 0.3], "quaternion": [0, 0, 0, 0]}}
        refused = http.post("/api/frames", json=zero)
        assert refused.status_code == 422
        fields = {e["field"]: e["message"] for e in refused.json()["errors"]}
        assert "non-zero" in fields["pose.quaternion"], fields


# ------------------------------------------------ defect 9: every float of a request is bounded

HUGE = 1e308
# Fields a huge value is right for: scale-free directions and quaternions (normalized; checked
# above and in test_server_bad_input.py).
SCALE_FREE = {"axis", "normal", "quaternion"}
MINIMAL: dict[type[BaseModel], dict[str, Any]] = {
    PtwlParams: {"type": "ptwl"},
    RweParams: {"type": "rwe"},
    DitherParams: {"type": "dither"},
    GripperParams: {"type": "gripper", "action": "close"},
    StateMachineParams: {"type": "state_machine", "task": "sleeve_on_peg"},
    MonitorSpec: {},
    SceneRequest: {"name": "free_space"},
    TypedPose: {"position": [0.4, 0.0, 0.3], "quaternion": [1.0, 0.0, 0.0, 0.0]},  # in FrameRequest
}
# What a field needs beside it to be judged on its own (a valid value for its partner).
GAINS = [1000.0, 1000.0, 1000.0, 50.0, 50.0, 50.0]
COMPANIONS: dict[str, dict[str, Any]] = {
    "max_age": {"sent_at": 0.0},
    "stiffness": {"damping": GAINS},
    "damping": {"stiffness": GAINS},
}


def validate(model: type[BaseModel], body: dict[str, Any]) -> Any:
    """The request as the API validates it: a typed pose inside a frame request."""
    if model is TypedPose:
        pose = FrameRequest.model_validate({"name": "f", "pose": body}).pose
        assert not isinstance(pose, str)
        return pose
    return model.model_validate(body)


def float_fields(model: type[BaseModel]) -> dict[str, int]:
    """{field: 0 for a number, n for an array of n numbers} from the model's JSON schema, so a
    float field added later is checked without editing this test."""
    found = {}
    for name, prop in model.model_json_schema()["properties"].items():
        for option in prop.get("anyOf", [prop]):
            if option.get("type") == "number":
                found[name] = 0
            elif option.get("type") == "array" and option.get("items", {}).get("type") == "number":
                found[name] = option.get("minItems") or 1
    return found


CASES = [(model, field, n) for model in MINIMAL for field, n in float_fields(model).items()]


@pytest.mark.parametrize(("model", "field", "n"), CASES, ids=[f"{m.__name__}.{f}" for m, f, _ in CASES])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_every_float_field_of_a_request_is_bounded(
    model: type[BaseModel], field: str, n: int, sign: float
) -> None:
    """1e308 (or -1e308) in any float field is refused with a 422 that names the field and the
    range, unless the field is scale-free. On main position_tolerance, orientation_tolerance,
    force_residual, torque_residual, valid_until_sim_time and sent_at took 1e308."""
    value: Any = sign * HUGE if n == 0 else [sign * HUGE] * n
    body = {**MINIMAL[model], field: value, **COMPANIONS.get(field, {})}
    if field in SCALE_FREE:
        got = getattr(validate(model, body), field)
        assert all(math.isfinite(v) for v in got) and math.hypot(*got) == pytest.approx(1.0)
        return
    if field == "sent_at" and sign > 0:  # its bound moves with the robot's clock: the book's
        with pytest.raises(FutureSentAtError, match=r"must be in \[0, now \+ 5\] s"):
            CommandBook(8, 16).submit(validate(model, body))
        return
    with pytest.raises(ValidationError) as refused:
        validate(model, body)
    items = field_errors([dict(e) for e in refused.value.errors()])
    named = [i for i in items if field in i["field"] or field in i["message"]]
    assert named, items
    assert any(
        word in i["message"] for i in named for word in ("must be in", "must be within", "must be <=", "in [")
    ), named


def test_the_bounded_fields_include_the_reported_ones() -> None:
    """Guard for the test above: the schema walk finds the fields the report named."""
    assert {"position_tolerance", "orientation_tolerance", "translation", "stiffness"} <= set(
        float_fields(PtwlParams)
    )
    assert {"force_residual", "torque_residual", "valid_until_sim_time"} <= set(float_fields(RweParams))


def test_a_huge_tolerance_is_refused_through_the_api(own: Own) -> None:
    _, srv, _ = own
    answer = httpx.post(srv.url + "/api/commands", json={"type": "ptwl", "position_tolerance": 1e308})
    assert answer.status_code == 422
    assert answer.json()["detail"] == "position_tolerance: must be in (0, 1] m, got 1e+308"


def test_a_dither_axis_of_1e308_is_a_direction_not_zero() -> None:
    """hypot(1e308, 1e308) is inf: on main the axis came out [0, 0, 0]."""
    axis = DitherParams(axis=[HUGE, 0.0, HUGE]).axis
    assert axis == pytest.approx([2**-0.5, 0.0, 2**-0.5], abs=1e-15)


# --------------------------------------------------------------------- defect 10: sent_at


def test_a_sent_at_ahead_of_the_robot_by_more_than_the_skew_is_refused() -> None:
    clock = FakeClock(1_700_000_000.0)
    book = CommandBook(8, 16, wall_clock_s=clock)
    with pytest.raises(FutureSentAtError) as refused:
        book.submit(RweParams(sent_at=clock.now + 3600.0, max_age=1.0))  # the reported attack
    message = str(refused.value)
    assert refused.value.field == "sent_at"
    assert "must be in [0, now + 5] s" in message and "got 1.7e+09" in message, message
    with pytest.raises(FutureSentAtError):
        book.submit(RweParams(sent_at=1e308))
    with pytest.raises(FutureSentAtError):
        book.submit(RweParams(sent_at=clock.now + 5.001))
    edge = book.submit(RweParams(sent_at=clock.now + 5.0, max_age=1.0))  # at the skew: accepted
    assert book.queued_count() == 1 and book.get(edge.id) is not None
    # ...and it still expires by its age on the robot's clock: 1 s after the sender's stamp.
    clock.now += 6.5
    with book.held() as held:
        held.start_next(lambda record: None, 0.0)
    status = book.get(edge.id)
    assert status is not None and status.exit == "expired"


def test_the_skew_is_the_servers_setting() -> None:
    clock = FakeClock(1000.0)
    book = CommandBook(8, 16, sent_at_skew_s=60.0, wall_clock_s=clock)
    book.submit(RweParams(sent_at=1059.0))
    with pytest.raises(FutureSentAtError, match=r"now \+ 60\] s"):
        book.submit(RweParams(sent_at=1061.0))


@pytest.mark.parametrize("skew", ["-1", "nan", "3601"])
def test_a_bad_skew_setting_stops_the_server_with_one_line(
    skew: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert ptwl_main(["serve", "--port", "0", "--sent-at-skew", skew]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--sent-at-skew must be in [0, 3600] s" in err, err


def test_a_future_sent_at_gets_a_422_naming_it(own: Own) -> None:
    robot, srv, _ = own
    queued_before = robot.health().queued
    body = {"type": "rwe", "sent_at": time.time() + 3600.0, "max_age": 1}
    answer = httpx.post(srv.url + "/api/commands", json=body)
    assert answer.status_code == 422, answer.text  # main: 202, and it ran
    (error,) = answer.json()["errors"]
    assert error["field"] == "sent_at" and "must be in [0, now + 5] s" in error["message"]
    assert robot.health().queued == queued_before  # nothing was queued


# --------------------------------------------------------------------- defect 12: ids


class FakeMicros:
    def __init__(self, now_us: int) -> None:
        self.now_us = now_us

    def __call__(self) -> int:
        return self.now_us


def test_ids_grow_across_a_restart_with_the_clock_stepped_back(tmp_path: Path) -> None:
    """The reported case: the clock 2 us back across a restart. On main the first run's ids
    started at its boot microsecond and the second's at its own, 2 us earlier: repeats."""
    state = tmp_path / "command-ids.json"
    clock = FakeMicros(1_700_000_000_000_000)
    first_run = CommandBook(8, 16, ids=CommandIds(state, clock))
    old = [first_run.submit(RweParams()).id for _ in range(3)]
    assert old == [clock.now_us, clock.now_us + 1, clock.now_us + 2]
    clock.now_us -= 2  # restart; NTP stepped the clock back
    second_run = CommandBook(8, 16, ids=CommandIds(state, clock))
    new = [second_run.submit(RweParams()).id for _ in range(3)]
    assert min(new) > max(old)
    assert new == sorted(new) and len(set(old + new)) == 6


def test_without_a_record_the_clock_alone_repeats_ids() -> None:
    """Control for the test above: it is the record that keeps them apart."""
    clock = FakeMicros(5_000_000)
    old = CommandIds(None, clock).take()
    clock.now_us -= 2
    assert CommandIds(None, clock).take() < old + 1


def test_ids_past_a_block_survive_a_crash_and_a_clock_far_back(tmp_path: Path) -> None:
    state = tmp_path / "ids.json"
    clock = FakeMicros(10**15)
    ids = CommandIds(state, clock)
    given = [ids.take() for _ in range(ID_BLOCK + 10)]  # a second block was put on record
    assert given == list(range(10**15, 10**15 + ID_BLOCK + 10))
    assert json.loads(state.read_text())["next_id"] == 10**15 + 2 * ID_BLOCK
    clock.now_us = 10  # no clean shutdown, and the clock reads 1970
    assert CommandIds(state, clock).take() == 10**15 + 2 * ID_BLOCK


def test_two_servers_on_one_data_dir_never_share_an_id(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(server.commands, "ID_BLOCK", 3)
    state = tmp_path / "ids.json"
    clock = FakeMicros(100)
    a, b = CommandIds(state, clock), CommandIds(state, clock)
    taken = [source.take() for _ in range(10) for source in (a, b)]
    assert len(set(taken)) == len(taken)


def test_a_later_clock_still_leads(tmp_path: Path) -> None:
    """Ids stay near the clock: a restart a day later starts at the clock, not at the record."""
    state = tmp_path / "ids.json"
    clock = FakeMicros(10**15)
    CommandIds(state, clock).take()
    clock.now_us += 86_400 * 10**6
    assert CommandIds(state, clock).take() == clock.now_us


@pytest.mark.parametrize("text", ["", "{}", '{"next_id": "7"}', '{"next_id": -1}', "[1]"])
def test_a_damaged_record_stops_the_server_with_one_line(
    tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "command-ids.json").write_text(text)
    with pytest.raises(ValueError, match="not a command id record"):
        CommandIds(tmp_path / "command-ids.json")
    assert ptwl_main(["serve", "--port", "0", "--data-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "command-ids.json: not a command id record" in err, err


def test_an_unwritable_data_dir_stops_the_server_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocked = tmp_path / "file"
    blocked.write_text("")
    assert ptwl_main(["serve", "--port", "0", "--data-dir", str(blocked / "sub")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--data-dir" in err and "cannot be created" in err, err


def test_the_server_keeps_its_ids_on_record_in_its_data_dir(own: Own) -> None:
    robot, _, data_dir = own
    accepted = robot.rwe(duration=0.05)
    record = json.loads((data_dir / "command-ids.json").read_text())
    assert accepted.id < record["next_id"] <= accepted.id + ID_BLOCK
    assert robot.state().instance == accepted.instance


def test_an_id_record_that_cannot_be_moved_up_mid_run_refuses_the_command_with_a_named_503(
    tmp_path: Path,
) -> None:
    """A full disk or a record replaced under a running robot: no id can be sure never to repeat,
    so the command is refused (503 naming the record), nothing is queued, and the robot runs on."""
    from fastapi import FastAPI
    from fastapi.testclient import TestClient

    from server.commands import IdRecordError
    from server.errors import install_error_handlers

    record = tmp_path / "command-ids.json"
    ids = CommandIds(record, clock_us=lambda: 1)
    for _ in range(ID_BLOCK):  # the block on record, given out
        ids.take()
    book = CommandBook(8, 16, ids=ids)
    record.unlink()
    record.mkdir()  # the next block cannot be read or written
    with pytest.raises(IdRecordError, match=f"command ids cannot be put on record in {record}"):
        book.submit(RweParams())
    assert book.recent(16) == []  # nothing queued

    app = FastAPI()
    install_error_handlers(app)

    @app.post("/c")
    def submit() -> None:
        book.submit(RweParams())

    answer = TestClient(app).post("/c")
    assert answer.status_code == 503 and str(record) in answer.json()["detail"]
