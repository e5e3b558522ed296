"""One table says how bad each exit is (issue 28: three tables disagreed: `anomaly` was Info in
MCAP and a warning in the README, `failed` had no colour in the console)."""

import re
from pathlib import Path

from foxglove.messages import LogLevel

from ptwl.recording.well_known import log_level
from robot_sim.behaviors.base import ExitCondition
from robot_sim.exit_severity import EXIT_SEVERITY, Severity, severity
from web.history import exit_color_hex
from web.notifier import exit_color

ROBOT_DOC = Path(__file__).resolve().parents[1] / "docs" / "robot.md"  # the severity table lives there


def test_every_exit_has_a_severity_and_anything_unknown_is_an_error() -> None:
    assert set(EXIT_SEVERITY) == set(ExitCondition)
    assert severity("anomaly") is Severity.WARNING and severity("failed") is Severity.WARNING
    assert severity("refused") is Severity.ERROR and severity(None) is Severity.ERROR


def test_the_robot_docs_list_the_table() -> None:
    rows = re.findall(r"^\| (success|notice|warning|error) \| (.+) \|$", ROBOT_DOC.read_text(), re.M)
    names = [(level, name) for level, listed in rows for name in re.findall(r"`(\w+)`", listed)]
    listed = {ExitCondition(name): Severity(level) for level, name in names}
    assert listed == EXIT_SEVERITY


def test_console_and_recording_tell_each_exit_at_its_severity() -> None:
    toast = {"success": "green", "notice": "blue", "warning": "orange", "error": "red"}
    history = {"success": "#2f9e44", "notice": "#ae3ec9", "warning": "#e8590c", "error": "#e03131"}
    log = {
        "success": LogLevel.Info,
        "notice": LogLevel.Warning,
        "warning": LogLevel.Warning,
        "error": LogLevel.Error,
    }
    for exit_condition, level in EXIT_SEVERITY.items():
        assert exit_color(exit_condition) == toast[level], exit_condition
        assert exit_color_hex(exit_condition) == history[level], exit_condition
        assert log_level(exit_condition) == log[level], exit_condition
    assert log_level(None) == LogLevel.Info  # a change that is not an end
