"""The virtual-time trial against the real system: the same operator through the real `ptwl
serve` and `ptwl proxy`, paced to real time, takes the same task time (within 5 %)."""

import io
import re
from pathlib import Path

import pytest

from ptwl.experiments.sweep.realtime import NotOneGridPoint, cross_check, link_delays, robot_lag_s
from ptwl.experiments.sweep.spec import SweepSettings
from ptwl.launcher import running_proxy, running_server


def test_a_ground_trial_through_the_real_link_takes_the_virtual_task_time(tmp_path: Path) -> None:
    settings = SweepSettings("quick_connect", [0.5], 1, ["ground"], str(tmp_path), think_s=0.5)
    out = io.StringIO()
    with (
        running_server("--scene", settings.task) as robot,
        running_proxy(robot.url, *link_delays(settings)) as link,
    ):
        status = cross_check(settings, robot.url, link.url, out)
    text = out.getvalue()
    found = re.search(
        r"mean task time ([\d.]+) s in real time \(the robot ([\d.]+) s behind it\), "
        r"([\d.]+) s in virtual time",
        text,
    )
    assert found, text
    real, lag, virtual = float(found[1]), float(found[2]), float(found[3])
    assert virtual > 7.0  # the insertion (5.9 s), a round trip and a think, the relieve (1 s)
    assert lag < 0.05 * virtual, text  # a robot that cannot keep real time is named, not judged
    # The command line's bar is 5 %; measured +0.0 % on an idle machine. Never more than 2 % short
    # of the virtual time: an operator that stamped each arrival with the time its wait began (a
    # bug this caught) read -4.6 %. A busy host only makes real time longer (+5.2 % with a core
    # hogged and two tests at once), so above it the bound is that margin's.
    assert virtual * 0.98 <= real <= virtual * 1.08, text
    verdict_holds = "holds" in text
    assert (status == 0) == verdict_holds, text  # the exit status is the verdict it printed
    off = abs(real - virtual) / virtual  # (of figures rounded to 10 ms: judged clear of the bar)
    assert verdict_holds if off <= 0.045 else (not verdict_holds if off >= 0.055 else True), text


def test_realtime_runs_one_plain_grid_point(tmp_path: Path) -> None:
    with pytest.raises(NotOneGridPoint, match="one --rtt and one --operator"):
        link_delays(SweepSettings("lid", [0.0, 1.0], 1, ["ground"], str(tmp_path)))
    with pytest.raises(NotOneGridPoint, match="leave out --jitter"):
        link_delays(SweepSettings("lid", [1.0], 1, ["ground"], str(tmp_path), jitter_s=0.1))
    with pytest.raises(NotOneGridPoint, match="--max-age"):  # its task time counts only what ran
        link_delays(SweepSettings("lid", [1.0], 1, ["ground"], str(tmp_path), max_age_s=3.0))
    assert link_delays(SweepSettings("lid", [1.0], 1, ["ground"], str(tmp_path))) == [
        "--uplink",
        "0.5",
        "--downlink",
        "0.5",
    ]


def test_the_robots_lag_is_its_commands_wall_span_less_their_simulated_time() -> None:
    assert robot_lag_s(100.0, 106.5, 5.9) == pytest.approx(0.6)  # a 5.9 s move took 6.5 s of wall
    assert robot_lag_s(100.0, 105.8, 5.9) == pytest.approx(-0.1)  # a lag from before caught up
    unknown = (robot_lag_s(100.0, None, 5.9), robot_lag_s(None, 101.0, 1.0), robot_lag_s(1.0, 2.0, None))
    assert unknown == (0.0, 0.0, 0.0)  # a command that never ran or ended adds nothing
