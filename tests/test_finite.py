"""A fault's NaN becomes null the one way (robot_sim/finite.py) in the API and in recordings."""

import json
import math
from pathlib import Path

from mcap.reader import make_reader

from ptwl.recording.writer import SessionRecorder
from robot_sim.finite import finite_json, finite_or_none, finite_vector_or_none

NAN, INF = math.nan, math.inf


def test_a_number_or_a_whole_vector_becomes_null() -> None:
    assert finite_or_none(1.5) == 1.5 and finite_or_none(NAN) is None and finite_or_none(-INF) is None
    assert finite_vector_or_none((1, 2.5, 3)) == [1.0, 2.5, 3.0]
    assert finite_vector_or_none([1.0, NAN, 3.0]) is None  # a wrench with a hole is not one


def test_json_is_made_finite_throughout_and_keeps_what_is_not_a_number() -> None:
    message = {
        "sim_time": NAN,
        "wrench": [0.0, INF, 0.0, 0.0, 0.0, 0.0],
        "port": {"position": [0.1, 0.2, 0.3], "quaternion": [1, 0, 0, 0]},
        "names": ["a", "b"],
        "flags": [True, False],
        "steps": [{"peak_force": NAN, "exit": "fault"}],
        "count": 3,
        "empty": [],
    }
    assert finite_json(message) == {
        "sim_time": None,
        "wrench": None,
        "port": {"position": [0.1, 0.2, 0.3], "quaternion": [1.0, 0.0, 0.0, 0.0]},
        "names": ["a", "b"],
        "flags": [True, False],
        "steps": [{"peak_force": None, "exit": "fault"}],
        "count": 3,
        "empty": [],
    }


def test_a_recorded_fault_reads_back_as_strict_json_with_nulls(tmp_path: Path) -> None:
    path = tmp_path / "fault.mcap"
    recorder = SessionRecorder(path, {"source": "test"})
    step = {"index": 0, "behavior": "ptwl", "exit": "fault", "peak_force": NAN, "final_wrench": [NAN] * 6}
    recorder.step(7, step, 1_000)
    recorder.close()
    with open(path, "rb") as f:
        texts = [m.data.decode() for _, _, m in make_reader(f).iter_messages(topics=["/steps"])]
    assert len(texts) == 1
    decoded = json.loads(texts[0], parse_constant=lambda name: (_ for _ in ()).throw(ValueError(name)))
    assert decoded["peak_force"] is None and decoded["final_wrench"] is None and decoded["command"] == 7


def test_a_published_report_reads_back_with_null_as_nan_never_as_a_measured_zero() -> None:
    """The sweep's real-time operator read a null peak as 0.0 N, the recording's report as NaN;
    one rule now (robot_sim/finite.py: report_from_json)."""
    from robot_sim.finite import report_from_json

    published = finite_json(
        {
            "type": "ptwl",
            "exit": "fault",
            "peak_force": NAN,
            "peak_torque": 0.25,
            "final_wrench": [1.0, NAN, 0.0, 0.0, 0.0, 0.0],
            "final_port": {"position": [0.1, 0.2, 0.3], "quaternion": [1.0, 0.0, 0.0, 0.0]},
            "detail": "unstable",
        }
    )
    back = report_from_json(published, 2.0, 3.5)
    assert back.behavior == "ptwl" and back.exit.value == "fault" and back.detail == "unstable"
    assert math.isnan(back.peak_force) and back.peak_torque == 0.25
    assert len(back.final_wrench) == 6 and all(math.isnan(v) for v in back.final_wrench)
    assert back.final_port.position == (0.1, 0.2, 0.3) and back.duration == 1.5
