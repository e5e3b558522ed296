"""The link line says what the telemetry shows (issue 27.3): on main a drop blackout that lost 448
messages kept "link round trip 3 s · connected" on the bar."""

import itertools

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


def test_the_line_s_edges_in_numbers_one_lost_message_a_repeated_state_and_the_30_s_of_a_gap() -> None:
    """Silent after 1 s (a state is due every 20 ms), even one lost message counted, a repeated
    state (a paused replay sends the same one again) neither lost nor a new period, and a gap's
    count shown for 30 s, then the line is fresh again."""
    health = TelemetryHealth()
    assert health.silent_s(1000.0) is None  # nothing yet
    health.on_transport(True, "connected")
    last = flowing(health, range(0, 10), 1000.0)
    assert health.silent_s(last + 2.5) == pytest.approx(2.5)
    assert health.line(3.0, last + 0.99).level == "fresh"
    assert health.line(3.0, last + 1.01).level == "stale"
    # The same state again: nothing lost, the period unchanged, no gap.
    assert health.on_state(9, 1000.0 + 9 * PERIOD_S, last + 0.1) == 0
    assert health.period_s == pytest.approx(PERIOD_S) and health.last_gap is None
    # One message lost (10 never came): counted, shown for 30 s.
    ended_at = 1000.0 + 11 * PERIOD_S + 1.5
    assert health.on_state(11, 1000.0 + 11 * PERIOD_S, ended_at) == 1
    assert health.lost == 1 and health.last_gap is not None and health.last_gap.lost == 1
    seqs = itertools.count(12)  # the next states, one after another: no gap of their own
    for after_s, level, shown in ((5.0, "late", True), (29.0, "late", True), (31.0, "fresh", False)):
        now = ended_at + after_s
        assert health.on_state(next(seqs), now - 1.5, now) == 0  # a state just arrived: flowing
        line = health.line(3.0, now)
        assert line.level == level, (after_s, line)
        assert ("1 messages lost in a gap" in line.text) is shown, (after_s, line)
