"""A direction's statistics, judged on releases given by hand: the counts a soak reads to say that
nothing left early and nothing was reordered, and the percentiles of its delays."""

from collections import deque

import pytest

from latency.delay_line import Entry
from latency.stats import DirectionStats, _percentiles


def entry(seq: int, arrival: float, release_at: float) -> Entry:
    return Entry(seq, "downlink", "state", 100, arrival, release_at, release_at - arrival, 1)


def test_a_message_released_before_a_later_seq_is_counted_reordered_unless_reorder_is_on() -> None:
    stats = DirectionStats()
    for seq in (1, 3, 2, 4, 2):  # 2 after 3, then 2 again after 4: two out of order
        stats.on_release(entry(seq, 0.0, 1.0), 1.0, reorder_allowed=False)
    assert (stats.released, stats.reorderings) == (5, 2)
    allowed = DirectionStats()
    for seq in (1, 3, 2):
        allowed.on_release(entry(seq, 0.0, 1.0), 1.0, reorder_allowed=True)
    assert allowed.reorderings == 0


def test_a_release_before_its_time_is_counted_early_and_its_delays_are_kept() -> None:
    stats = DirectionStats()
    stats.on_release(entry(1, 10.0, 11.0), 10.999, reorder_allowed=False)  # 1 ms early
    stats.on_release(entry(2, 10.0, 11.0), 11.25, reorder_allowed=False)  # 0.25 s late
    stats.on_release(entry(3, 10.0, 11.0), 11.0, reorder_allowed=False)  # on the dot: not early
    assert stats.early_releases == 1
    assert list(stats._realized) == pytest.approx([0.999, 1.25, 1.0])
    assert list(stats._holding_error) == pytest.approx([-0.001, 0.25, 0.0])
    assert list(stats._configured) == [1.0, 1.0, 1.0]


def test_percentiles_are_the_nearest_ranks_and_none_without_releases() -> None:
    assert _percentiles(deque()) == {"p50": None, "p95": None, "p99": None, "max": None}
    assert _percentiles(deque(float(v) for v in range(101, 0, -1))) == {
        "p50": 51.0,
        "p95": 96.0,
        "p99": 100.0,
        "max": 101.0,
    }


def test_the_delays_kept_for_percentiles_are_the_newest_20000() -> None:
    """A soak's link releases for hours: its percentiles are of a bounded recent window."""
    stats = DirectionStats()
    for seq in range(1, 20_002):
        stats.on_release(entry(seq, 0.0, 1.0), 1.0 + seq * 1e-6, reorder_allowed=False)
    assert len(stats._realized) == len(stats._configured) == len(stats._holding_error) == 20_000
    assert stats._holding_error[0] == pytest.approx(2e-6)  # the first release is gone
