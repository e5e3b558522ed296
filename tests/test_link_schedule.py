"""The link's schedule and bandwidth on a simulated clock: contact windows (store and forward, or
drop), a drifting or piecewise delay, serialisation at a rate, states replaced on a narrow
downlink, an ION contact plan, and the outlook the console counts down from."""

import itertools
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import ValidationError

from latency.clock import SimulatedLink
from latency.delay_line import Dropped, Entry, Parked
from latency.named import named_profile
from latency.plan_file import PlanFileError, read_schedule
from latency.profile import LinkProfile
from latency.record import McapRecorder
from latency.schedule import Plan
from ptwl.guard.outbox import Outbox
from ptwl.recording import topics
from ptwl.recording.reader import read
from ptwl.recording.report import report_text
from ptwl.recording.writer import SessionRecorder
from tests.fake_clock import FakeClock


def gap_profile(mode: str = "store", **extra: Any) -> LinkProfile:
    """In contact [0, 10) and [20, 100); 0.5 s each way."""
    schedule = {"contacts": [{"start": 0.0, "end": 10.0}, {"start": 20.0, "end": 100.0}], "mode": mode}
    return LinkProfile.model_validate({"uplink": 0.5, "downlink": 0.5, "schedule": schedule, **extra})


def released(sim: SimulatedLink, direction: str = "downlink") -> list[tuple[float, Entry]]:
    return [(t, e) for t, e in sim.released if e.direction == direction]


def test_messages_sent_in_a_gap_are_held_and_forwarded_in_order_at_the_next_contact() -> None:
    sim = SimulatedLink(gap_profile())
    for t in (5.0, 9.9, 12.0, 13.0, 19.99, 25.0):
        sim.send(t, "downlink")
    sim.advance_to(60.0)
    out = released(sim)
    assert [round(t, 9) for t, _ in out] == [5.5, 10.4, 20.5, 20.5, 20.5, 25.5]
    assert [e.seq for _, e in out] == [1, 2, 3, 4, 5, 6]
    held = out[2][1]
    assert held.waits == {"contact_gap": pytest.approx(8.0), "delay": pytest.approx(0.5)}
    assert out[0][1].waits == {"delay": pytest.approx(0.5)}  # sent in contact: the delay only


def test_drop_mode_loses_what_is_sent_between_contacts_and_says_why() -> None:
    sim = SimulatedLink(gap_profile("drop"))
    outcomes = [sim.send(t, "uplink") for t in (5.0, 12.0, 19.99, 20.0)]
    assert [type(o) for o in outcomes] == [Entry, Dropped, Dropped, Entry]
    assert {o.reason for o in outcomes if isinstance(o, Dropped)} == {"contact_gap"}
    assert sim.link.stats_view()["uplink"]["dropped"]["contact_gap"] == 2


def test_a_link_that_never_opens_again_drops_with_no_contact() -> None:
    profile = LinkProfile.model_validate({"schedule": {"contacts": [{"start": 0.0, "end": 10.0}]}})
    sim = SimulatedLink(profile)
    assert isinstance(sim.send(5.0, "downlink"), Entry)
    lost = sim.send(11.0, "downlink")
    assert isinstance(lost, Dropped) and lost.reason == "no_contact"


def test_a_rate_serialises_each_message_behind_the_one_before() -> None:
    """netem's `rate`: a message of N bytes leaves the wire N / rate after its predecessor."""
    sim = SimulatedLink(LinkProfile(uplink=0.1, uplink_bytes_per_s=1000.0))
    for size in (500, 250, 1000):
        sim.send(0.0, "uplink", size=size)
    sim.send(3.0, "uplink", size=100)  # the wire is free again by then: no queue
    sim.advance_to(10.0)
    out = released(sim, "uplink")
    assert [round(t, 9) for t, _ in out] == [0.6, 0.85, 1.85, 3.2]
    assert out[1][1].waits == {
        "queue": pytest.approx(0.5),
        "serialization": pytest.approx(0.25),
        "delay": pytest.approx(0.1),
    }
    assert "queue" not in out[3][1].waits


def test_a_message_that_cannot_finish_before_the_gap_waits_for_the_next_contact() -> None:
    """ION does not begin a bundle its contact cannot finish: 1500 B at 1000 B/s needs 1.5 s,
    and 1 s is left; the message behind it keeps its place."""
    sim = SimulatedLink(gap_profile(downlink_bytes_per_s=1000.0))
    sim.send(9.0, "downlink", size=1500)
    sim.send(9.1, "downlink", size=100)
    sim.advance_to(60.0)
    (t1, first), (t2, _) = released(sim)
    assert t1 == pytest.approx(20.0 + 1.5 + 0.5)
    assert t2 == pytest.approx(20.0 + 1.5 + 0.1 + 0.5)
    assert first.waits["contact_gap"] == pytest.approx(11.0)


def test_a_window_rate_overrides_the_profile_rate() -> None:
    schedule = {
        "contacts": [{"start": 0.0, "end": 10.0, "rate_bytes_per_s": 100.0}, {"start": 10.0, "end": 50.0}]
    }
    profile = LinkProfile.model_validate({"downlink_bytes_per_s": 1000.0, "schedule": schedule})
    sim = SimulatedLink(profile)
    sim.send(1.0, "downlink", size=100)
    sim.send(20.0, "downlink", size=100)
    sim.advance_to(60.0)
    assert [round(t, 9) for t, _ in released(sim)] == [2.0, 20.1]


def test_a_drifting_delay_is_the_schedule_at_ten_points() -> None:
    """A constant plus a drift rate (the Earth's turning, at its fastest)."""
    drift = 1.5e-6
    profile = LinkProfile.model_validate({"downlink": 1.28, "schedule": {"drift_s_per_s": drift}})
    sim = SimulatedLink(profile)
    times = [float(t) for t in np.linspace(0.0, 7200.0, 10)]
    for t in times:
        sim.send(t, "downlink")
    sim.advance_to(8000.0)
    realized = [t - e.arrival for t, e in released(sim)]
    expected = [1.28 + drift * t for t in times]
    assert np.max(np.abs(np.subtract(realized, expected))) < 1e-9
    assert realized[-1] - realized[0] == pytest.approx(drift * 7200.0)  # 10.8 ms over two hours


def test_earth_moon_drifts_over_a_day_within_its_swing_at_ten_points() -> None:
    profile = named_profile("earth_moon").merged({"jitter": {"distribution": "none"}})
    assert profile.schedule is not None
    at = [p.at for p in profile.schedule.delay]
    one_way = [p.one_way_s for p in profile.schedule.delay]
    sim = SimulatedLink(profile)
    times = [float(t) for t in np.linspace(0.0, 2 * 86400.0, 10)]
    for t in times:
        sim.send(t, "downlink")
    sim.advance_to(2 * 86400.0 + 10.0)
    realized = [t - e.arrival for t, e in released(sim)]
    expected = [float(np.interp(t % 86400.0, at, one_way)) for t in times]
    assert realized == pytest.approx(expected, abs=1e-9)
    assert min(realized) >= 1.259 and max(realized) <= 1.301
    trend = Plan(profile.schedule, "downlink", 1.28, None, 0.0).trend(1000.0)
    assert trend == pytest.approx((1.2948 - 1.28) / 10800.0)  # 4.9 ms an hour, rising


def test_piecewise_delay_follows_its_points_and_repeats_with_the_period() -> None:
    profile = named_profile("lunar_far_side_relay").merged({"uplink_bytes_per_s": None})
    sim = SimulatedLink(profile)
    # In contact [0, 1500) of every 7200 s; 1.31 -> 1.29 -> 1.31 s over the pass.
    for t in (0.0, 375.0, 750.0, 1125.0, 7200.0 + 375.0):
        sim.send(t, "uplink", size=1)
    sim.advance_to(9000.0)
    realized = [t - e.arrival for t, e in released(sim, "uplink")]
    assert realized == pytest.approx([1.31, 1.30, 1.29, 1.30, 1.30], abs=1e-9)


def test_the_plan_starts_where_the_trial_is_put_in_the_pass() -> None:
    """A sweep's trial starts at a seeded point of the pass: 1495 s into the relay's 1500 s
    contact, a message sent 10 s later waits for the next pass."""
    profile = named_profile("lunar_far_side_relay")
    sim = SimulatedLink(profile, plan_offset_s=1495.0)
    sim.send(10.0, "uplink", size=10)
    sim.advance_to(8000.0)
    ((t, entry),) = released(sim, "uplink")
    assert entry.waits["contact_gap"] == pytest.approx(7200.0 - 1505.0)
    assert t == pytest.approx(7200.0 - 1495.0 + 10 / 1000.0 + 1.31)  # next pass + 10 B at 1 kB/s + delay


def test_on_a_2_kB_s_downlink_states_are_replaced_and_events_keep_their_order() -> None:
    """50 Hz states of 1000 B (50 kB/s offered) and an event of 1500 B every second, for a
    minute, on 2000 B/s: events all arrive, in order, delayed by the link's delay and the wire
    alone (never a growing queue); the newest state wins the wire, and the state age at the
    receiver stays bounded."""
    one_way_s, rate = 0.5, 2000.0
    sim = SimulatedLink(LinkProfile(downlink=one_way_s, downlink_bytes_per_s=rate))
    for i in range(60 * 50):
        t = i * 0.02
        state = sim.send(t, "downlink", size=1000, kind="state", replace_key="client-1")
        assert isinstance(state, Entry | Parked)
        if i % 50 == 25:
            sim.send(t, "downlink", size=1500, kind="event")
    sim.advance_to(70.0)
    out = released(sim)
    events = [(t, e) for t, e in out if e.kind == "event"]
    states = [(t, e) for t, e in out if e.kind == "state"]
    assert len(events) == 60
    assert [e.seq for _, e in events] == sorted(e.seq for _, e in events)
    # An event waits at most for the state on the wire ahead of it, then its own 0.75 s.
    worst_event_s = max(t - e.arrival for t, e in events)
    assert worst_event_s <= one_way_s + (1000 + 1500) / rate + 1e-9
    # States: the age of the newest one the receiver has, sampled every 0.1 s after the first.
    ages = []
    for now in np.arange(states[0][0], 60.0, 0.1):
        newest = max(e.arrival for t, e in states if t <= now)
        ages.append(now - newest)
    # Events take 75% of the wire (1500 B/s), so a state gets it every other second at worst:
    # 2 s between states + 0.5 s on the wire + 0.5 s delay.
    assert 2.5 < max(ages) <= 3.0 + 1e-9
    assert max(ages[-100:]) <= max(ages[:100]) + 1e-9  # the last 10 s no older than the first
    superseded = sim.link.stats_view()["downlink"]["dropped"]["superseded"]
    assert superseded > 2500 and len(states) + superseded == 60 * 50
    assert sim.link.stats_view()["downlink"]["held_now"]["parked_states"] == 0


def test_states_held_through_a_gap_do_not_pile_up() -> None:
    """Over a 10 s loss of signal only the newest state waits (events are all stored)."""
    sim = SimulatedLink(gap_profile())
    for i in range(500, 1500):  # 10-30 s at 50 Hz, across the gap [10, 20)
        sim.send(i * 0.02, "downlink", kind="state", replace_key="c")
    sim.advance_to(40.0)
    out = released(sim)
    from_the_gap = [(t, e) for t, e in out if e.arrival < 20.0]
    assert len(from_the_gap) == 1
    ((t, newest),) = from_the_gap
    assert (t, newest.arrival) == (pytest.approx(20.5), pytest.approx(19.98))
    assert newest.waits["contact_gap"] == pytest.approx(0.02)
    assert len(out) == 1 + 500  # the gap's newest, then every state sent in contact
    assert sim.link.stats_view()["downlink"]["dropped"]["superseded"] == 499


def test_a_blackout_counts_from_when_its_profile_took_effect_not_from_clock_zero() -> None:
    """A link whose clock reads 1000 s when the profile is set: its blackout at +10 s for 5 s is
    the clock's [1010, 1015)."""
    sim = SimulatedLink(LinkProfile(blackouts=[{"start": 10.0, "duration": 5.0}]), start=1000.0)
    sim.advance_to(1009.0)
    down = sim.link.outlook(now_unix=5_000.0)["downlink"]
    assert (down["in_contact"], down["changes_in_s"]) == (True, pytest.approx(1.0))
    sim.advance_to(1012.0)
    down = sim.link.outlook(now_unix=5_000.0)["downlink"]
    assert (down["in_contact"], down["changes_in_s"]) == (False, pytest.approx(3.0))
    assert down["closed_since_unix"] == pytest.approx(5_000.0 - 2.0)


def test_outlook_counts_down_to_the_next_loss_of_signal_and_back() -> None:
    profile = named_profile("leo_tdrs")
    sim = SimulatedLink(profile)
    sim.advance_to(100.0)
    down = sim.link.outlook(now_unix=1_000_000.0)["downlink"]
    assert down["in_contact"] is True
    assert down["changes_in_s"] == pytest.approx(2590.0)
    assert down["changes_at_unix"] == pytest.approx(1_002_590.0)
    assert down["next_gap_s"] == pytest.approx(10.0)
    assert down["closed_since_unix"] is None
    sim.advance_to(2694.0)
    down = sim.link.outlook(now_unix=2_000_000.0)["downlink"]
    assert down["in_contact"] is False
    assert down["changes_in_s"] == pytest.approx(6.0)
    assert down["closed_since_unix"] == pytest.approx(2_000_000.0 - 4.0)
    # The second handover, across the period's end: [5390, 5400) then the next orbit.
    sim.advance_to(5000.0)
    assert sim.link.outlook(0.0)["uplink"]["changes_in_s"] == pytest.approx(390.0)
    assert sim.link.outlook(0.0)["uplink"]["next_gap_s"] == pytest.approx(10.0)


def test_outlook_sees_blackouts_and_the_delay_trend() -> None:
    profile = LinkProfile.model_validate(
        {
            "downlink": 1.0,
            "blackouts": [{"start": 50.0, "duration": 5.0, "period": 100.0}],
            "schedule": {"drift_s_per_s": 1e-4},
        }
    )
    sim = SimulatedLink(profile)
    sim.advance_to(10.0)
    down = sim.link.outlook(0.0)["downlink"]
    assert (down["changes_in_s"], down["next_gap_s"]) == (pytest.approx(40.0), pytest.approx(5.0))
    assert down["one_way_s"] == pytest.approx(1.001) and down["trend_s_per_s"] == pytest.approx(1e-4)
    sim.advance_to(152.0)
    down = sim.link.outlook(0.0)["downlink"]
    assert down["in_contact"] is False and down["changes_in_s"] == pytest.approx(3.0)


ION_PLAN = """\
# ground (1) and robot (2): two passes, 1.3 s then 1.4 s light time
m production 1000000
a contact +0 +600 1 2 4000
a contact +0 +600 2 1 16000
a contact +1800 +2400 1 2 4000
a contact +1800 +2400 2 1 16000
a contact +0 +600 2 3 99
a range +0 +1200 1 2 1.3
a range +1200 +2400 1 2 1.4
"""

TOML_PLAN = """\
contacts = [
    { start = 0.0, end = 600.0, direction = "uplink", rate_bytes_per_s = 4000.0 },
    { start = 0.0, end = 600.0, direction = "downlink", rate_bytes_per_s = 16000.0 },
    { start = 1800.0, end = 2400.0, direction = "uplink", rate_bytes_per_s = 4000.0 },
    { start = 1800.0, end = 2400.0, direction = "downlink", rate_bytes_per_s = 16000.0 },
]
delay = [
    { at = 0.0, one_way_s = 1.3 }, { at = 1200.0, one_way_s = 1.3 },
    { at = 1200.0, one_way_s = 1.4 }, { at = 2400.0, one_way_s = 1.4 },
]
"""


def test_an_ion_contact_plan_gives_the_same_windows_as_its_toml(tmp_path: Path) -> None:
    (tmp_path / "plan.ion").write_text(ION_PLAN)
    (tmp_path / "plan.toml").write_text(TOML_PLAN)
    ion, toml = read_schedule(tmp_path / "plan.ion"), read_schedule(tmp_path / "plan.toml")
    assert ion == toml
    for direction, rate in (("uplink", 4000.0), ("downlink", 16000.0)):
        plan = Plan(ion, direction, 0.0, None, 0.0)
        probes = [0.0, 599.0, 600.0, 1000.0, 1800.0, 2399.0, 2400.0]
        assert [plan.window_at(t) is not None for t in probes] == [
            True,
            True,
            False,
            False,
            True,
            True,
            False,
        ]
        assert plan.rate(100.0) == rate
        assert plan.next_open(700.0) == 1800.0
    plan = Plan(ion, "downlink", 0.0, None, 0.0)
    assert [plan.one_way_s(t) for t in (0.0, 1199.0, 1200.0, 1900.0)] == [1.3, 1.3, 1.4, 1.4]


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        (
            "a contact 2026/11/27-12:00:00 +600 1 2 100\n",
            r"plan.ion:1: time '2026/11/27-12:00:00' is absolute",
        ),
        ("# c\na contact +0 +600 1 2\n", r"plan.ion:2: `a contact` needs \+START \+END FROM TO VALUE"),
        ("a contact +0 +600 1 2 fast\n", r"plan.ion:1: rate 'fast' is not a number"),
        ("a contact +0 +600 3 4 100\n", r"no contact between nodes 1 and 2"),
        ("a contact +0 +600 1 x 100\n", r"plan.ion:1: node numbers must be integers, got \['1', 'x'\]"),
        ("a contact +600 +0 1 2 100\n", r"contacts.0: end \(0 s\) must be after start \(600 s\)"),
    ],
)
def test_a_bad_contact_plan_is_refused_naming_its_line(tmp_path: Path, text: str, fragment: str) -> None:
    (tmp_path / "plan.ion").write_text(text)
    with pytest.raises(PlanFileError, match=fragment):
        read_schedule(tmp_path / "plan.ion")


def test_a_plan_file_is_read_up_to_4_mib(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A file is read whole: one larger than 4 MiB is refused before it is read."""
    contact = "a contact +0 +600 1 2 100\na contact +0 +600 2 1 100\n"
    at_bound = tmp_path / "plan.ion"
    at_bound.write_text(contact + "#" * (4 * 2**20 - len(contact) - 1) + "\n")
    assert at_bound.stat().st_size == 4 * 2**20 and read_schedule(at_bound).contacts
    over = tmp_path / "big.ion"
    over.write_text(contact + "#" * (4 * 2**20 - len(contact)) + "\n")

    def not_read(*_: object, **__: object) -> str:
        raise AssertionError("an oversized plan file was read")

    monkeypatch.setattr(Path, "read_text", not_read)
    monkeypatch.setattr(Path, "read_bytes", not_read)
    with pytest.raises(PlanFileError, match=r"big.ion: larger than 4194304 bytes"):
        read_schedule(over)


@pytest.mark.parametrize(
    ("schedule", "fragment"),
    [
        ({"contacts": []}, "an empty list is a link that never exists"),
        ({"contacts": [{"start": 5.0, "end": 5.0}]}, r"end \(5 s\) must be after start"),
        ({"contacts": [{"start": 0.0, "end": 50.0}], "period": 40.0}, r"ends at 50 s, after the period"),
        ({"drift_s_per_s": 1e-6, "delay": [{"at": 0.0, "one_way_s": 1.0}]}, "not both"),
        ({"delay": [{"at": 5.0, "one_way_s": 1.0}, {"at": 1.0, "one_way_s": 1.0}]}, "increasing `at`"),
        ({"contacts": [{"start": 0.0, "end": 5.0, "rate_bytes_per_s": 0.5}]}, "greater than or equal to 1"),
        (
            {"contacts": [{"start": 0.0, "end": 5.0, "direction": "uplink"}]},
            "no contact carries the downlink",
        ),
        ({"mode": "hold"}, "'store' or 'drop'"),
        ({"contacts": [{"start": 0.0, "end": 5.0, "colour": 1}]}, "Extra inputs are not permitted"),
    ],
)
def test_a_bad_schedule_is_refused_naming_the_field(schedule: dict[str, Any], fragment: str) -> None:
    with pytest.raises(ValidationError, match=fragment):
        LinkProfile.model_validate({"schedule": schedule})


def test_overlapping_windows_of_a_direction_merge() -> None:
    schedule = LinkProfile.model_validate(
        {
            "schedule": {
                "contacts": [
                    {"start": 0.0, "end": 10.0},
                    {"start": 5.0, "end": 20.0},
                    {"start": 20.0, "end": 30.0},
                ]
            }
        }
    ).schedule
    plan = Plan(schedule, "uplink", 0.0, None, 0.0)
    assert plan.next_close(1.0) == 30.0
    assert [plan.window_at(t) is not None for t in (9.0, 19.0, 29.0, 30.0)] == [True, True, True, False]
    assert list(itertools.islice((plan.next_open(t) for t in (30.0, 31.0)), 2)) == [None, None]


def test_the_links_mcap_record_says_why_each_message_waited_and_the_report_sums_it(tmp_path: Path) -> None:
    """Recording (issue point 5): each message's scheduled and actual release and its waits, read
    back from the MCAP file; `ptwl report` sums them per reason."""
    path = tmp_path / "link.mcap"
    sim = SimulatedLink(gap_profile(downlink_bytes_per_s=1000.0))
    sim.link.recorder = McapRecorder(SessionRecorder(path, {"source": "test"}), lambda t: int(t * 1e9))
    sim.send(5.0, "downlink", size=500)  # 0.5 s on the wire, 0.5 s delay
    sim.send(12.0, "downlink", size=100)  # in the gap: waits 8 s for the contact
    sim.send(12.5, "downlink", size=100, kind="state", replace_key="c")
    sim.send(13.0, "downlink", size=100, kind="state", replace_key="c")  # supersedes the one before
    sim.advance_to(40.0)
    sim.link.recorder.close()
    records = [m.value for m in read(path).on(topics.LINK.name)]
    released = [r for r in records if r["release"] is not None]
    assert [r["why"] for r in released] == [
        {"serialization": pytest.approx(0.5), "delay": pytest.approx(0.5)},
        {"contact_gap": pytest.approx(8.0), "serialization": pytest.approx(0.1), "delay": pytest.approx(0.5)},
        # Parked behind the message the gap held (it had the wire from 20.0 to 20.1): a queue.
        {"queue": pytest.approx(7.1), "serialization": pytest.approx(0.1), "delay": pytest.approx(0.5)},
    ]
    assert [r["scheduled_release"] for r in released] == pytest.approx([6.0, 20.6, 20.7])
    assert [r["release"] for r in released] == [r["scheduled_release"] for r in released]
    assert [r["drop_reason"] for r in records if r["release"] is None] == ["superseded"]
    text = report_text(path)
    assert "downlink: 3 released, dropped: superseded 1" in text
    assert "waited for contact_gap: 1 messages, mean 8.000 s, max 8.000 s" in text
    assert "waited for queue: 1 messages, mean 7.100 s, max 7.100 s" in text
    assert "released late by mean 0.00 ms, max 0.00 ms" in text


def test_an_inner_window_at_its_own_rate_keeps_the_outer_window_around_it() -> None:
    """Overlaps: the contact listed later sets the rate where it lies; the rest of the earlier
    one stays open (found by review: the outer window was cut off after the inner one)."""
    schedule = {
        "contacts": [{"start": 0.0, "end": 100.0}, {"start": 20.0, "end": 30.0, "rate_bytes_per_s": 1e6}],
    }
    plan = Plan(LinkProfile.model_validate({"schedule": schedule}).schedule, "uplink", 0.0, None, 0.0)
    assert plan._windows == [(0.0, 20.0, None), (20.0, 30.0, 1e6), (30.0, 100.0, None)]
    assert plan.window_at(50.0) is not None and plan.next_close(5.0) == 100.0
    same_start = {
        "contacts": [
            {"start": 0.0, "end": 100.0},
            {"start": 0.0, "end": 50.0, "direction": "downlink", "rate_bytes_per_s": 2000.0},
        ]
    }
    plan = Plan(LinkProfile.model_validate({"schedule": same_start}).schedule, "downlink", 0.0, None, 0.0)
    assert plan._windows == [(0.0, 50.0, 2000.0), (50.0, 100.0, None)]


def test_window_edges_survive_the_rounding_of_many_periods() -> None:
    """A period that is no binary fraction (5400.3 s): every in-contact instant over 200 orbits
    still sees its window close, where the contact plan says (found by review: the end, located
    again, rounded back inside the window and the link never closed)."""
    schedule = {
        "period": 5400.3,
        "contacts": [{"start": 0.0, "end": 2690.1}, {"start": 2700.2, "end": 5390.0}],
    }
    plan = Plan(LinkProfile.model_validate({"schedule": schedule}).schedule, "downlink", 0.0, None, 0.0)
    for t in np.linspace(0.0, 200 * 5400.3, 601):
        window = plan.window_at(float(t))
        if window is None:
            continue
        close = plan.next_close(float(t))
        assert close is not None and close == pytest.approx(window[1], abs=1e-6)
        assert plan.window_at(close) is None  # closed at its end, not still inside


def test_touching_windows_across_the_period_are_one_contact_and_a_full_plan_never_closes() -> None:
    wrap = {
        "period": 100.0,
        "contacts": [{"start": 0.0, "end": 10.0}, {"start": 60.0, "end": 100.0, "rate_bytes_per_s": 5.0}],
    }
    plan = Plan(LinkProfile.model_validate({"schedule": wrap}).schedule, "uplink", 0.0, None, 0.0)
    assert plan.next_close(70.0) == 110.0  # runs on into the next period's first window
    assert plan.next_close(105.0) == 110.0
    full = {
        "period": 10.0,
        "contacts": [{"start": 0.0, "end": 5.0}, {"start": 5.0, "end": 10.0, "rate_bytes_per_s": 9.0}],
    }
    plan = Plan(LinkProfile.model_validate({"schedule": full}).schedule, "uplink", 0.0, None, 0.0)
    assert plan.next_close(3.0) is None and plan.next_open(1e6 + 0.3) == 1e6 + 0.3


def test_touching_windows_inside_a_period_close_together_and_the_last_close_is_last_periods() -> None:
    """Two windows that touch inside a periodic plan are one contact closing at the second's end,
    in the same period (not a period later); in the gap at the start of the next period the link
    last closed at the end of the previous period's last window."""
    periodic = {
        "period": 100.0,
        "contacts": [
            {"start": 20.0, "end": 30.0},
            {"start": 30.0, "end": 40.0, "rate_bytes_per_s": 5.0},
            {"start": 60.0, "end": 70.0},
        ],
    }
    plan = Plan(LinkProfile.model_validate({"schedule": periodic}).schedule, "uplink", 0.0, None, 0.0)
    assert plan.next_close(25.0) == 40.0 and plan.next_close(125.0) == 140.0
    assert plan.next_close(65.0) == 70.0
    assert plan.last_close_before(110.0) == 70.0  # the gap before the next period's first window
    assert plan.last_close_before(50.0) == 40.0 and plan.last_close_before(10.0) is None  # never before
    assert plan.last_close_before(35.0) is None  # open


def test_ten_thousand_touching_windows_cost_microseconds_a_message() -> None:
    """A hostile plan (found by review: each message walked every touching window): 10,000
    windows of alternating rates; admitting 2,000 messages takes well under a second."""
    contacts = [
        {"start": float(i), "end": float(i + 1), "rate_bytes_per_s": 1e6 if i % 2 else 2e6}
        for i in range(10_000)
    ]
    profile = LinkProfile.model_validate({"downlink_bytes_per_s": 1e6, "schedule": {"contacts": contacts}})
    sim = SimulatedLink(profile)
    started = time.process_time()
    for i in range(2000):
        sim.send(i * 0.001, "downlink", size=100, kind="state", replace_key="c")
        sim.send(i * 0.001, "downlink", size=100)
    sim.advance_to(3.0)
    assert time.process_time() - started < 1.0
    assert sim.link.outlook(0.0)["downlink"]["changes_in_s"] == pytest.approx(10_000.0 - 3.0)


def test_a_new_profile_frees_the_wire_and_takes_the_parked_states() -> None:
    """Found by review: a parked state kept the old profile's crawl and went after newer ones.
    Now the wire is free from the change, and a parked state goes first, by the new profile's
    rule (all behind the message already booked: no overtaking, as for any profile change)."""
    sim = SimulatedLink(LinkProfile(downlink_bytes_per_s=1.0))
    sim.send(0.0, "downlink", size=5)  # 5 s on the wire at 1 B/s
    parked = sim.send(1.0, "downlink", size=100, kind="state", replace_key="c")  # 100 s more
    assert isinstance(parked, Parked)
    sim.advance_to(2.0)
    sim.link.set_profile(LinkProfile())
    sim.send(3.0, "downlink", size=100, kind="state", replace_key="c")
    sim.advance_to(10.0)
    out = released(sim)
    assert [(round(t, 9), e.kind, e.arrival) for t, e in out] == [
        (5.0, "ws", 0.0),
        (5.0, "state", 1.0),
        (5.0, "state", 3.0),
    ]


def test_a_closed_sockets_parked_state_goes_and_parked_states_count_against_the_caps() -> None:
    sim = SimulatedLink(gap_profile(max_held_messages=3))
    for key in ("a", "b", "c"):
        assert isinstance(sim.send(12.0, "downlink", kind="state", replace_key=key), Parked)
    refused = sim.send(12.5, "downlink")  # three parked: the cap is reached
    assert isinstance(refused, Dropped) and refused.reason == "overflow"
    sim.link.forget("downlink", "b")
    assert sim.link.stats_view()["downlink"]["dropped"]["gone"] == 1
    assert sim.link.stats_view()["downlink"]["held_now"]["parked_states"] == 2
    sim.advance_to(40.0)
    assert [e.arrival for _, e in released(sim)] == [12.0, 12.0]


def test_in_drop_mode_a_state_parked_behind_a_queue_is_lost_to_the_gap_not_carried_across() -> None:
    """Found by review: it crossed the gap as a 'queue' wait."""
    sim = SimulatedLink(gap_profile("drop", downlink_bytes_per_s=1000.0))
    sim.send(9.0, "downlink", size=900)  # on the wire until 9.9
    sim.send(9.5, "downlink", size=200, kind="state", replace_key="c")  # 9.9 + 0.2 > 10: the gap
    sim.advance_to(40.0)
    assert [e.kind for _, e in released(sim)] == ["ws"]
    assert sim.link.stats_view()["downlink"]["dropped"]["contact_gap"] == 1


def test_a_message_held_for_a_contact_travels_the_delay_of_when_it_leaves() -> None:
    """The one-way delay is the schedule's at the moment a message takes the wire, not at its
    arrival: held 8 s by a gap on a drifting delay, it gets the later delay."""
    profile = gap_profile().merged(
        {
            "schedule": {
                "contacts": [{"start": 0.0, "end": 10.0}, {"start": 20.0, "end": 100.0}],
                "drift_s_per_s": 1e-3,
            }
        }
    )
    sim = SimulatedLink(profile)
    sim.send(12.0, "downlink")
    sim.advance_to(40.0)
    ((t, entry),) = released(sim)
    assert entry.waits["delay"] == pytest.approx(0.5 + 1e-3 * 20.0)  # left at 20 s, not 12 s
    assert t == pytest.approx(20.0 + 0.52)


def test_a_hold_blackout_alone_stores_every_state_as_before() -> None:
    """Parking is for a busy wire or a schedule's gap; a blackout (seconds) stores each state and
    releases them all, in order, when it ends (the older rule, kept)."""
    sim = SimulatedLink(
        LinkProfile.model_validate({"blackouts": [{"start": 1.0, "duration": 1.0, "mode": "hold"}]})
    )
    for i in range(150):  # 0-3 s at 50 Hz
        sim.send(i * 0.02, "downlink", kind="state", replace_key="c")
    sim.advance_to(5.0)
    out = released(sim)
    assert len(out) == 150 and [e.seq for _, e in out] == sorted(e.seq for _, e in out)
    held = [t for t, e in out if 1.0 <= e.arrival < 2.0]
    assert len(held) == 50 and held == pytest.approx([2.0] * 50)  # the held second, at its end


def test_the_robot_keeps_its_states_to_half_the_downlink_it_is_told() -> None:
    """50 Hz states of 1000 characters on a socket told 2000 B/s: one a second (STATE_SHARE of
    the rate), each saying how many it left out and the interval."""
    clock = FakeClock()
    box = Outbox(clock=clock)
    box.set_downlink(2000.0)
    state = '{"type": "state"' + "x" * (1000 - len('{"type": "state"') - 1) + "}"
    queued = []
    for i in range(500):  # 10 s
        clock.now = 100.0 + i * 0.02
        thinned = box.thinned
        box.put(state)
        if box.thinned == thinned:
            queued.append(box.thinning_fields())
    assert len(queued) == 10
    assert queued[0] == ', "skipped": 0, "every_s": 1.000000'
    assert all(
        q in (', "skipped": 49, "every_s": 1.000000', ', "skipped": 50, "every_s": 1.000000')
        for q in queued[1:]
    )
    assert box.thinned == 490
    box.set_downlink(None)
    assert box.thinning_fields() == ""
