"""A whole sweep: its outputs, the same bytes whatever the workers or backend, resuming, Ctrl-C,
and the findings it exists for (ground time linear in RTT, onboard flat)."""

import itertools
import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from ptwl.cli import main
from ptwl.experiments.sweep import sweep as sweep_module
from ptwl.experiments.sweep.backends import BackendMissing
from ptwl.experiments.sweep.spec import SweepSettings
from ptwl.experiments.sweep.summary import Fit, break_even_s, fits, sweet_spots
from ptwl.experiments.sweep.sweep import OutDirectoryError, run_sweep
from ptwl.experiments.sweep.table import NAMES, read_rows
from ptwl.recording.reader import read

SMALL: dict[str, Any] = {
    "task": "quick_connect",
    "rtts_s": [0.0, 1.0],
    "trials": 2,
    "operators": ["ground", "onboard"],
}


def small(out: Path, **changes: Any) -> SweepSettings:
    return SweepSettings(**{**SMALL, "out": str(out), "think_s": 1.0, **changes})


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small grid on one worker."""
    out = tmp_path_factory.mktemp("reference")
    run_sweep(small(out, workers=1))
    return out


def test_outputs_list_every_trial_and_the_papers_rows(reference: Path) -> None:
    rows = read_rows(reference / "trials.csv")
    assert [(r["operator"], r["rtt_s"], r["seed"]) for r in rows] == [
        (op, rtt, seed) for op in ("ground", "onboard") for rtt in (0.0, 1.0) for seed in (0, 1)
    ]
    assert (reference / "trials.csv").read_text().splitlines()[0].split(",") == NAMES
    assert all(r["success"] for r in rows)
    summary = (reference / "summary.md").read_text()
    for name in ("Success", "Max force [N]", "Run time [s]", "PTWL (wrench breach)", "RWE", "Dither"):
        assert f"| {name} |" in summary
    assert "| | ground 0 s | ground 1 s | onboard 0 s | onboard 1 s |" in summary
    record = json.loads((reference / "sweep.json").read_text())
    assert record["complete"] and record["trials_done"] == 8 and record["seeds"] == [0, 1]
    assert record["arguments"]["rtts_s"] == [0.0, 1.0] and "mujoco" in record["versions"]
    for png in ("task_time_vs_rtt.png", "success_vs_rtt.png", "peak_force_vs_rtt.png"):
        data = (reference / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


@pytest.fixture(scope="module")
def two_workers(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small grid on two workers, recording every trial (--record)."""
    out = tmp_path_factory.mktemp("two_workers")
    run_sweep(small(out, workers=2, record=True))
    return out


def test_two_workers_write_the_same_bytes_as_one(reference: Path, two_workers: Path) -> None:
    # ... and recording every trial changed none of them.
    assert (two_workers / "trials.csv").read_bytes() == (reference / "trials.csv").read_bytes()
    assert (two_workers / "summary.csv").read_bytes() == (reference / "summary.csv").read_bytes()


def test_record_writes_each_trial_whose_report_is_its_row(
    two_workers: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rows = read_rows(two_workers / "trials.csv")
    files = sorted((two_workers / "recordings").glob("*.mcap"))
    assert [f.name for f in files] == sorted(
        f"quick_connect_{r['operator']}_rtt{r['rtt_s']!r}_j0.0_l0.0_s{r['seed']}.mcap" for r in rows
    )
    for row in rows:
        path = (
            two_workers
            / "recordings"
            / f"quick_connect_{row['operator']}_rtt{row['rtt_s']!r}_j0.0_l0.0_s{row['seed']}.mcap"
        )
        recording = read(path)
        assert recording.complete and recording.metadata["ptwl"]["operator"] == row["operator"]
        assert main(["report", str(path), "--json"]) == 0
        [trial] = json.loads(capsys.readouterr().out)
        assert trial["success"] == row["success"]
        assert trial["max_force_n"] == row["max_force_n"] and trial["max_torque_nm"] == row["max_torque_nm"]
        assert trial["run_time_s"] == row["task_time_s"]
        assert (trial["behaviors"], trial["rwe"], trial["dither"]) == (
            row["behaviors"],
            row["rwe"],
            row["dither"],
        )
        assert trial["ptwl"] == {e: row[f"ptwl_{e}"] for e in ("timeout", "goal_reached", "wrench_breach")}
        commands = [e for e in recording.values("/commands") if e["status"] == "done"]
        assert len(commands) == row["commands_sent"] and {e["sender"] for e in commands} == {
            f"{row['operator']} operator"
        }
        # The link: every request up and every reply and event down, each delayed by half the RTT.
        link = recording.values("/link/messages")
        up = [m for m in link if m["direction"] == "uplink"]
        assert len(up) == row["commands_sent"] and len(link) == 3 * row["commands_sent"]
        assert all(m["realized_delay"] == pytest.approx(row["rtt_s"] / 2, abs=1e-9) for m in link)
        # ... each logged when it left the link, on the trial's clock.
        stamped = recording.on("/link/messages")
        assert all(m.log_time_ns == round(m.value["release"] * 1e9) for m in stamped)
        # Telemetry at 50 Hz of the trial's own clock.
        times = [m.log_time_ns for m in recording.on("/ptwl/telemetry")]
        steps = {b - a for a, b in itertools.pairwise(times)}
        assert steps <= {19_000_000, 20_000_000, 21_000_000}  # on 1 ms ticks
        assert (times[-1] - times[0]) / (len(times) - 1) == pytest.approx(20e6, rel=0.001)
        assert len(times) >= 50 * row["task_time_s"]
        if row["operator"] == "ground" and row["rtt_s"] == 1.0:
            queued = [e for e in recording.values("/commands") if e["status"] == "queued"]
            for before, after in zip(commands, queued[1:], strict=False):  # move, wait a round trip, think
                assert after["queued_at"] - before["ended_at"] >= 1.0 + 0.5 * 1.0 - 0.002


def test_a_rerun_runs_only_the_missing_trials(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    ran: list[int] = []
    real_run = sweep_module.backends.run

    def counting(specs, *args):  # type: ignore[no-untyped-def]
        ran.append(len(specs))
        return real_run(specs, *args)

    monkeypatch.setattr(sweep_module.backends, "run", counting)
    run_sweep(small(tmp_path, trials=1))
    with (tmp_path / "trials.csv").open("a") as f:
        f.write("quick_connect,ground,1.0,0.0,0.0,1")  # a row cut short by a kill
    run_sweep(small(tmp_path))
    run_sweep(small(tmp_path))
    assert ran == [4, 4, 0]
    assert (tmp_path / "trials.csv").read_bytes() == (reference / "trials.csv").read_bytes()
    with pytest.raises(OutDirectoryError, match=r"jitter_s = 0\.0, not 0\.5"):
        run_sweep(small(tmp_path, jitter_s=0.5))


def test_ctrl_c_keeps_whole_rows_and_the_same_command_finishes_the_sweep(
    reference: Path, tmp_path: Path
) -> None:
    cmd = [
        sys.executable,
        "-m",
        "ptwl.cli",
        "sweep",
        "--task",
        "quick_connect",
        "--rtt",
        "0,1",
        "--trials",
        "2",
    ]
    cmd += ["--think", "1", "--workers", "1", "--out", str(tmp_path)]
    # As from a terminal, where Ctrl-C is never ignored: a test run started in the background of
    # a non-interactive shell inherits SIGINT ignored, and Python then keeps it ignored.
    inherited = signal.signal(signal.SIGINT, signal.SIG_DFL)
    try:
        process = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    finally:
        signal.signal(signal.SIGINT, inherited)
    csv_path = tmp_path / "trials.csv"
    # Interrupted as the second row lands: its progress line follows the row's write at once, and
    # a blocking read wakes on it (a sweep of 8 trials is about 6 s with the compiled loop, so a
    # poll of the file on a busy machine could see the rows only once all were done).
    assert process.stderr is not None
    seen = []
    for line in process.stderr:
        seen.append(line)
        if line.startswith("sweep: 2/8 trials"):
            break
    process.send_signal(signal.SIGINT)
    _, rest = process.communicate(timeout=60)
    err = "".join(seen) + rest
    assert process.returncode == 130, err
    assert "run the same command to resume" in err
    assert "sweep: 1/8 trials" in err  # plain progress lines when not a terminal
    kept = read_rows(csv_path)
    assert 2 <= len(kept) < 8 and csv_path.read_text().endswith("\n")
    record = json.loads((tmp_path / "sweep.json").read_text())
    assert record["trials_done"] == len(kept) and not record["complete"]
    assert main(cmd[3:]) == 0
    assert csv_path.read_bytes() == (reference / "trials.csv").read_bytes()


def test_ray_runs_the_same_trials_to_the_same_bytes(reference: Path, tmp_path: Path) -> None:
    pytest.importorskip("ray")
    os.environ.pop("RAY_ADDRESS", None)
    run_sweep(small(tmp_path, workers=2, backend="ray"))
    assert (tmp_path / "trials.csv").read_bytes() == (reference / "trials.csv").read_bytes()
    assert "ray" in json.loads((tmp_path / "sweep.json").read_text())["versions"]


def test_ground_time_grows_linearly_with_delay_and_onboard_stays_flat(tmp_path: Path) -> None:
    """Ferrell's move-and-wait, measured: the lid takes 5 ground commands."""
    rows = run_sweep(
        SweepSettings(
            "lid", [0.0, 5.0, 10.0], 1, ["ground", "onboard"], str(tmp_path), workers=os.cpu_count() or 1
        )
    )
    assert all(r["success"] for r in rows)
    assert all(r["wait_cycles"] == 5 for r in rows if r["operator"] == "ground")
    line = fits(rows)
    ground, onboard = line["ground"], line["onboard"]
    assert ground.r2_means >= 0.95 and ground.slope == pytest.approx(4.0, abs=0.1)  # four waits of one RTT
    assert abs(onboard.slope) < 0.1 * ground.slope
    report = (tmp_path / "report.md").read_text()
    assert f"{ground.slope:.3f} x RTT (R^2 = {ground.r2_means:.3f} against the mean at each RTT" in report
    change = abs(onboard.slope) * 10.0
    flat = f"{onboard.slope:.3f} x RTT (flat: {change:.3f} s from 0 to 10 s of RTT, so no R^2)"
    assert flat in report  # a line without a trend is called flat, not given a meaningless R^2
    assert f"onboard slope is {100.0 * onboard.slope / ground.slope:.1f} % of the ground slope" in report
    assert "onboard is faster at every delay measured" in report  # think time makes ground slower at 0


def test_ray_missing_is_refused_before_anything_is_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sweep_module.backends.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(BackendMissing, match=r'pip install -e "\.\[ray\]"'):
        run_sweep(small(tmp_path / "out", backend="ray"))
    assert not (tmp_path / "out").exists()
    out = tmp_path / "cli"
    assert (
        main(["sweep", "--task", "lid", "--rtt", "0", "--trials", "1", "--backend", "ray", "--out", str(out)])
        == 2
    )
    assert not out.exists()


def test_bad_arguments_name_the_argument_and_the_range(capsys: pytest.CaptureFixture[str]) -> None:
    for args, message in (
        (["--rtt", "0,-1"], "each RTT must be in [0, 600] s"),
        (["--operator", "pilot"], "operators from ground, onboard"),
        (["--loss", "1.5"], "must be in [0, 0.9]"),
        (["--max-age", "0"], "argument --max-age: must be in [0.001, 86400] s, got 0"),
    ):
        with pytest.raises(SystemExit) as exit_info:
            main(["sweep", "--task", "lid", "--out", "unused", *args])
        assert exit_info.value.code == 2
        assert message in capsys.readouterr().err


def test_the_fit_judges_linearity_on_the_means_and_says_where_onboard_wins() -> None:
    # Two seeds, one needing two more waits than the other: each line has slope 4 s/s.
    fit = Fit.of([0.0, 0.0, 10.0, 10.0], [10.0, 30.0, 50.0, 70.0])
    assert fit is not None
    assert (fit.slope, fit.intercept) == pytest.approx((4.0, 20.0))
    assert fit.r2_means == pytest.approx(1.0) and fit.r2_trials == pytest.approx(0.8)
    ground, onboard = Fit(2.0, 10.0, 1.0, 1.0), Fit(0.1, 20.0, 1.0, 1.0)
    assert break_even_s(ground, onboard) == pytest.approx(10.0 / 1.9)
    assert break_even_s(ground, Fit(2.0, 0.0, 1.0, 1.0)) is None
    assert Fit.of([1.0, 1.0], [2.0, 3.0]) is None  # one RTT: no line


def test_autonomy_levels_full_is_flat_and_confirming_every_step_grows_one_rtt_per_decision(
    tmp_path: Path,
) -> None:
    """`--autonomy off,full` on the plug at RTT 0 and 5 s: the report's sweet-spot table names a
    level per RTT; at `off` every decision waits a round trip (and the same seeded think time at
    both RTTs), so the task time grows by about one RTT per decision taken before the last
    behavior's end; at `full` nothing waits."""
    rows = run_sweep(
        SweepSettings("plug", [0.0, 5.0], 1, ["onboard"], str(tmp_path), autonomies=["off", "full"])
    )
    by = {(r["autonomy"], r["rtt_s"]): r for r in rows}
    assert set(by) == {("off", 0.0), ("off", 5.0), ("full", 0.0), ("full", 5.0)}
    assert all(r["success"] for r in rows)
    assert by[("full", 0.0)]["decisions_waited"] == by[("full", 5.0)]["decisions_waited"] == 0
    # Flat: only how long the arm has settled when the command arrives differs (4 ms seen).
    assert by[("full", 5.0)]["task_time_s"] == pytest.approx(by[("full", 0.0)]["task_time_s"], abs=0.05)
    waits = by[("off", 5.0)]["decisions_waited"]
    assert waits == by[("off", 0.0)]["decisions_waited"] >= 3  # every transition, the last one too
    grown_s = by[("off", 5.0)]["task_time_s"] - by[("off", 0.0)]["task_time_s"]
    assert grown_s == pytest.approx(5.0 * (waits - 1), rel=0.1)  # the last waits after the last end
    assert by[("off", 5.0)]["decision_wait_s"] - by[("off", 0.0)]["decision_wait_s"] == pytest.approx(
        5.0 * waits, abs=0.002 * waits
    )
    header = next(line for line in (tmp_path / "trials.csv").read_text().splitlines())
    assert header.startswith("task,operator,autonomy,") and ",decisions_waited,decision_wait_s," in header
    report = (tmp_path / "report.md").read_text()
    assert (
        "## Autonomy levels: the sweet spot" in report and (tmp_path / "autonomy_vs_rtt.png").stat().st_size
    )
    assert (
        "| RTT [s] | off: success, time [s], waits | full: success, time [s], waits | sweet spot |" in report
    )
    for rtt in (0, 5):  # both succeed; full is faster
        assert re.search(
            rf"^\| {rtt} \| 100 %, [\d.]+, {waits}\.0 \| 100 %, [\d.]+, 0\.0 \| \*\*full\*\* \|$",
            report,
            re.M,
        ), report


def test_the_sweet_spot_is_the_fastest_level_at_least_as_successful_as_full_autonomy() -> None:
    def rows(level: str, rtt: float, times: list[float], successes: list[bool]) -> list[dict[str, object]]:
        return [
            {
                "operator": "onboard",
                "autonomy": level,
                "rtt_s": rtt,
                "task_time_s": t,
                "success": ok,
                "decisions_waited": 1,
            }
            for t, ok in zip(times, successes, strict=True)
        ]

    table = [
        *rows("off", 0.0, [10.0, 11.0], [False, True]),  # fastest, but half fail: not it
        *rows("high", 0.0, [15.0, 16.0], [True, True]),  # as successful as full, faster: the spot
        *rows("full", 0.0, [20.0, 21.0], [True, True]),
        *rows("high", 5.0, [40.0, 41.0], [True, True]),
        *rows("full", 5.0, [20.0, 21.0], [True, True]),
    ]
    spots = sweet_spots(table)
    assert [(s.rtt_s, s.reference, s.best) for s in spots] == [(0.0, "full", "high"), (5.0, "full", "full")]
    assert [x.level for x in spots[0].levels] == ["off", "high", "full"]
    assert spots[0].levels[0].success_rate == 0.5 and spots[0].levels[1].task_time_median_s == 15.5
