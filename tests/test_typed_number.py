"""Number fields that keep what was typed (issue 27), without a browser: how a field's text is
read, what the robot's rules say of it at the field in its units, and what the panel then makes
of the request (nothing, while a field is not a number).

On main, viser's number inputs turned "1e9" into 19, "2.5e1" into 2.51, "0x10" into 10, "abc"
into the last value and a duration of "-5" into 0.01 s, and range errors were said above Send in
SI ("translation: magnitude must be <= 1 m, got 5" for 5000 mm typed)."""

import html
import math
from collections.abc import Iterator
from typing import Any

import pytest
import viser

from robot_sim.task_frames import TaskFrames
from web.checks import check_command
from web.defaults import load_defaults
from web.handshake import Catalog
from web.panel import Panel
from web.typed_number import (
    DEG,
    MM,
    SECONDS,
    FieldError,
    TypedNumber,
    TypedVector,
    format_number,
    in_field_units,
    parse_number,
    parse_vector,
)

NOT_A_NUMBER = "not a number (write e.g. 12.5 or 2.5e1)"


@pytest.mark.parametrize(
    ("typed", "value"),
    [
        ("15", 15.0),
        ("2.5e1", 25.0),  # not 2.51
        ("1e9", 1e9),  # not 19: the range rule refuses it, at the field
        ("-5", -5.0),  # not 0.01: the duration rule refuses it, at the field
        ("-.5", -0.5),
        ("+3.", 3.0),
        ("2.5E-3", 0.0025),
        (" 7 ", 7.0),  # spaces around are not part of a number
    ],
)
def test_a_decimal_reads_as_a_person_means_it(typed: str, value: float) -> None:
    assert parse_number(typed) == value


@pytest.mark.parametrize(
    ("typed", "reason"),
    [
        ("abc", NOT_A_NUMBER),
        ("15abc", NOT_A_NUMBER),  # not 15
        ("1e", NOT_A_NUMBER),
        ("1.2.3", NOT_A_NUMBER),
        ("0x10", "not a decimal number (0x, 0o and 0b are refused)"),  # not 10, not 16
        ("0b1", "not a decimal number (0x, 0o and 0b are refused)"),
        ("nan", "must be a finite number"),  # float() takes these three
        ("-inf", "must be a finite number"),
        ("Infinity", "must be a finite number"),
        ("1e999", "must be a finite number"),  # a decimal, past any float
        ("1_0", "no underscores: type the digits alone"),  # float() reads 10
        ("2,5", "use a point for decimals (2.5), and no thousands separators"),
        ("1,000", "use a point for decimals (2.5), and no thousands separators"),
        ("", "empty: type a number"),
        ("   ", "empty: type a number"),
    ],
)
def test_anything_else_is_refused_with_its_reason(typed: str, reason: str) -> None:
    with pytest.raises(FieldError) as refused:
        parse_number(typed)
    assert refused.value.reason == reason


def test_a_vector_is_three_numbers_and_names_the_one_that_is_not() -> None:
    assert parse_vector(["1", "-2.5", "3e1"]) == (1.0, -2.5, 30.0)
    with pytest.raises(FieldError) as short:
        parse_vector(["1", "2"])
    assert short.value.reason == "needs 3 components (x, y, z), got 2"
    with pytest.raises(FieldError) as bad:
        parse_vector(["1", "0x10", "abc"])
    assert bad.value.reason == "y: not a decimal number (0x, 0o and 0b are refused)"


def test_the_robots_words_in_the_fields_units() -> None:
    """The limits are the models' (robot_sim/params.py); only their units change."""
    said = in_field_units("magnitude must be <= 1 m, got 5", MM)
    assert said == "magnitude must be <= 1000 mm, got 5000 mm"
    assert in_field_units("must be in (0, 1] m, got 0.0005", MM) == "must be in (0, 1000] mm, got 0.5 mm"
    assert in_field_units("must be in (0, 600] s, got -5", SECONDS) == "must be in (0, 600] s, got -5 s"
    assert (
        in_field_units("magnitude must be <= 3.14159 rad, got 5", DEG)
        == "magnitude must be <= 180 deg, got 286.479 deg"
    )


def test_written_numbers_are_rounded_and_never_minus_zero() -> None:
    assert format_number(14.0) == "14"
    assert format_number(12.3456, 2) == "12.35"
    assert format_number(-0.0001, 2) == "0"
    assert format_number(0.1) == "0.1"


@pytest.fixture(scope="module")
def gui() -> Iterator[viser.GuiApi]:
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield server.gui
    server.stop()


@pytest.fixture
def panel(gui: viser.GuiApi) -> Panel:
    """A form as one browser gets it, in control, checked by the robot's own rules."""
    local = Catalog.local()
    presets = dict(local.presets)
    dither = presets.pop("dither")
    made = Panel(gui, load_defaults(), presets, dither, {t.name: t.summary for t in local.tasks})
    made.show_control(True, None)
    return made


def type_into(field: Any, *texts: str) -> None:
    """What the browser sends as the operator types: the text, as it is."""
    for handle, text in zip(field.inputs, texts, strict=True):
        handle.value = text


def recheck(panel: Panel, behavior: str = "ptwl") -> None:
    """As the desk does on every field update (web/desk.py recheck), without a robot state."""
    try:
        params = panel.params(behavior)
    except FieldError:
        panel.show_unreadable(behavior)
    else:
        panel.show_check(behavior, check_command(behavior, params, None, None, TaskFrames()))


def check_line(panel: Panel, behavior: str = "ptwl") -> str:
    """The check line's HTML, as the browser reads it."""
    return html.unescape(str(panel._requests[behavior].check_line.content))


def test_what_is_sent_is_the_typed_number_times_its_unit(panel: Panel) -> None:
    type_into(panel.ptwl.translation, "15", "-2.5e1", "0.5")
    type_into(panel.ptwl.rotation, "90", "0", "-45")
    type_into(panel.ptwl.typed["position_tolerance"], "2")
    type_into(panel.ptwl.typed["orientation_tolerance"], "1.5")
    type_into(panel.ptwl.typed["duration"], "3")
    params = panel.ptwl.params()
    assert params["translation"] == [15 / 1000, -25 / 1000, 0.5 / 1000]
    assert params["rotation"] == pytest.approx([math.pi / 2, 0.0, -math.pi / 4], abs=1e-15)
    assert params["position_tolerance"] == 2 / 1000
    assert params["orientation_tolerance"] == pytest.approx(math.radians(1.5), abs=1e-15)
    assert params["duration"] == 3.0
    recheck(panel)
    assert panel._valid["ptwl"] and not panel.ptwl.send.disabled
    assert "within the robot's limits" in check_line(panel)


@pytest.mark.parametrize("typed", ["abc", "0x10", "nan", "inf", "1_0", "2,5", ""])
def test_a_field_that_is_not_a_number_makes_no_request_and_sends_nothing(panel: Panel, typed: str) -> None:
    type_into(panel.ptwl.translation, "15", "0", "0")
    recheck(panel)
    assert not panel.ptwl.send.disabled
    type_into(panel.ptwl.translation, typed, "0", "0")
    assert panel.ptwl.translation.texts == (typed, "0", "0")  # kept as typed, not rewritten
    with pytest.raises(FieldError):
        panel.ptwl.params()  # never the last good value, 15 mm
    with pytest.raises(FieldError):
        panel.ptwl.values()  # no target to draw either
    recheck(panel)
    assert panel.ptwl.translation.reason.startswith("x: ")
    assert panel.ptwl.translation.reason_line.visible
    step = panel.ptwl.step
    assert panel.ptwl.send.disabled and step.send_step.disabled and step.preview.disabled
    line = check_line(panel)
    assert "within the robot" not in line and 'data-valid="0"' in line
    assert "Translation [mm]: x: " in line


@pytest.mark.parametrize(
    ("typed", "value_mm", "said"),
    [
        ("5000", 5000.0, "magnitude must be <= 1000 mm, got 5000 mm"),
        ("1e9", 1e9, "magnitude must be <= 1000 mm, got 1e+09 mm"),
    ],
)
def test_a_translation_out_of_range_is_refused_at_the_field_in_mm(
    panel: Panel, typed: str, value_mm: float, said: str
) -> None:
    type_into(panel.ptwl.translation, typed, "0", "0")
    assert panel.ptwl.translation.value == (value_mm, 0.0, 0.0)
    assert panel.ptwl.params()["translation"] == [value_mm / 1000, 0.0, 0.0]  # what the robot judges
    recheck(panel)
    assert panel.ptwl.translation.reason == said
    assert f"translation: {said}" in check_line(panel)  # not "<= 1 m, got 5"
    assert panel.ptwl.send.disabled and panel.ptwl.step.preview.disabled
    with pytest.raises(FieldError):
        panel.ptwl.values()  # no target drawn for a move that will not be sent
    type_into(panel.ptwl.translation, "2.5e1", "0", "0")  # a new text is judged anew
    recheck(panel)
    assert panel.ptwl.translation.reason == "" and not panel.ptwl.translation.reason_line.visible
    assert panel.ptwl.values()[0].tolist() == [0.025, 0.0, 0.0]
    assert not panel.ptwl.send.disabled


def test_a_negative_duration_is_refused_at_the_duration_field_in_seconds(panel: Panel) -> None:
    type_into(panel.ptwl.translation, "0", "0", "70")
    type_into(panel.ptwl.typed["duration"], "-5")
    assert panel.ptwl.params()["duration"] == -5.0  # not 0.01 s
    recheck(panel)
    assert panel.ptwl.typed["duration"].reason == "must be in (0, 600] s, got -5 s"
    assert panel.ptwl.translation.reason == ""
    assert panel.ptwl.send.disabled
    assert "m/s" not in check_line(panel)  # no impact speed from a duration nobody typed


def test_the_watchdog_is_written_as_the_robot_applies_it(panel: Panel) -> None:
    type_into(panel.ptwl.translation, "0", "0", "5")
    type_into(panel.ptwl.typed["duration"], "9")
    recheck(panel)
    assert panel.ptwl.settings.watchdog.texts == ("14",) and panel.ptwl.settings.watchdog.disabled
    type_into(panel.ptwl.typed["duration"], "abc")  # the auto watchdog is not read, nor rewritten
    recheck(panel)
    watchdog = panel.ptwl.settings.watchdog
    assert watchdog.texts == ("14",) and watchdog.reason_line.visible is False
    assert panel.ptwl.typed["duration"].reason == NOT_A_NUMBER


def test_a_rule_across_fields_is_said_at_the_field_it_names(panel: Panel) -> None:
    """The translational radius cap is a model rule (`body`), named for its field."""
    panel.dither.mode.value = "translational"
    type_into(panel.dither.typed["amplitude"], "30")
    recheck(panel, "dither")
    said = "amplitude must be in (0, 20] mm for translational mode, got 30 mm"
    assert panel.dither.typed["amplitude"].reason == said
    assert panel.dither.send.disabled
    type_into(panel.dither.typed["amplitude"], "15")
    recheck(panel, "dither")
    assert panel.dither.typed["amplitude"].reason == "" and not panel.dither.send.disabled
    assert panel.dither.params()["amplitude"] == 15 / 1000


def test_values_set_by_the_console_are_written_as_text_and_read_back_alike(panel: Panel) -> None:
    panel.ptwl.set_displacement([0.0123456, -0.0300001, 0.0], [0.0, 0.0, 0.2])  # type: ignore[arg-type]
    assert panel.ptwl.translation.texts == ("12.35", "-30", "0")
    assert panel.ptwl.rotation.texts == ("0", "0", "11.46")
    assert panel.ptwl.params()["translation"] == [12.35 / 1000, -30 / 1000, 0.0]
    preset = panel.dither.presets[str(panel.dither.preset.value)]
    panel.dither.fill_fields()
    assert panel.dither.typed["travel"].value == pytest.approx(preset["travel"] * 1000)
    assert panel.dither.params()["duration"] == preset["duration"]
    with pytest.raises(ValueError):
        panel.ptwl.translation.value = (1.0, 2.0)


def test_a_step_outside_the_move_is_refused_and_send_step_is_off(panel: Panel) -> None:
    type_into(panel.ptwl.translation, "0", "0", "5")
    recheck(panel)
    type_into(panel.ptwl.step.step_percent, "150")
    assert panel.ptwl.step.step_percent.reason == "must be in (0, 100] %, got 150 %"
    assert panel.ptwl.step.send_step.disabled and not panel.ptwl.send.disabled
    with pytest.raises(FieldError):
        panel.ptwl.step_params()
    type_into(panel.ptwl.step.step_percent, "5e1")
    assert not panel.ptwl.step.send_step.disabled
    assert panel.ptwl.step_params()["translation"] == [0.0, 0.0, 0.5 * 5 / 1000]


def test_a_typed_frame_pose_that_is_not_numbers_is_not_added(panel: Panel) -> None:
    type_into(panel.frames.new_frame_position, "400", "abc", "300")
    assert (
        panel.frames.add_frame_typed.disabled
        and panel.frames.new_frame_position.reason == f"y: {NOT_A_NUMBER}"
    )
    with pytest.raises(FieldError):
        panel.frames.typed_pose()
    type_into(panel.frames.new_frame_position, "400", "0", "300")
    assert not panel.frames.add_frame_typed.disabled
    assert panel.frames.typed_pose()["position"] == [0.4, 0.0, 0.3]


def test_a_vector_written_by_the_console_is_heard_once_and_typing_always(panel: Panel) -> None:
    """A gizmo drag writes three components: one recheck, not three; an unchanged write, none."""
    heard: list[object] = []
    panel.ptwl.translation.on_update(heard.append)
    panel.ptwl.translation.value = (1.0, 2.0, 3.0)
    assert len(heard) == 1 and panel.ptwl.translation.texts == ("1", "2", "3")
    panel.ptwl.translation.value = (1.0, 2.0, 3.0)
    assert len(heard) == 1
    type_into(panel.ptwl.translation, "4", "2", "3")  # as the browser's updates arrive: each one heard
    assert len(heard) == 2


def test_a_field_writes_three_decimals_and_the_robots_refusals_of_one_text_add_up(gui: viser.GuiApi) -> None:
    """Written by the console with three decimals unless told; two rules refusing the same text
    are both said under it, a new text is judged anew, and clear() forgets what was refused."""
    duration = TypedNumber(gui, "duration", "Duration [s]", 2.0 / 3.0, SECONDS)
    assert duration.texts == ("0.667",)
    duration.value = 1.23456
    assert duration.texts == ("1.235",)
    translation = TypedVector(gui, "translation", "Translation [mm]", (1.0 / 3.0, 0.0, 2.5), MM)
    assert translation.texts == ("0.333", "0", "2.5")
    translation.value = (0.0, 12.3456, 0.0)
    assert translation.texts == ("0", "12.346", "0")

    assert duration.refuse("must be > 0 s, got 1.235") == "must be > 0 s, got 1.235 s"
    duration.refuse("must be <= 1 s, got 1.235")
    assert duration.reason == "must be > 0 s, got 1.235 s; must be <= 1 s, got 1.235 s"
    duration.show()  # shown under the field ...
    assert duration.reason_line.visible and "must be &lt;= 1 s" in str(duration.reason_line.content)
    duration.show(active=False)  # ... and hidden while the field is not in use
    assert not duration.reason_line.visible
    type_into(duration, "0.5")
    assert duration.reason == ""  # judged anew
    duration.refuse("must be <= 0.4 s, got 0.5")
    assert duration.reason == "must be <= 0.4 s, got 0.5 s"  # not added to the old text's
    duration.clear()
    assert duration.reason == ""
