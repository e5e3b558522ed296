"""Bad parameters raise errors that name the field and the allowed range."""

import math

import pytest
from pydantic import ValidationError

from robot_sim.params import DitherParams, GainsSpec, PtwlParams, RweParams


def error_text(model: type, **fields: object) -> str:
    with pytest.raises(ValidationError) as err:
        model(**fields)
    return str(err.value)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_duration_names_field_and_range(value: float) -> None:
    text = error_text(PtwlParams, duration=value)
    assert "duration" in text and "finite" in text and "(0, 600] s" in text


@pytest.mark.parametrize("value", [-1.0, 0.0, 601.0])
def test_duration_outside_range(value: float) -> None:
    text = error_text(PtwlParams, duration=value)
    assert "duration" in text and "(0, 600] s" in text


def test_non_finite_vector_component() -> None:
    text = error_text(PtwlParams, translation=[0.0, math.nan, 0.0])
    assert "translation" in text and "component 1 must be a finite number" in text


def test_absurd_displacements() -> None:
    assert "magnitude must be <= 1 m" in error_text(PtwlParams, translation=[0.9, 0.9, 0.0])
    assert "magnitude must be <= 3.14159 rad" in error_text(PtwlParams, rotation=[0.0, 0.0, 4.0])


@pytest.mark.parametrize(
    ("field", "allowed"),
    [
        ("force_threshold", "(0, 500] N"),
        ("torque_threshold", "(0, 50] N m"),
        ("position_tolerance", "(0, 1] m"),
        ("orientation_tolerance", "(0, 3.14159] rad"),
    ],
)
def test_thresholds_must_be_positive_and_capped(field: str, allowed: str) -> None:
    for bad in (0.0, 1e308) if "inf" not in allowed else (0.0,):
        text = error_text(PtwlParams, **{field: bad})
        assert field in text and allowed in text


def test_watchdog_shorter_than_duration() -> None:
    assert "watchdog (1 s) must be >= duration (2 s)" in error_text(PtwlParams, duration=2.0, watchdog=1.0)
    assert PtwlParams(duration=2.0).watchdog == 7.0


@pytest.mark.parametrize(
    ("index", "damping", "expected"),
    [
        (0, 0.0, "damping[0] (x) must be > 0 N s/m"),
        (1, -5.0, "damping[1] (y) must be > 0 N s/m"),
        (2, 100.0, "damping[2] (z) must be in [200, 50000] N s/m"),
        (4, 5.0, "damping[4] (ry) must be in [20, 2000] N m s/rad"),
    ],
)
def test_damping_outside_the_stable_range(index: int, damping: float, expected: str) -> None:
    b = [1000.0, 1000.0, 1000.0, 50.0, 50.0, 50.0]
    b[index] = damping
    assert expected in error_text(GainsSpec, stiffness=[100.0] * 3 + [10.0] * 3, damping=b)
    assert expected in error_text(PtwlParams, stiffness=[100.0] * 3 + [10.0] * 3, damping=b)


def test_negative_stiffness_and_too_short_time_constant() -> None:
    b = [1000.0] * 3 + [50.0] * 3
    assert "stiffness[0] (x) must be in [0, 20000] N/m" in error_text(
        GainsSpec, stiffness=[-1.0] + [0.0] * 5, damping=b
    )
    text = error_text(GainsSpec, stiffness=[20000.0] + [0.0] * 5, damping=[900.0] + b[1:])
    assert "damping[0]/stiffness[0] (x) must be >= 0.3 s" in text


def test_unknown_presets_list_the_valid_names() -> None:
    assert "unknown stiffness preset 'bouncy'; valid: hinge, medium, planar, soft, stiff" in error_text(
        PtwlParams, preset="bouncy"
    )
    text = error_text(DitherParams, preset="wobble")
    assert "unknown dither preset 'wobble'; valid: torsional_pull, torsional_push" in text


def test_gains_choice_is_one_or_the_other() -> None:
    assert "either preset or stiffness/damping" in error_text(
        PtwlParams, preset="soft", stiffness=[0.0] * 6, damping=[1000.0] * 3 + [50.0] * 3
    )
    assert "stiffness and damping go together" in error_text(PtwlParams, stiffness=[0.0] * 6)


def test_rwe_axes() -> None:
    assert "axes" in error_text(RweParams, axes=[])
    assert "axes must not repeat" in error_text(RweParams, axes=["x", "x"])
    assert "'x', 'y', 'z', 'rx', 'ry' or 'rz'" in error_text(RweParams, axes=["w"])
    assert RweParams(axes=["x", "rz"]).axis_mask() == [True, False, False, False, False, True]


def test_dither_checks() -> None:
    assert "must be a non-zero direction" in error_text(DitherParams, axis=[0.0, 0.0, 0.0])
    assert "frequency" in error_text(DitherParams, frequency=0.0)
    assert "(0, 0.02] m for translational" in error_text(DitherParams, mode="translational", amplitude=0.1)


def test_unknown_fields_are_refused() -> None:
    assert "Extra inputs are not permitted" in error_text(PtwlParams, translaton=[0, 0, 0.01])
