"""The MCAP file itself: every channel read back equals what was recorded (counts, first and
last values, monotonic log times), Foxglove's schemas where Foxglove looks for them, chunks
under 1 s of log time, and a file cut anywhere read up to its last whole chunk."""

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader

from ptwl.recording import topics
from ptwl.recording.reader import read
from ptwl.recording.well_known import FORCE_ARROW_M_PER_N
from ptwl.recording.writer import SessionRecorder
from robot_sim.arm import JOINT_NAMES
from robot_sim.geometry import moving_bodies, scene_geometry
from robot_sim.sim import Simulation
from robot_sim.telemetry import frames_message, state_fields

T0_NS = 1_800_000_000_000_000_000  # a Unix time, as a live session's log times are
STATES = 150  # 3 s at 50 Hz
PERIOD_NS = 20_000_000


def _session(path: Path) -> dict[str, Any]:
    """Record a made-up but well-formed session; return what was sent, by topic."""
    sim = Simulation("surface", None)
    moving = moving_bodies(sim.model)
    geometry = {"scene": "surface", **scene_geometry(sim.model, sim.data)}
    out = SessionRecorder(path, {"source": "test"})
    sent: dict[str, Any] = {"states": [], "commands": [], "steps": [], "links": []}
    out.geometry(geometry, T0_NS)
    sent["frames"] = frames_message(sim.frames)
    out.frames(sent["frames"], T0_NS)
    for i in range(STATES):
        state = {"type": "state", "seq": i + 1, **state_fields(sim, moving), "active_command": None}
        # A force that turns and grows, so every arrow differs; one at rest (no arrow).
        angle = 0.05 * i
        magnitude = 0.0 if i == 3 else 0.2 * i
        state["wrench"] = [
            magnitude * math.cos(angle),
            magnitude * math.sin(angle),
            -1.0 * (i % 7),
            0.01,
            0.02,
            0.03,
        ]
        if i == 3:
            state["wrench"][:3] = [0.01, 0.02, -0.03]  # sensor noise at rest: no arrow
        state["sim_time"] = 0.02 * i
        out.state(state, T0_NS + i * PERIOD_NS)
        sent["states"].append(state)
        if i in (10, 11, 100):
            status = {10: "queued", 11: "running", 100: "done"}[i]
            event = {
                "type": "command",
                "id": 7,
                "behavior": "ptwl",
                "status": status,
                "sender": "ana",
                "exit": "goal_reached" if status == "done" else None,
                "params": {"duration": 1.5},
                "peak_force": 3.5 if status == "done" else None,
                "peak_torque": 0.1 if status == "done" else None,
            }
            out.command(event, T0_NS + i * PERIOD_NS + 1)
            sent["commands"].append(event)
        if i == 100:
            step = {
                "index": 0,
                "behavior": "ptwl",
                "why": "",
                "exit": "goal_reached",
                "started_at": 0.22,
                "ended_at": 2.0,
                "peak_force": 3.5,
                "peak_torque": 0.1,
            }
            out.step(7, step, T0_NS + i * PERIOD_NS + 2)
            sent["steps"].append(step)
        link = {
            "seq": i,
            "direction": "downlink",
            "kind": "ws",
            "size": 900,
            "arrival": 0.02 * i,
            "release": 0.02 * i + 1.5,
            "configured_delay": 1.5,
            "realized_delay": 1.5,
            "drop_reason": None,
        }
        out.link(link, T0_NS + i * PERIOD_NS + 3)
        sent["links"].append(link)
    out.close()
    sent["geometry"] = geometry
    return sent


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    path = tmp_path_factory.mktemp("rec") / "session.mcap"
    return path, _session(path)


def test_every_channel_reads_back_as_sent(recorded: tuple[Path, dict[str, Any]]) -> None:
    path, sent = recorded
    rec = read(path)
    assert rec.complete and rec.problem == ""
    assert rec.metadata["ptwl"]["source"] == "test"
    counts = {t.name: len(rec.on(t.name)) for t in topics.ALL}
    assert counts == {
        "/tf": STATES + 2,  # every state, the bodies placed with the geometry, the task frames
        "/port": STATES,
        "/attractor": STATES,
        "/joint_states": STATES,
        "/scene": STATES + 1,  # every state's force arrow, and the geometry
        "/log": 4,  # queued, running, the step, done
        "/events": 1,
        "/wrench": STATES,
        "/task": STATES,
        "/commands": 3,
        "/steps": 1,
        "/ptwl/telemetry": STATES,
        "/ptwl/geometry": 1,
        "/ptwl/frames": 1,
        "/link/messages": STATES,
    }
    for topic in topics.ALL:
        times = [m.log_time_ns for m in rec.on(topic.name)]
        assert times == sorted(times), topic.name
        assert {m.schema for m in rec.on(topic.name)} == {topic.schema}
    states = sent["states"]
    telemetry = rec.values("/ptwl/telemetry")
    assert telemetry[0] == states[0] and telemetry[-1] == states[-1]
    assert rec.values("/commands") == sent["commands"]
    assert (
        rec.values("/link/messages")[0] == sent["links"][0]
        and rec.values("/link/messages")[-1] == sent["links"][-1]
    )
    assert rec.values("/ptwl/geometry") == [sent["geometry"]]
    assert rec.values("/ptwl/frames") == [sent["frames"]]
    assert sent["frames"]["frames"][0]["name"] == "plate_normal"
    [placed] = rec.values("/tf")[1].transforms  # the plate's frame, where the scene put it
    assert placed.child_frame_id == "frame/plate_normal"
    assert placed.translation.z == sent["frames"]["frames"][0]["pose"]["position"][2]
    step = rec.values("/steps")[0]
    assert step == {"command": 7, **sent["steps"][0]}
    first_log = rec.values("/log")[0]
    assert "#7 ptwl queued by ana" in first_log.message
    lines = [line.message for line in rec.values("/log")]
    assert lines[2].startswith("#7 ptwl done by ana: goal_reached, peak 3.5 N")
    assert lines[3] == "#7 step 0 ptwl: goal_reached, peak 3.5 N / 0.10 N m"
    event = rec.values("/events")[0]
    started = event.start_time.seconds * 10**9 + event.start_time.nanos
    assert started == T0_NS + 11 * PERIOD_NS + 1  # from the running event to the done event
    assert {kv.key: kv.value for kv in event.metadata}["exit"] == "goal_reached"


def test_wrench_joints_and_poses_are_plottable_values(recorded: tuple[Path, dict[str, Any]]) -> None:
    path, sent = recorded
    rec = read(path)
    last = sent["states"][-1]
    wrench = rec.values("/wrench")[-1]
    fx, fy, fz = last["wrench"][:3]
    assert (wrench["force"]["x"], wrench["force"]["y"], wrench["force"]["z"]) == (fx, fy, fz)
    assert wrench["force_norm"] == pytest.approx(math.hypot(fx, fy, fz), rel=1e-12)
    joints = rec.values("/joint_states")[-1]
    assert [j.name for j in joints.joints] == list(JOINT_NAMES)
    assert [j.position for j in joints.joints] == pytest.approx(last["joint_positions"], abs=1e-12)
    port = rec.values("/port")[-1]
    assert port.frame_id == topics.BASE_FRAME
    assert [port.pose.position.x, port.pose.position.y, port.pose.position.z] == last["port"]["position"]
    w, x, y, z = last["port"]["quaternion"]
    o = port.pose.orientation
    assert (o.w, o.x, o.y, o.z) == (w, x, y, z)  # Foxglove's order is x y z w; values kept
    tf = rec.values("/tf")[-1]
    children = {t.child_frame_id: t for t in tf.transforms}
    assert {"port", "attractor", *last["bodies"]} == set(children)
    assert children["attractor"].translation.z == last["attractor"]["position"][2]
    assert all(t.parent_frame_id == topics.BASE_FRAME for t in tf.transforms)


def test_force_arrow_points_along_the_force_and_scales_with_it(recorded: tuple[Path, dict[str, Any]]) -> None:
    path, sent = recorded
    updates = read(path).values("/scene")[1:]  # the first draws the geometry
    checked = 0
    for state, update in zip(sent["states"], updates, strict=True):
        force = np.asarray(state["wrench"][:3])
        norm = float(np.linalg.norm(force))
        if norm < 0.05:
            assert [d.id for d in update.deletions] == ["measured_force"] and not update.entities
            continue
        arrow = update.entities[0].arrows[0]
        assert arrow.shaft_length + arrow.head_length == pytest.approx(norm * FORCE_ARROW_M_PER_N, rel=1e-9)
        q = arrow.pose.orientation
        x_axis = _rotate((q.w, q.x, q.y, q.z), (1.0, 0.0, 0.0))
        assert x_axis == pytest.approx(force / norm, abs=1e-9)
        assert [arrow.pose.position.x, arrow.pose.position.y, arrow.pose.position.z] == state["port"][
            "position"
        ]
        checked += 1
    assert checked == STATES - 2  # all but the two at rest (i = 0 and i = 3)


def test_scene_draws_every_geom_on_its_body(recorded: tuple[Path, dict[str, Any]]) -> None:
    path, sent = recorded
    scene = read(path).values("/scene")[0]
    assert [d.type for d in scene.deletions] == [1]  # everything drawn before goes first
    geoms = sent["geometry"]["geoms"]
    by_body = {e.id.removeprefix("body:"): e for e in scene.entities}
    assert set(by_body) == {g["body"] for g in geoms}
    assert {e.frame_id for e in scene.entities} == {
        "base" if g["body"] == "world" else g["body"] for g in geoms
    }
    drawn = sum(len(e.cubes) + len(e.cylinders) + len(e.triangles) for e in scene.entities)
    drawn_spheres = sum(len(e.spheres) for e in scene.entities)
    kinds = [g["type"] for g in geoms]
    assert drawn == sum(k in ("box", "plane", "cylinder", "capsule", "mesh") for k in kinds)
    assert drawn_spheres == kinds.count("sphere") + 2 * kinds.count("capsule")
    box = next(g for g in geoms if g["type"] == "box")
    cube = by_body[box["body"]].cubes[0]
    assert [cube.size.x, cube.size.y, cube.size.z] == pytest.approx([2 * s for s in box["size"]])


def test_chunks_never_span_a_second(recorded: tuple[Path, dict[str, Any]]) -> None:
    path, _ = recorded
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    spans = [c.message_end_time - c.message_start_time for c in summary.chunk_indexes]
    assert len(spans) >= 3  # 3 s of messages
    assert max(spans) < 1_000_000_000


def test_a_file_cut_anywhere_reads_up_to_its_last_whole_chunk(
    recorded: tuple[Path, dict[str, Any]], tmp_path: Path
) -> None:
    path, _ = recorded
    data = path.read_bytes()
    with path.open("rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes  # type: ignore[union-attr]
    whole = read(path)
    cut = tmp_path / "cut.mcap"
    for chunk in chunks:
        end = chunk.chunk_start_offset + chunk.chunk_length
        expected = [m for m in whole.messages if m.log_time_ns <= chunk.message_end_time]
        for into_next in (1, 7, 20, 300):  # mid-way into the next record, wherever the kill fell
            cut.write_bytes(data[: end + into_next])
            rec = read(cut)
            assert not rec.complete and rec.problem
            assert [(m.topic, m.log_time_ns) for m in rec.messages] == [
                (m.topic, m.log_time_ns) for m in expected
            ]
            assert rec.values("/ptwl/telemetry") == [
                m.value for m in expected if m.topic == "/ptwl/telemetry"
            ]


def _rotate(q_wxyz: tuple[float, ...], v: tuple[float, float, float]) -> np.ndarray:
    import mujoco

    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(v), np.asarray(q_wxyz))
    return out


def test_the_recording_docs_document_every_topic_and_schema() -> None:
    readme = (Path(__file__).parent.parent / "docs" / "recording.md").read_text()
    for topic in topics.ALL:
        assert f"`{topic.name}`" in readme and topic.schema.split(".")[1] in readme, topic.name


def test_a_file_that_is_no_recording_is_named_as_such(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from ptwl.cli import main

    bogus = tmp_path / "notes.mcap"
    bogus.write_text("these are my notes, not an MCAP file\n")
    with pytest.raises(ValueError, match="not an MCAP recording"):
        read(bogus)
    assert main(["report", str(bogus)]) == 2
    assert "not an MCAP recording" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "missing.mcap")]) == 2
    assert "no recording" in capsys.readouterr().err
