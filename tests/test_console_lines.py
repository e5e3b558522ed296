"""What the console's lines say, drawn from their models without a browser (issue 27.5): the
bar's force, who has control and a recording said as such; frames listed with their poses."""

import math

from tests.helpers import robot_state
from web.panel_html import frames_html
from web.status_bar import BarInputs, _fraction_done, _prediction_html, _render
from web.telemetry_health import LinkLine


def bar(**more: object) -> str:
    state = robot_state()
    state["wrench"] = [3.0, 4.0, 0.0, 0.0, 0.0, 0.5]  # |f| 5 N
    inputs = BarInputs(state, 100.1, True, LinkLine("fresh", "link round trip 0 s · connected"), 0.0, "", "")
    return str(_render(BarInputs(**{**inputs.__dict__, **more}), 0.1, "fresh"))


def test_the_bar_says_the_force_and_who_has_control() -> None:
    assert "<b>|f| 5.0 N</b>" in bar()
    assert '<span id="ptwl-holder">control: nobody</span>' in bar()
    assert '<span id="ptwl-holder">control: operator 3</span>' in bar(holder="operator 3")


def test_a_replay_says_it_is_a_recording_not_a_link() -> None:
    shown = bar(recording="jam.mcap")
    assert "<b>REPLAY</b> of jam.mcap: what was recorded, nothing here reaches a robot" in shown
    assert "link round trip" not in shown  # on main: "link round trip 0 s" on a recording


def test_frames_are_listed_with_their_poses() -> None:
    half = math.sqrt(0.5)  # 90 deg about x
    frames = [
        {
            "name": "slanted",
            "source": "operator",
            "defined_by": "typed pose",
            "pose": {"position": [0.4, -0.05, 0.3], "quaternion": [half, half, 0.0, 0.0]},
        }
    ]
    html = str(frames_html(frames))
    assert "<b>slanted</b> origin (400.0, -50.0, 300.0) mm, rotation (90.0, 0.0, 0.0) deg" in html


def monitor_fields(**more: object) -> dict[str, object]:
    from robot_sim.params import MonitorSpec
    from robot_sim.task_monitor import FrictionMonitor

    return {**FrictionMonitor(MonitorSpec(), 0.001).fields(), **more}


def test_the_force_monitor_never_passes_silently_on_the_bar() -> None:
    def shown(**more: object) -> str:
        state = robot_state()
        state["active_command"] = more.pop("active_command", 3)
        state["monitor"] = monitor_fields(**more)
        inputs = BarInputs(state, 100.1, True, LinkLine("fresh", "link round trip 0 s"), 0.0, "", "")
        return str(_render(inputs, 0.1, "fresh"))

    assert 'id="ptwl-monitor"' not in bar()  # no behavior asked for one
    assert 'data-state="learning"' in shown() and "force monitor: learning (0 samples)" in shown()
    judging = shown(judging=True, mu=0.3, c=0.01, band=1.0)
    assert 'data-state="judging"' in judging and "judging · mu 0.300, c 0.01 N · within ±1.00 N" in judging
    blind = shown(judging=False, not_judging="normal force 1.8 N < 3.3 N")
    assert 'data-state="blind"' in blind and "<b>not judging</b> (normal force 1.8 N &lt; 3.3 N)" in blind
    assert 'data-state="anomaly"' in shown(anomaly=True, not_judging=None)
    ended = shown(active_command=None, judging=True)  # the last behavior's, kept in telemetry
    assert "force monitor (last command, ended): judging" in ended and 'data-running="0"' in ended
    # From a recording the reason is data, never markup.
    crafted = shown(not_judging='<img src=x onerror="alert(1)">')
    assert "<img" not in crafted and "&lt;img src=x" in crafted


def test_the_port_and_the_twins_prediction_are_said_in_mm() -> None:
    state = robot_state()
    state["port"] = {**state["port"], "position": [0.4123, -0.0205, 0.3]}
    shown = str(_render(BarInputs(state, 100.1, True, LinkLine("fresh", ""), 0.0, "", ""), 0.1, "fresh"))
    assert "port (412.3, -20.5, 300.0) mm" in shown
    twin = str(_prediction_html((0.4123, -0.0205, 0.3), (0.0012, 0.0034), "off by 1.2 mm", True))
    assert 'data-x="412.30" data-y="-20.50" data-z="300.00"' in twin
    assert 'data-error-mm="1.200" data-max-mm="3.400"' in twin
    assert "twin: port (412.3, -20.5, 300.0) mm" in twin


def test_the_task_bar_fills_with_progress_and_for_an_error_with_target_over_error() -> None:
    assert _fraction_done(None, 30.0, False) == 0.0  # nothing known yet: empty, not full
    assert _fraction_done(12.0, 30.0, False) == 0.4
    assert _fraction_done(45.0, 30.0, False) == 1.0
    assert _fraction_done(10.0, 5.0, True) == 0.5  # an error of 10 to bring under 5
    assert _fraction_done(0.0, 0.0, True) == 1.0  # at its target of 0: full (and no 0 / 0)
    assert _fraction_done(None, 5.0, True) == 0.0
