"""Sweeps on link schedules (issue point 4): each trial starts at a seeded point of the pass, its
row says how much of it the link was closed, and report.md splits the times by that."""

import csv
import statistics
from pathlib import Path

import pytest

from latency.profile import Blackout, LinkProfile
from latency.schedule import Contact, Schedule
from ptwl.cli import main
from ptwl.experiments.sweep.plots import write_report
from ptwl.experiments.sweep.spec import (
    RttSetBySchedule,
    SweepSettings,
    TrialSpec,
    default_rtts_s,
    fixed_rtt_s,
    link_schedule,
)
from ptwl.experiments.sweep.summary import write_summary
from ptwl.experiments.sweep.table import NAMES, read_rows
from ptwl.experiments.sweep.trial import blackout_s, los_s, row, run_trial, simulate

TICK_S = 0.001
PERIOD_S = 60.0
GAP_S = 20.0


def gap_file(path: Path, start_s: float, gap_s: float = GAP_S, period_s: float = PERIOD_S) -> str:
    """A TOML schedule repeating every period_s, closed for gap_s from start_s (in plan time,
    wrapping round the period), open the rest."""
    start_s %= period_s
    end_s = start_s + gap_s
    windows = [(0.0, start_s), (end_s, period_s)] if end_s <= period_s else [(end_s - period_s, start_s)]
    lines = [f"period = {period_s}"]
    for a, b in windows:
        if b > a:
            lines += ["[[contacts]]", f"start = {a}", f"end = {b}"]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def quick(seed: int, schedule: str | None = None, rtt_s: float = 1.0, operator: str = "ground") -> TrialSpec:
    return TrialSpec("quick_connect", operator, rtt_s, 0.0, 0.0, seed, 0.0, schedule=schedule)


# ------------------------------------------------------------------------------ (a) offsets
def test_offsets_are_seeded_within_the_period_paired_across_rtts_and_operators(tmp_path: Path) -> None:
    plan = gap_file(tmp_path / "plan.toml", 30.0)
    offsets = {
        (seed, rtt, operator): quick(seed, plan, rtt, operator).plan_offset_s
        for seed in range(200)
        for rtt in (0.0, 5.0)
        for operator in ("ground", "onboard")
    }
    by_seed = [{v for (s, _, _), v in offsets.items() if s == seed} for seed in range(200)]
    assert all(len(one) == 1 for one in by_seed)  # the same at every RTT, for either operator
    drawn = [one.pop() for one in by_seed]
    # Each seed its own point of the pass (200 draws of 60,000 ticks: a shared tick is chance).
    assert len(set(drawn[:20])) == 20 and len(set(drawn)) >= 195
    assert all(0.0 <= o < PERIOD_S and o == round(o, 3) for o in drawn)  # whole ticks
    assert statistics.fmean(drawn) == pytest.approx(PERIOD_S / 2, abs=3.0)  # uniform: mean 30 s
    assert quick(3, plan).plan_offset_s == quick(3, plan).plan_offset_s == 31.455  # seeded
    # A named profile's schedule counts too; a link without contact windows starts at 0.
    leo = TrialSpec("quick_connect", "ground", 1.0, 0.0, 0.0, 3, profile="leo_tdrs")
    assert 0.0 <= leo.plan_offset_s < 5400.0 and leo.plan_offset_s != 0.0
    assert quick(3).plan_offset_s == 0.0
    assert (
        TrialSpec("quick_connect", "ground", 1.0, 0.0, 0.0, 3, profile="earth_moon_lossy").plan_offset_s
        == 0.0
    )


def test_without_a_period_the_offset_falls_before_the_last_contacts_end(tmp_path: Path) -> None:
    (tmp_path / "once.toml").write_text("[[contacts]]\nstart = 10.0\nend = 25.0\n")
    offsets = [quick(seed, str(tmp_path / "once.toml")).plan_offset_s for seed in range(50)]
    assert all(0.0 <= o < 25.0 for o in offsets) and max(offsets) > 20.0


# ----------------------------------------------------------------- (b) a gap inside the trial
def test_a_gap_as_the_trial_starts_costs_the_whole_gap_and_is_counted_to_the_tick(tmp_path: Path) -> None:
    offset_s = quick(1, gap_file(tmp_path / "probe.toml", 0.0)).plan_offset_s  # depends on the period only
    at_start = quick(1, gap_file(tmp_path / "at_start.toml", offset_s))
    two_in = quick(1, gap_file(tmp_path / "two_in.toml", offset_s + 2.0))
    away = quick(1, gap_file(tmp_path / "away.toml", offset_s + 30.0))  # after the trial's end
    assert at_start.plan_offset_s == two_in.plan_offset_s == away.plan_offset_s == offset_s == 17.408
    clear = row(simulate(away))
    assert clear["success"] and not clear["los_in_trial"] and clear["los_s"] == 0.0
    assert clear["operator_time_s"] < 10.0  # the gap would have come 30 s in
    # The link closes as the first command is sent: it waits the whole gap, and so does the rest.
    held = row(simulate(at_start))
    assert held["success"] and held["los_in_trial"]
    assert held["los_s"] == pytest.approx(GAP_S, abs=1e-9)
    assert held["operator_time_s"] - clear["operator_time_s"] == pytest.approx(GAP_S, abs=TICK_S)
    assert held["task_time_s"] == pytest.approx(clear["task_time_s"], abs=TICK_S)  # the robot's own work
    assert (held["schedule"], held["plan_offset_s"]) == (at_start.schedule, 17.408)
    # Closing 2 s in, while the first command runs: only the rest of the gap after its end is lost,
    # its end event held until the link opens.
    trial = simulate(two_in)
    late = row(trial)
    first_end_s = trial.robot.figures.steps[0].report.ended_at
    assert late["los_s"] == pytest.approx(GAP_S, abs=1e-9) and late["los_in_trial"]
    assert late["operator_time_s"] - clear["operator_time_s"] == pytest.approx(
        2.0 + GAP_S - first_end_s, abs=2 * TICK_S
    )
    assert 15.0 < late["operator_time_s"] - clear["operator_time_s"] < GAP_S


def test_los_counts_either_direction_closed_and_blackouts_from_the_plans_start() -> None:
    # Plan time: the uplink is open 0-10 of every 20 s, the downlink 0-15; a blackout 12-14
    # (inside the uplink's gap: no more closed) and 16-17 every 20 s (inside both gaps).
    schedule = Schedule(
        contacts=[
            Contact(start=0.0, end=10.0, direction="uplink"),
            Contact(start=0.0, end=15.0, direction="downlink"),
        ],
        period=20.0,
    )
    profile = LinkProfile(
        schedule=schedule,
        blackouts=[Blackout(start=12.0, duration=2.0, period=20.0), Blackout(start=16.0, duration=1.0)],
    )
    assert los_s(profile, 10.0) == 0.0
    assert los_s(profile, 30.0) == pytest.approx(10.0 + 0.0)  # 10-20; 30-40 is past the end
    assert los_s(profile, 45.0) == pytest.approx(10.0 + 10.0)  # 10-20, 30-40
    assert los_s(profile, 10.0, plan_offset_s=5.0) == pytest.approx(5.0)  # plan 5-15: closed 10-15
    # A blackout alone, once, 1 s starting at plan time 16: a trial 15 s in meets it 1 s after its start.
    once = LinkProfile(blackouts=[Blackout(start=16.0, duration=1.0)])
    assert los_s(once, 5.0, plan_offset_s=15.0) == pytest.approx(1.0)
    assert blackout_s(once, 5.0, plan_offset_s=15.0) == pytest.approx(1.0)
    assert blackout_s(once, 5.0, plan_offset_s=16.5) == pytest.approx(0.5)
    every = LinkProfile(blackouts=[Blackout(start=10.0, duration=5.0, period=100.0)])
    assert blackout_s(every, 100.0, plan_offset_s=112.0) == pytest.approx(3.0 + 2.0)  # 112-115, 210-212


# ------------------------------------------------------------------- (c) a sweep end to end
def test_a_sweep_on_a_schedule_writes_the_columns_and_splits_the_report_by_loss_of_signal(
    tmp_path: Path,
) -> None:
    plan = gap_file(tmp_path / "plan.toml", 30.0)  # closed 30-50 of every 60 s
    out = tmp_path / "out"
    args = ["sweep", "--task", "quick_connect", "--rtt", "1", "--trials", "3", "--operator", "ground"]
    assert main([*args, "--think", "1", "--workers", "1", "--schedule", plan, "--out", str(out)]) == 0
    header = (out / "trials.csv").read_text().splitlines()[0].split(",")
    assert header == NAMES
    assert {"schedule", "plan_offset_s", "los_s", "los_in_trial", "blackout_s"} <= set(header)
    rows = read_rows(out / "trials.csv")
    assert [r["plan_offset_s"] for r in rows] == [21.104, 17.408, 52.402]  # seeds 0-2
    assert all(r["schedule"] == str(Path(plan).resolve()) and r["success"] for r in rows)
    # Seed 0 starts 8.9 s before the gap and is still going when it comes; 1 and 2 end in the open.
    assert [r["los_in_trial"] for r in rows] == [True, False, False]
    assert rows[0]["los_s"] == pytest.approx(GAP_S) and rows[1]["los_s"] == rows[2]["los_s"] == 0.0
    with (out / "trials.csv").open() as f:
        assert [line["los_in_trial"] for line in csv.DictReader(f)] == ["1", "0", "0"]
    report = (out / "report.md").read_text()
    assert "## Loss of signal" in report
    assert (
        "| operator | RTT [s] | LOS in trial | trials | success | task time median [s] "
        "| operator time median [s] |" in report
    )
    for los in (False, True):
        part = [r for r in rows if r["los_in_trial"] == los]
        task = statistics.median(r["task_time_s"] for r in part)
        operator = statistics.median(r["operator_time_s"] for r in part)
        line = (
            f"| ground | 1 | {'yes' if los else 'no'} | {len(part)} | 100 % | {task:.2f} | {operator:.2f} |"
        )
        assert line in report, report
    with_los = next(r for r in rows if r["los_in_trial"])
    assert (
        with_los["operator_time_s"] > max(r["operator_time_s"] for r in rows if not r["los_in_trial"]) + 15.0
    )


def test_a_sweep_whose_link_never_closes_says_nothing_of_loss_of_signal(tmp_path: Path) -> None:
    rows = [run_trial(quick(0))]
    assert rows[0]["los_s"] == 0.0 and rows[0]["plan_offset_s"] == 0.0 and rows[0]["schedule"] is None
    write_report(tmp_path, rows, write_summary(tmp_path, rows))
    assert "Loss of signal" not in (tmp_path / "report.md").read_text()


# --------------------------------------------------------------- (d) delay points set the RTT
def test_rtt_with_a_schedule_whose_delay_points_set_the_delay_is_refused_naming_both(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = tmp_path / "delay.toml"
    plan.write_text(
        "period = 100.0\n"
        "[[contacts]]\nstart = 0.0\nend = 100.0\n"
        "[[delay]]\nat = 0.0\none_way_s = 1.0\n"
        "[[delay]]\nat = 60.0\none_way_s = 2.0\n"
        "[[delay]]\nat = 100.0\none_way_s = 2.0\n"
    )
    # Mean one-way: (60 x 1.5 + 40 x 2) / 100 = 1.7 s; the RTT twice that.
    assert fixed_rtt_s(link_schedule(None, str(plan))) == pytest.approx(3.4)
    assert default_rtts_s(link_schedule(None, str(plan))) == [pytest.approx(3.4)]
    assert fixed_rtt_s(link_schedule("lunar_far_side_relay", None)) == pytest.approx(2.6)  # 1.31-1.29-1.31
    assert fixed_rtt_s(link_schedule("leo_tdrs", None)) is None
    out = tmp_path / "out"
    for given in (["--schedule", str(plan)], ["--profile", "lunar_far_side_relay"]):
        with pytest.raises(SystemExit) as exit_info:
            main(["sweep", "--task", "quick_connect", "--rtt", "1,2", "--out", str(out), *given])
        assert exit_info.value.code == 2
        err = capsys.readouterr().err
        assert f"--rtt 1,2 and {' '.join(given)}: its schedule's delay points set the delay" in err, err
        assert "leave out --rtt" in err
    assert not out.exists()
    with pytest.raises(RttSetBySchedule, match="--rtt 1 and --schedule"):
        SweepSettings("quick_connect", [1.0], 1, ["ground"], str(out), schedule=str(plan))
    settings = SweepSettings("quick_connect", [3.4], 1, ["ground"], str(out), schedule=str(plan))
    assert [s.rtt_s for s in settings.specs()] == [3.4]


def test_a_bad_schedule_file_is_one_error_naming_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = tmp_path / "plan.txt"
    plan.write_text("a contact +0 +40 1 2 1000\n# a comment\na contact +50 +later 1 2 1000\n")
    with pytest.raises(SystemExit) as exit_info:
        main(["sweep", "--task", "quick_connect", "--schedule", str(plan), "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 2
    assert f"argument --schedule: {plan}:3: time '+later' is not +seconds" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------- (e) an ION plan
def test_an_ion_contact_plan_is_a_schedule(tmp_path: Path) -> None:
    plan = tmp_path / "pass.ionrc"
    plan.write_text(
        "# ground 7, robot 9: a 300 s pass with a 15 s gap at 100 s; ranges give the light time\n"
        "m horizon +0\n"
        "a contact +0 +100 7 9 100000\n"
        "a contact +0 +100 9 7 100000\n"
        "a contact +115 +300 7 9 100000\n"
        "a contact +115 +300 9 7 100000\n"
        "a range +0 +300 7 9 0.6\n"
        "a contact +0 +300 1 2 5\n"  # other nodes: not this link
    )
    out = tmp_path / "out"
    nodes = ["--ground-node", "7", "--robot-node", "9"]
    args = ["sweep", "--task", "quick_connect", "--trials", "2", "--operator", "ground", "--think", "1"]
    assert main([*args, "--workers", "1", "--schedule", str(plan), *nodes, "--out", str(out)]) == 0
    rows = read_rows(out / "trials.csv")
    assert [r["rtt_s"] for r in rows] == [
        pytest.approx(1.2),
        pytest.approx(1.2),
    ]  # the range's 0.6 s each way
    assert all(0.0 <= r["plan_offset_s"] < 300.0 and r["success"] for r in rows)  # the plan's span
    assert all(r["schedule"] == str(plan.resolve()) for r in rows)
    spec = TrialSpec(
        "quick_connect", "ground", 1.2, 0.0, 0.0, 0, schedule=str(plan), ground_node=7, robot_node=9
    )
    contacts = spec.link_profile().schedule
    assert contacts is not None and contacts.contacts is not None
    assert [(c.start, c.end, c.direction) for c in contacts.contacts] == [
        (0.0, 100.0, "uplink"),
        (0.0, 100.0, "downlink"),
        (115.0, 300.0, "uplink"),
        (115.0, 300.0, "downlink"),
    ]
    assert "## Loss of signal" in (out / "report.md").read_text()
