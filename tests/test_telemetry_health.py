"""The link line says what the telemetry shows (issue 27.3): on main a drop blackout that lost 448
messages kept "link round trip 3 s · connected" on the bar."""

import pytest

from web.telemetry_health import SHOW_GAP_S, SILENT_AFTER_S, TelemetryHealth

PERIOD_S = 0.02  # the robot's 50 Hz


def flowing(health: TelemetryHealth, seqs: range, t0: float) -> float:
    """States `seqs` sent every PERIOD_S from t0, each arriving 1.5 s later; the last arrival."""
    arrived = t0
    for seq in seqs:
        sent_at = t0 + seq * PERIOD_S
        arrived = sent_at + 1.5
        health.on_state(seq, sent_at, arrived)
    return arrived


def test_a_silent_stream_on_a_connected_link_says_so_and_counts_what_is_missing() -> None:
    health = TelemetryHealth()
    health.on_transport(True, "connected")
    last = flowing(health, range(0, 100), 1000.0)
    assert health.period_s == pytest.approx(PERIOD_S)
    line = health.line(3.0, last + 0.5)
    assert line.level == "fresh"
    assert line.text == "link round trip 3 s · connected · telemetry flowing (0 lost in all)"
    line = health.line(3.0, last + 9.0)  # a blackout: the transport still says connected
    assert line.level == "stale"
    assert "no telemetry for 9.0 s (~450 messages lost)" in line.text and "connected" in line.text
    assert health.line(3.0, last + SILENT_AFTER_S * 0.9).level == "fresh"


def test_after_the_gap_the_exact_count_from_the_sequence_numbers() -> None:
    health = TelemetryHealth()
    health.on_transport(True, "connected")
    flowing(health, range(0, 50), 1000.0)
    assert health.on_state(498, 1000.0 + 498 * PERIOD_S, 1011.46) == 448
    line = health.line(3.0, 1012.0)
    assert line.level == "late" and "448 messages lost in a gap 1 s ago" in line.text
    assert "(448 lost in all)" in line.text
    assert health.line(3.0, 1011.46 + SHOW_GAP_S + 0.5).level == "stale"  # silent since, too
    flowing(health, range(499, 520), 1000.0)
    later = health.line(3.0, 1000.0 + 520 * PERIOD_S + 1.5)
    assert later.level == "late"
    assert health.lost == 448
    # A restarted robot counts again from 0: nothing was lost.
    assert health.on_state(0, 2000.0, 2001.5) == 0 and health.lost == 448


def test_a_dropped_transport_says_why_and_for_how_long() -> None:
    health = TelemetryHealth()
    assert health.line(0.0, 5.0).text == "link round trip 0 s · connecting"
    health.on_transport(True, "connected")
    assert health.line(0.0, 5.0).text.endswith("connected; no telemetry yet")
    last = flowing(health, range(0, 10), 1000.0)
    health.on_transport(False, "no telemetry: the connection to the link dropped; reconnecting")
    line = health.line(0.0, last + 4.0)
    assert line.level == "stale" and line.text.endswith("reconnecting (nothing for 4.0 s)")
