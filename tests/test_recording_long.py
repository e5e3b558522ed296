"""A long recording is read in bounded memory: `ptwl report` streams it (one chunk and one
trial in memory) and `ptwl replay` keeps an index of it, each in a fresh process whose peak RSS
is measured against the list-of-everything reader on the same file; and both give what that
reader gives: the same trial figures, the same messages at the playhead."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from bench.recording import write_session
from ptwl.recording import topics
from ptwl.recording.reader import Recording, read
from ptwl.recording.replay import timeline as timeline_module
from ptwl.recording.replay.timeline import Timeline
from ptwl.recording.report import report_json

SECONDS = 120  # 6,000 states, ~48,000 messages, 27 MB decompressed
RESET_EVERY_S = 30  # four trials
STREAMED_MB = 30.0  # what streaming may add to the interpreter: a chunk, a trial, the index


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("long") / "session.mcap"
    write_session(path, SECONDS, RESET_EVERY_S)
    return path


@pytest.fixture(scope="module")
def everything(session: Path) -> Recording:
    return read(session)


def _peak_mb(code: str, path: Path) -> float:
    """Peak RSS of a fresh interpreter running `code` with `path` as sys.argv[1] (VmHWM: the
    process's own, not pytest's carried over the exec as ru_maxrss is)."""
    script = (
        f"import sys\nfrom pathlib import Path\n{code}\n"
        "print(open('/proc/self/status').read().split('VmHWM:')[1].split()[0])"
    )
    done = subprocess.run(
        [sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=120, check=True
    )
    return int(done.stdout.strip().splitlines()[-1]) / 1024


def test_report_and_replay_hold_far_less_than_the_file_decoded(session: Path) -> None:
    imports = "import ptwl.cli, ptwl.recording.report, ptwl.recording.replay.timeline"
    baseline = _peak_mb(imports, session)
    report = _peak_mb(f"{imports}\nassert ptwl.cli.main(['report', sys.argv[1]]) == 0", session)
    replay = _peak_mb(f"{imports}\nptwl.recording.replay.timeline.Timeline(Path(sys.argv[1]))", session)
    listed = _peak_mb(f"{imports}\nfrom ptwl.recording.reader import read\nread(Path(sys.argv[1]))", session)
    figures = {"baseline": baseline, "report": report, "replay": replay, "list": listed}
    assert report - baseline < STREAMED_MB, figures
    assert replay - baseline < STREAMED_MB, figures
    assert listed - baseline > 2.5 * STREAMED_MB, figures  # what a list of everything costs here


def test_the_report_is_the_one_the_whole_file_in_memory_gives(session: Path, everything: Recording) -> None:
    streamed = report_json(session)
    assert streamed == report_json(everything)
    assert [t["scene"] for t in streamed] == ["surface"] * 4
    assert [t["behaviors"] for t in streamed] == [2, 1, 2, 1]  # done at 6, 26, 46 ... 106 s
    assert everything.count == len(everything.messages) > 40_000


def test_the_replay_serves_what_the_whole_file_in_memory_holds(
    session: Path, everything: Recording, monkeypatch: pytest.MonkeyPatch
) -> None:
    timeline = Timeline(session)
    ordered = sorted(everything.messages, key=lambda m: m.log_time_ns)  # stable: file order on ties
    streamed = [
        m for m in ordered if m.topic in (topics.TELEMETRY.name, topics.COMMANDS.name, topics.FRAMES.name)
    ]
    sent = timeline.between(timeline.start_ns - 1, timeline.end_ns)
    assert [(o.ns, o.text, o.is_state) for o in sent] == [
        (m.log_time_ns, json.dumps(m.value), m.topic == topics.TELEMETRY.name) for m in streamed
    ]
    telemetry = [m for m in ordered if m.topic == topics.TELEMETRY.name]
    assert len(timeline.telemetry.values) == len(telemetry) == SECONDS * 50
    for m in telemetry[:: len(telemetry) // 7]:
        assert timeline.state_at(m.log_time_ns + 5_000_000) == m.value  # between states: the one before
    geometry_ns = [m.log_time_ns for m in ordered if m.topic == topics.GEOMETRY.name]
    assert len(geometry_ns) == SECONDS // RESET_EVERY_S
    assert timeline.geometry_at(geometry_ns[2] + 1) == everything.values(topics.GEOMETRY.name)[2]
    frames = [m for m in ordered if m.topic == topics.FRAMES.name]
    assert timeline.frames_at(frames[-2].log_time_ns) == frames[-2].value["frames"]
    tasks = [m for m in ordered if m.topic == topics.TASK.name]
    assert timeline.task_at(tasks[1234].log_time_ns) == tasks[1234].value
    events = [m.value for m in ordered if m.topic == topics.COMMANDS.name]
    assert [c["status"] for c in timeline.commands_at(timeline.end_ns)] == ["done"] * (len(events) // 3)
    assert len(timeline._chunks) <= timeline_module.CACHED_CHUNKS  # what it keeps decompressed
