"""The delay line on a simulated clock: FIFO release rule, jitter, loss, blackouts, versions, caps."""

import itertools

import pytest
from pydantic import ValidationError

from latency.clock import SimulatedLink
from latency.delay_line import Dropped, Entry
from latency.profile import LinkProfile


def releases(sim: SimulatedLink, direction: str = "downlink") -> list[tuple[float, Entry]]:
    return [(t, e) for t, e in sim.released if e.direction == direction]


def test_fixed_delay_releases_exactly_on_time_in_order() -> None:
    sim = SimulatedLink(LinkProfile(uplink=0.5, downlink=1.0))
    for i in range(100):
        sim.send(i * 0.01, "downlink")
        sim.send(i * 0.01, "uplink")
    sim.advance_to(5.0)
    for direction, delay in (("downlink", 1.0), ("uplink", 0.5)):
        out = releases(sim, direction)
        assert len(out) == 100
        assert all(t - e.arrival == pytest.approx(delay) for t, e in out)
        assert [e.seq for _, e in out] == list(range(1, 101))


def test_jitter_never_reorders_and_never_releases_early() -> None:
    profile = LinkProfile(downlink=1.0, jitter={"distribution": "uniform", "amount": 0.3, "seed": 7})
    sim = SimulatedLink(profile)
    for i in range(2000):  # 200 msg/s for 10 s
        sim.send(i * 0.005, "downlink")
    sim.advance_to(20.0)
    out = releases(sim)
    assert [e.seq for _, e in out] == list(range(1, 2001))
    # release = max(arrival + drawn delay, previous release): never before its own delay...
    assert all(t >= e.arrival + e.configured_delay - 1e-12 for t, e in out)
    # ...and only later when the previous message leaves later (no pile-up).
    for (t_prev, _), (t, e) in itertools.pairwise(out):
        assert t == pytest.approx(max(e.arrival + e.configured_delay, t_prev))
    drawn = [e.configured_delay for _, e in out]
    assert min(drawn) >= 0.7 - 1e-9 and max(drawn) <= 1.3 + 1e-9
    assert max(drawn) - min(drawn) > 0.55  # the jitter is really there


def test_reorder_option_lets_jitter_reorder() -> None:
    profile = LinkProfile(
        downlink=1.0, reorder=True, jitter={"distribution": "uniform", "amount": 0.3, "seed": 7}
    )
    sim = SimulatedLink(profile)
    for i in range(500):
        sim.send(i * 0.005, "downlink")
    sim.advance_to(10.0)
    out = releases(sim)
    assert [e.seq for _, e in out] != sorted(e.seq for _, e in out)
    assert all(t == pytest.approx(e.arrival + e.configured_delay) for t, e in out)


def test_blackout_hold_releases_everything_in_order_after_the_window() -> None:
    profile = LinkProfile(downlink=0.5, blackouts=[{"start": 1.0, "duration": 2.0, "mode": "hold"}])
    sim = SimulatedLink(profile)
    for i in range(400):  # 0 to 4 s at 100 msg/s
        sim.send(i * 0.01, "downlink")
    sim.advance_to(10.0)
    out = releases(sim)
    assert [e.seq for _, e in out] == list(range(1, 401))
    held = [(t, e) for t, e in out if 1.0 <= e.arrival < 3.0]
    assert len(held) == 200
    assert all(t == pytest.approx(3.0 + 0.5) for t, _ in held)  # all go when the window ends, plus the delay
    assert not any(3.0 + 0.5 > t > 1.0 + 0.5 for t, e in out if e.arrival < 1.0)
    after = [t - e.arrival for t, e in out if e.arrival >= 3.0]
    assert all(d == pytest.approx(0.5) for d in after)


def test_blackout_drop_drops_whole_messages_and_counts_them() -> None:
    profile = LinkProfile(downlink=0.2, blackouts=[{"start": 1.0, "duration": 0.5, "mode": "drop"}])
    sim = SimulatedLink(profile)
    outcomes = [sim.send(i * 0.01, "downlink") for i in range(300)]
    sim.advance_to(10.0)
    dropped = [o for o in outcomes if isinstance(o, Dropped)]
    assert len(dropped) == 50 and all(o.reason == "blackout" and 1.0 <= o.arrival < 1.5 for o in dropped)
    stats = sim.link.stats_view()["downlink"]
    assert stats["dropped"]["blackout"] == 50 and stats["released"] == 250 and stats["arrived"] == 300


def test_periodic_blackout_repeats() -> None:
    profile = LinkProfile(blackouts=[{"start": 1.0, "duration": 0.5, "mode": "drop", "period": 2.0}])
    sim = SimulatedLink(profile)
    lost_at = [t / 100 for t in range(700) if isinstance(sim.send(t / 100, "uplink"), Dropped)]
    assert lost_at[0] == pytest.approx(1.0) and lost_at[-1] == pytest.approx(5.49)
    assert len(lost_at) == 3 * 50


def test_bernoulli_loss_rate_and_determinism() -> None:
    profile = LinkProfile(downlink=0.1, loss={"model": "bernoulli", "probability": 0.1, "seed": 4})

    def lost_pattern(p: LinkProfile) -> list[bool]:
        sim = SimulatedLink(p)
        return [isinstance(sim.send(i * 0.001, "downlink"), Dropped) for i in range(20000)]

    pattern = lost_pattern(profile)
    assert sum(pattern) / len(pattern) == pytest.approx(0.1, abs=0.01)
    assert lost_pattern(profile) == pattern  # same seed, same losses
    other = profile.merged({"loss": {"model": "bernoulli", "probability": 0.1, "seed": 5}})
    assert lost_pattern(other) != pattern


def test_gilbert_elliott_loss_comes_in_bursts() -> None:
    spec = {
        "model": "gilbert_elliott",
        "p_good_to_bad": 0.02,
        "p_bad_to_good": 0.2,
        "loss_in_bad": 1.0,
        "seed": 9,
    }
    sim = SimulatedLink(LinkProfile(loss=spec))
    lost = [isinstance(sim.send(i * 0.001, "uplink"), Dropped) for i in range(50000)]
    rate = sum(lost) / len(lost)
    # Stationary bad-state share p_gb / (p_gb + p_bg) = 0.02 / 0.22.
    assert rate == pytest.approx(0.02 / 0.22, rel=0.15)
    runs = [len(list(g)) for k, g in itertools.groupby(lost) if k]
    assert sum(runs) / len(runs) == pytest.approx(1 / 0.2, rel=0.15)  # mean burst 1 / p_bad_to_good


def test_profile_change_keeps_the_delay_given_on_arrival() -> None:
    sim = SimulatedLink(LinkProfile(downlink=1.0))
    for i in range(100):  # 0 to 1 s under version 1
        sim.send(i * 0.01, "downlink")
    assert sim.link.set_profile(LinkProfile(downlink=0.2)) == 2
    for i in range(100, 200):  # 1 to 2 s under version 2
        sim.send(i * 0.01, "downlink")
    sim.advance_to(10.0)
    out = releases(sim)
    assert [e.seq for _, e in out] == list(range(1, 201))
    v1 = [(t, e) for t, e in out if e.version == 1]
    v2 = [(t, e) for t, e in out if e.version == 2]
    assert len(v1) == 100 and all(t - e.arrival == pytest.approx(1.0) for t, e in v1)
    assert all(e.configured_delay == pytest.approx(0.2) for _, e in v2)
    # The first new messages wait behind the last old one (no overtaking), then run at 0.2 s.
    last_old = v1[-1][0]
    assert all(t >= last_old for t, _ in v2)
    assert v2[-1][0] - v2[-1][1].arrival == pytest.approx(0.2)


def test_caps_bound_memory_with_drop_newest() -> None:
    sim = SimulatedLink(LinkProfile(downlink=10.0, max_held_messages=50, max_held_bytes=4096))
    outcomes = [sim.send(i * 0.001, "downlink", size=100) for i in range(100)]
    kept = [o for o in outcomes if isinstance(o, Entry)]
    assert len(kept) == 40  # 4096 bytes / 100 bytes, before the message cap
    stats = sim.link.stats_view()["downlink"]
    assert stats["dropped"]["overflow"] == 60
    assert stats["held_now"] == {"messages": 40, "bytes": 4000, "parked_states": 0}
    sim.advance_to(20.0)
    assert sim.link.stats_view()["downlink"]["held_now"] == {"messages": 0, "bytes": 0, "parked_states": 0}


@pytest.mark.parametrize(
    ("update", "fragment"),
    [
        ({"uplink": -1}, "uplink"),
        ({"downlink": float("nan")}, "downlink"),
        ({"jitter": {"distribution": "gamma"}}, "jitter.distribution"),
        ({"loss": {"model": "bernoulli", "probability": 1.5}}, "loss.probability"),
        (
            {"blackouts": [{"start": 0, "duration": 5, "period": 2}]},
            "duration (5 s) must be shorter than period",
        ),
        ({"max_held_messages": 0}, "max_held_messages"),
        ({"latency": 1}, "latency"),
    ],
)
def test_bad_profiles_name_the_field(update: dict, fragment: str) -> None:
    with pytest.raises(ValidationError) as err:
        LinkProfile().merged(update)
    text = str(err.value)
    assert fragment.split(".")[0] in text and (fragment in text or fragment.split(".")[-1] in text)
