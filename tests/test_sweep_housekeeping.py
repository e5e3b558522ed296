"""A sweep touches only its own files and leaves no process behind (issue 26).

The defects: `ptwl sweep --out` into an existing directory that was not a sweep overwrote its
report.md and summary.md without a word; after `kill -9` of a sweep its pool workers lived on,
reparented to init, each busy on a trial nobody would read."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from ptwl.cli import main
from ptwl.experiments.sweep.parent_watch import ParentWatch
from ptwl.experiments.sweep.spec import SweepSettings
from ptwl.experiments.sweep.sweep import OutDirectoryError, _check_directory, _write_json

SWEEP = ["sweep", "--task", "quick_connect", "--rtt", "0,1", "--trials", "1", "--think", "1"]


def _settings(out: Path, **changes: Any) -> SweepSettings:
    """What SWEEP gives, into `out`, with `changes`."""
    given: dict[str, Any] = {"task": "quick_connect", "rtts_s": [0.0, 1.0], "trials": 1, "think_s": 1.0}
    return SweepSettings(**{**given, "operators": ["ground", "onboard"], "out": str(out), **changes})


# ------------------------------------------------------------------------- --out: whose files
def test_a_directory_that_is_not_a_sweep_is_refused_and_left_as_it_was(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "report.md").write_text("my own report\n")
    (tmp_path / "summary.md").write_text("my notes\n")
    assert main([*SWEEP, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1  # one line
    assert f"--out {tmp_path}: not empty and not a sweep's directory (no sweep.json" in err
    assert "'report.md', 'summary.md'" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md", "summary.md"]  # nothing added
    assert (tmp_path / "report.md").read_text() == "my own report\n"


@pytest.mark.parametrize(
    ("content", "why"),
    [("{not json", "JSONDecodeError"), ('{"task": "lid"}', "KeyError: 'arguments'"), ("[1]", "TypeError")],
)
def test_a_sweep_json_that_is_not_a_sweeps_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str, why: str
) -> None:
    (tmp_path / "sweep.json").write_text(content)
    assert main([*SWEEP, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--out {tmp_path}: its sweep.json is not a sweep's ({why}" in err
    assert [p.name for p in tmp_path.iterdir()] == ["sweep.json"]


def test_a_file_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "a_file"
    target.write_text("x")
    assert main([*SWEEP, "--out", str(target)]) == 2
    assert f"--out {target}: exists and is not a directory" in capsys.readouterr().err


def test_a_sweep_of_other_settings_is_refused_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _write_json(tmp_path, _settings(tmp_path, jitter_s=0.5), [], 0, 0.0)
    before = (tmp_path / "sweep.json").read_bytes()
    assert main([*SWEEP, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds a sweep with jitter_s = 0.5, not 0.0" in err
    assert (tmp_path / "sweep.json").read_bytes() == before
    # A max age changes what a trial is: its rows are not another's.
    assert main([*SWEEP, "--max-age", "3", "--out", str(tmp_path)]) == 2
    assert "holds a sweep with jitter_s = 0.5" in capsys.readouterr().err
    _write_json(tmp_path, _settings(tmp_path), [], 0, 0.0)
    assert main([*SWEEP, "--max-age", "3", "--out", str(tmp_path)]) == 2
    assert "holds a sweep with max_age_s = None, not 3.0" in capsys.readouterr().err


def test_new_empty_and_same_grid_directories_are_accepted(tmp_path: Path) -> None:
    _check_directory(tmp_path / "new", _settings(tmp_path / "new"))
    _check_directory(tmp_path, _settings(tmp_path))  # empty
    _write_json(tmp_path, _settings(tmp_path), [], 0, 0.0)
    (tmp_path / "report.md").write_text("a sweep's own report")
    # The same grid, grown (more RTTs, operators, trials): a resume.
    _check_directory(tmp_path, _settings(tmp_path, rtts_s=[0.0, 1.0, 2.0], trials=3, operators=["ground"]))
    with pytest.raises(OutDirectoryError, match="task = 'quick_connect', not 'lid'"):
        _check_directory(tmp_path, _settings(tmp_path, task="lid"))


# --------------------------------------------------------------------- kill -9: no orphans
def _children(pid: int) -> dict[int, str]:
    """{child pid: state letter} of `pid`'s living children, from /proc."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        state, ppid = stat.rsplit(")", 1)[1].split()[:2]
        if int(ppid) == pid:
            found[int(entry.name)] = state
    return found


def _running(pid: int) -> bool:
    """Alive and not a zombie (one that died under a parent that does not reap is gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_kill_9_of_a_sweep_leaves_no_worker_behind(tmp_path: Path) -> None:
    cmd = [sys.executable, "-m", "ptwl.cli", "sweep", "--task", "lid", "--rtt", "10", "--trials", "20"]
    cmd += ["--workers", "2", "--out", str(tmp_path / "out")]
    sweep = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 60.0
        while len(workers) < 2 and time.monotonic() < deadline and sweep.poll() is None:
            workers = sorted(_children(sweep.pid))
            time.sleep(0.05)
        assert len(workers) == 2, f"the sweep started {workers} (exit {sweep.poll()})"
        os.kill(sweep.pid, signal.SIGKILL)
        sweep.wait(timeout=10.0)
        deadline = time.monotonic() + 5.0
        while any(_running(w) for w in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert [w for w in workers if _running(w)] == [], "workers outlived their sweep"
    finally:
        if sweep.poll() is None:
            sweep.kill()
        for w in workers:  # the test's own children's children, if the fix failed
            if _running(w):
                os.kill(w, signal.SIGKILL)


@pytest.mark.parametrize("when", ["before_the_worker_starts", "while_it_waits"])
def test_the_watcher_ends_a_worker_when_its_sweep_ends(when: str) -> None:
    """The watcher (another start method, another OS, or a sweep killed before prctl held): a
    worker ends once its sweep's process has, even while that is an unreaped zombie."""
    sweep = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    if when == "before_the_worker_starts":
        sweep.kill()
        sweep.wait()
    code = (
        "from ptwl.experiments.sweep.parent_watch import ParentWatch; "
        f"ParentWatch({sweep.pid}).wait(); raise SystemExit(7)"
    )
    worker = subprocess.Popen([sys.executable, "-c", code])
    try:
        if when == "while_it_waits":
            with pytest.raises(subprocess.TimeoutExpired):
                worker.wait(timeout=0.5)  # it waits while the sweep lives (any time would do)
            sweep.kill()  # not reaped until below: a zombie
        assert worker.wait(timeout=30.0) == 1  # 7: the watcher returned instead of ending it
    finally:
        worker.kill()
        sweep.kill()
        sweep.wait()


@pytest.mark.parametrize("how", ["pidfd", "polling"])
def test_a_stopped_watch_leaves_no_thread_and_its_process_lives_on(
    how: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The watch on a sweep that lives on is stopped and joined, whichever way it waits (a
    watch that ignored stop() would be a thread nobody owns)."""
    if how == "polling":
        monkeypatch.setattr(ParentWatch, "_pidfd", lambda self: None)
    watch = ParentWatch(os.getppid()).start()
    assert watch.alive
    time.sleep(0.05)  # it is waiting now, not about to
    watch.stop()
    assert not watch.alive
    assert [t for t in threading.enumerate() if t.name == "sweep-watch"] == []
    watch.stop()  # twice is harmless


def test_a_worker_that_watches_its_sweep_stops_the_watch_as_it_exits() -> None:
    """A pool worker whose parent is not its sweep (the watcher's case): its watch thread runs,
    and multiprocessing's exit (its finalizers, as a worker runs them) stops and joins it."""
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    code = (
        "import multiprocessing.util, threading\n"
        "from ptwl.experiments.sweep import backends\n"
        f"backends._worker_init({sleeper.pid})\n"
        "names = lambda: sorted(t.name for t in threading.enumerate())\n"
        "print(names())\n"
        "multiprocessing.util._exit_function()\n"
        "print(names())\n"
    )
    try:
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    finally:
        sleeper.kill()
        sleeper.wait()
    assert done.returncode == 0, done.stderr
    before, after = done.stdout.splitlines()
    assert before == "['MainThread', 'sweep-watch']" and after == "['MainThread']"
