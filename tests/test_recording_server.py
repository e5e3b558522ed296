"""`ptwl serve --record` and `ptwl proxy --record *.mcap` on real processes: the file holds what
the robot sent (compared with a client that listened), a SIGTERM finishes the file, a kill -9
leaves it readable up to its last chunk (< 1 s lost), and the link's file holds each message's
delay."""

import asyncio
import json
import signal
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import websockets

from ptwl.cli import main as ptwl_main
from ptwl.launcher import ServiceProcess, start
from ptwl.recording.reader import Recording, read
from ptwl.recording.report import report_json
from ptwl.up import _record_args, link_record
from server.client import RobotClient

ONE_WAY_S = 0.1
LISTEN_S = 2.5
KILL_AFTER_S = 3.0


def _ws(url: str) -> str:
    return url.replace("http://", "ws://") + "/api/telemetry"


async def _listen(url: str, seconds: float) -> list[dict]:
    out: list[dict] = []
    async with websockets.connect(_ws(url), ping_interval=None, max_queue=None) as ws:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            out.append(json.loads(await asyncio.wait_for(ws.recv(), 2.0)))
    return out


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Robot A (recorded, through a recorded link, stopped by SIGTERM) and robot B (recorded,
    killed with SIGKILL), run side by side."""
    tmp = tmp_path_factory.mktemp("rec")
    files = {"a": tmp / "a.mcap", "b": tmp / "b.mcap", "link": tmp / "link.mcap"}
    with ThreadPoolExecutor(1) as pool:  # both at once: each takes ~0.7 s to come up
        a_starting = pool.submit(
            start,
            "serve",
            "--port",
            "0",
            "--scene",
            "free_space",
            "--record",
            str(files["a"]),
            health="/api/health",
        )
        b = start("serve", "--port", "0", "--record", str(files["b"]), health="/api/health")
        b_started = time.time()
        a = a_starting.result()
    link = start(
        "proxy",
        "--upstream",
        a.url,
        "--port",
        "0",
        "--uplink",
        f"{ONE_WAY_S}",
        "--downlink",
        f"{ONE_WAY_S}",
        "--record",
        str(files["link"]),
        health="/_link/profile",
    )
    try:
        with RobotClient(link.url) as robot:
            accepted = robot.command("ptwl", sender="ana at test", translation=[0.0, 0.02, 0.0], duration=0.6)
            heard = asyncio.run(_listen(a.url, LISTEN_S))
            final = robot.wait(accepted.id, timeout=10.0)
            robot.add_frame("bench", {"position": [0.4, 0.1, 0.3], "quaternion": [0.0, 1.0, 0.0, 0.0]})
            robot.reset_scene("surface")  # a new scene: recorded anew, a new trial for the report
            time.sleep(0.5)
        stats = _stats(link)
        time.sleep(max(0.0, b_started + KILL_AFTER_S - time.time()))
        b.process.send_signal(signal.SIGKILL)
        killed_at = time.time()
        b.process.wait(5.0)
    finally:
        link.stop()
        a.stop(signal.SIGTERM)
        b.stop()
    return {
        "a": read(files["a"]),
        "b": read(files["b"]),
        "link": read(files["link"]),
        "heard": heard,
        "id": accepted.id,
        "final": final,
        "stats": stats,
        "killed_at": killed_at,
        "b_started": b_started,
    }


def _stats(link: ServiceProcess) -> dict:
    import httpx

    return httpx.get(link.url + "/_link/stats", timeout=5.0).json()


def test_sigterm_finishes_the_file_and_it_holds_every_state_the_robot_sent(session: dict) -> None:
    rec: Recording = session["a"]
    assert rec.complete and rec.problem == ""
    assert rec.metadata["ptwl"]["source"] == "ptwl serve" and rec.metadata["ptwl"]["scene"] == "free_space"
    telemetry = rec.values("/ptwl/telemetry")
    seqs = [m["seq"] for m in telemetry]
    assert seqs == list(range(1, len(seqs) + 1))  # from the first, none missing, in order
    recorded = {m["seq"]: m for m in telemetry}
    heard = [m for m in session["heard"] if m["type"] == "state"]
    # 50 states a second of sim time; a loaded machine's sim falls behind and drops its backlog
    # (server/pacing.py), so fewer leave per wall second (112 of 125 with three tests at once).
    assert len(heard) >= 0.5 * 50 * LISTEN_S
    for message in heard:  # what a client heard is what was recorded (but the moment it left)
        assert {k: v for k, v in message.items() if k != "sent_at"} == recorded[message["seq"]]
    scenes = [g["scene"] for g in rec.values("/ptwl/geometry")]  # each load: placed on /tf, drawn on /scene
    assert scenes == ["free_space", "surface"]
    loads = len(scenes)
    first_state_of = {m.value["scene"]: m.log_time_ns for m in reversed(rec.on("/ptwl/telemetry"))}
    assert [m.log_time_ns for m in rec.on("/ptwl/geometry")][1] <= first_state_of[
        "surface"
    ]  # drawn before moved
    placings = sum(1 for frames in rec.values("/ptwl/frames") if frames["frames"])  # task frames, on /tf
    extra = {"/tf": loads + placings, "/scene": loads}
    for topic in ("/tf", "/scene", "/port", "/attractor", "/joint_states", "/wrench", "/task"):
        assert len(rec.on(topic)) == len(telemetry) + extra.get(topic, 0), topic
        times = [m.log_time_ns for m in rec.on(topic)]
        assert times == sorted(times)
    last_port = rec.values("/port")[-1].pose.position
    assert [last_port.x, last_port.y, last_port.z] == telemetry[-1]["port"]["position"]
    [trial] = report_json(rec)  # one trial: the surface scene ran nothing
    assert trial["scene"] == "free_space" and trial["ptwl"]["goal_reached"] == 1 and trial["behaviors"] == 1


def test_each_command_event_and_step_with_its_sender(session: dict) -> None:
    rec: Recording = session["a"]
    events = [e for e in rec.values("/commands") if e["id"] == session["id"]]
    assert [e["status"] for e in events] == ["queued", "running", "done"]
    assert {e["sender"] for e in events} == {"ana at test"}
    assert events[0]["params"]["translation"] == [0.0, 0.02, 0.0] and events[0]["params"]["duration"] == 0.6
    done = events[-1]
    final = session["final"]
    assert done["exit"] == final.exit == "goal_reached"
    assert done["peak_force"] == final.peak_force and done["ended_at"] == final.ended_at
    steps = rec.values("/steps")
    assert [(s["command"], s["behavior"], s["exit"]) for s in steps] == [
        (session["id"], "ptwl", "goal_reached")
    ]
    assert steps[0]["ended_at"] - steps[0]["started_at"] == pytest.approx(final.duration, abs=1e-9)
    lines = [m.message for m in rec.values("/log")]
    assert any(line.startswith(f"#{session['id']} ptwl done by ana at test: goal_reached") for line in lines)
    assert len(rec.values("/events")) == 1


def test_kill_9_leaves_the_file_readable_up_to_its_last_chunk(session: dict) -> None:
    rec: Recording = session["b"]
    assert not rec.complete  # never finished: no data-end record
    telemetry = rec.on("/ptwl/telemetry")
    assert [m.value["seq"] for m in telemetry] == list(range(1, len(telemetry) + 1))
    last_ns = telemetry[-1].log_time_ns
    lost_s = session["killed_at"] - last_ns / 1e9
    assert 0.0 <= lost_s < 1.0 + 0.2  # chunks under 1 s, flushed as they close (+ the kill's own lag)
    assert len(telemetry) >= 50 * (session["killed_at"] - session["b_started"] - 1.2) * 0.9


def test_the_link_file_holds_every_message_with_its_delay(session: dict) -> None:
    rec: Recording = session["link"]
    assert rec.complete
    records = rec.values("/link/messages")
    stats = session["stats"]
    for direction in ("uplink", "downlink"):
        mine = [r for r in records if r["direction"] == direction]
        # The stats were read before the proxy stopped; messages released after are recorded too.
        assert len(mine) >= stats[direction]["released"] > 0
        delays = [r["realized_delay"] for r in mine]
        assert min(delays) >= ONE_WAY_S - 1e-6 and sorted(delays)[len(delays) // 2] < ONE_WAY_S + 0.01
        assert all(r["configured_delay"] == pytest.approx(ONE_WAY_S) for r in mine)
    times = [m.log_time_ns for m in rec.on("/link/messages")]
    assert times == sorted(times)


def test_recordings_are_never_overwritten_and_need_the_mcap_suffix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    existing = tmp_path / "kept.mcap"
    existing.write_bytes(b"precious")
    assert ptwl_main(["serve", "--port", "0", "--record", str(existing)]) == 2
    assert "exists" in capsys.readouterr().err
    assert ptwl_main(["up", "--record", str(tmp_path / "new.txt")]) == 2
    assert "must end in .mcap" in capsys.readouterr().err
    assert existing.read_bytes() == b"precious"
    # ptwl up: the link's file beside the robot's; a restarted child records into a new file.
    assert link_record(Path("s.mcap")) == Path("s.link.mcap")
    assert _record_args(Path("s.mcap"), 0) == ("--record", "s.mcap")
    assert _record_args(Path("s.mcap"), 2) == ("--record", "s.restart2.mcap")
    assert _record_args(None, 1) == ()


def test_task_frames_are_recorded_as_announced_and_placed_in_tf(session: dict) -> None:
    """Each `frames` message the robot sent (the scene's load, an operator's new frame, the next
    scene's load) is in the file, in order, and each frame is a transform under frame/<name>."""
    announced = [m.value["frames"] for m in session["a"].on("/ptwl/frames")]
    names = [[f["name"] for f in frames] for frames in announced]
    assert names == [[], ["bench"], ["plate_normal"]]  # free_space has none; a reset drops `bench`
    bench = announced[1][0]
    assert bench["pose"] == {"position": [0.4, 0.1, 0.3], "quaternion": [0.0, 1.0, 0.0, 0.0]}
    assert bench["source"] == "operator"
    tfs = session["a"].values("/tf")
    [placed] = [t for tf in tfs for t in tf.transforms if t.child_frame_id == "frame/bench"]
    assert placed.parent_frame_id == "base"
    t, q = placed.translation, placed.rotation
    assert (t.x, t.y, t.z) == (0.4, 0.1, 0.3) and (q.w, q.x, q.y, q.z) == (0.0, 1.0, 0.0, 0.0)
