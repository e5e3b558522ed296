"""The console plans around the link's schedule: the countdown line, a warning before a Send that
may outlast the contact (with valid_until_sim_time offered), commands held for the next contact,
the robot greyed through a loss of signal, and thinned telemetry not counted as lost.

The rules on constructed outlooks first (web/link_plan.py), then a console on a real robot and
proxy (no browser: the desk's logic with a stand-in client, as test_console_logic.py)."""

import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from ptwl.launcher import ServiceProcess, free_port, running_proxy
from robot_sim.params import DitherParams, GripperParams, PtwlParams, RweParams
from server.client import RobotClient
from tests.test_console_logic import viser_client, wait_for_state
from web.app import ConsoleApp
from web.link_plan import (
    DirectionNow,
    _uplink_wait,
    direction_now,
    duration_text,
    has_schedule,
    link_replaces_states,
    plan_send,
    run_time_s,
    schedule_line,
    signal,
)
from web.telemetry_health import TelemetryHealth

NOW = 1_800_000_000.0


def outlook(
    up_open: bool = True,
    down_open: bool = True,
    up_change_in: float | None = None,
    down_change_in: float | None = None,
    gap_s: float | None = None,
    one_way_s: float = 1.0,
    trend: float = 0.0,
) -> dict[str, Any]:
    def direction(open_: bool, change_in: float | None) -> dict[str, Any]:
        return {
            "in_contact": open_,
            "changes_at_unix": None if change_in is None else NOW + change_in,
            "changes_in_s": change_in,
            "next_gap_s": gap_s if open_ else None,
            "closed_since_unix": None if open_ else NOW - 12.0,
            "one_way_s": one_way_s,
            "trend_s_per_s": trend,
            "rate_bytes_per_s": 2000.0,
            "mode": "store",
            "held_messages": 0 if open_ else 2,
            "parked_states": 0,
        }

    return {
        "now_unix": NOW,
        "uplink": direction(up_open, up_change_in),
        "downlink": direction(down_open, down_change_in),
    }


def test_a_command_that_may_outlast_the_contact_is_warned_with_its_latest_start() -> None:
    """Needs up (1 s) + its longest run (watchdog) + down (1 s) before the downlink's loss of
    signal; the latest start is for its run as asked (duration)."""
    fits = plan_send(outlook(down_change_in=20.0, gap_s=60.0), NOW, (2.0, 7.0))
    assert not fits.ask_first and fits.text == ""  # 1 + 7 + 1 = 9 s <= 20 s
    tight = plan_send(outlook(down_change_in=8.0, gap_s=60.0), NOW, (2.0, 7.0))
    assert tight.ask_first and tight.los_at == NOW + 8.0
    assert tight.latest_start == pytest.approx(NOW + 8.0 - 1.0 - 2.0)  # LOS - down - duration
    assert "may run 7.0 s (its watchdog) + 1.00 s up + 1.00 s for its report" in tight.text
    assert "signal is lost in 8 s" in tight.text
    hopeless = plan_send(outlook(down_change_in=3.5, gap_s=60.0), NOW, (2.0, 7.0))
    assert hopeless.ask_first and hopeless.latest_start is None  # 1 + 2 > 3.5 - 1
    # No loss of signal in the plan, or a run that cannot be told (a machine): no warning.
    assert not plan_send(outlook(), NOW, (2.0, 7.0)).ask_first
    assert not plan_send(outlook(down_change_in=3.0), NOW, None).ask_first


def test_a_closed_uplink_holds_the_command_and_the_loss_is_judged_from_its_arrival() -> None:
    held = plan_send(
        outlook(up_open=False, up_change_in=30.0, down_change_in=38.0, gap_s=60.0), NOW, (2.0, 7.0)
    )
    assert held.held_until == NOW + 30.0
    assert "holds it for the uplink's next contact at" in held.text
    assert held.ask_first  # arrives at 31 s, may run to 38 s: its report 39 s > 38 s
    assert held.latest_start == pytest.approx(NOW + 38.0 - 1.0 - 2.0)


def test_the_countdown_flips_at_its_change_until_the_next_poll() -> None:
    o = outlook(down_change_in=5.0, gap_s=60.0, trend=1e-4)
    before = direction_now(o, "downlink", NOW + 4.0)
    after = direction_now(o, "downlink", NOW + 6.0)
    assert before.in_contact and not after.in_contact
    assert after.closed_since == NOW + 5.0 and after.changes_at == NOW + 65.0
    assert after.one_way_s == pytest.approx(1.0 + 6.0 * 1e-4)  # the delay drifts on between polls
    assert signal(o, NOW + 6.0).lost_since == NOW + 5.0


def test_the_bar_line_says_the_next_change_the_delay_trend_and_the_rate() -> None:
    line = schedule_line(outlook(down_change_in=42.0, gap_s=370.0, trend=1.5e-6), NOW, 1.2)
    assert "signal lost in 42 s for 6 min 10 s" in line
    assert "one way 1.000 s, rising 5.4 ms/h" in line and "downlink 2.0 kB/s, states every 1.2 s" in line
    lost = schedule_line(
        outlook(up_open=False, down_open=False, up_change_in=90.0, down_change_in=90.0), NOW, None
    )
    assert lost.startswith("LOSS OF SIGNAL for 12 s · next contact at ") and "(in 1 min 30 s)" in lost
    assert "uplink closed: 2 held for its next contact" in lost
    assert [duration_text(s) for s in (42.4, 370.0, 7260.0)] == ["42 s", "6 min 10 s", "2 h 01 min"]
    assert [duration_text(s) for s in (59.4, 60.0, 3599.0, 3600.0)] == [
        "59 s",
        "1 min 00 s",
        "59 min 59 s",
        "1 h 00 min",
    ]
    # Rounded to the second before the unit is chosen: no "60 s", no "59 min 60 s".
    assert [duration_text(s) for s in (59.7, 3599.6, -3.0)] == ["1 min 00 s", "1 h 00 min", "0 s"]


def test_an_unlimited_uplink_sends_a_command_at_once_up_to_its_close() -> None:
    """A command takes no time on an uplink without a rate: it goes if the link is open now,
    however soon it closes; on a 1 kB/s uplink 500 bytes take 0.5 s and wait for the next contact."""
    unlimited = DirectionNow(True, NOW + 0.2, 30.0, None, 1.0, 0.0, None, 0)
    assert _uplink_wait(unlimited, NOW, 500) is None
    narrow = DirectionNow(True, NOW + 0.2, 30.0, None, 1.0, 0.0, 1000.0, 0)
    assert _uplink_wait(narrow, NOW, 500) == NOW + 0.2 + 30.0
    assert _uplink_wait(narrow, NOW, 100) is None  # 0.1 s: off the wire before it closes


def test_a_plain_link_or_none_has_no_schedule_line() -> None:
    assert not has_schedule(None) and not has_schedule({"uplink": 1.0, "downlink": 1.0})
    assert has_schedule({"blackouts": [{"start": 0.0, "duration": 5.0}]})


def test_run_times_are_each_behaviors_own() -> None:
    assert run_time_s(PtwlParams(duration=2.0)) == (2.0, 7.0)
    assert run_time_s(PtwlParams(duration=2.0, watchdog=3.0)) == (2.0, 3.0)
    assert run_time_s(DitherParams(duration=4.0)) == (4.0, 9.0)
    assert run_time_s(RweParams(duration=1.5)) == (1.5, 1.5)
    assert run_time_s(GripperParams(action="close", duration=0.5)) == (0.5, 0.5)
    assert run_time_s(None) is None


# ------------------------------------------------------------ a console on a real link


@pytest.fixture(scope="module")
def link(server: ServiceProcess) -> Iterator[ServiceProcess]:
    with running_proxy(server.url) as p:
        yield p


@pytest.fixture(scope="module")
def console(link: ServiceProcess) -> Iterator[ConsoleApp]:
    app = ConsoleApp(link.url, port=free_port())
    app.connect(timeout=30.0)
    try:
        wait_for_state(app)
        yield app
    finally:
        app.close()


def set_link(console: ConsoleApp, link: ServiceProcess, profile: dict[str, Any]) -> None:
    base = {
        "uplink": 0.0,
        "downlink": 0.0,
        "schedule": None,
        "uplink_bytes_per_s": None,
        "downlink_bytes_per_s": None,
    }
    httpx.put(link.url + "/_link/profile", json={**base, **profile}).raise_for_status()
    assert console.link.poller is not None
    console.link.poller.poll()


@pytest.fixture
def plain_link_after(console: ConsoleApp, link: ServiceProcess) -> Iterator[None]:
    yield
    set_link(console, link, {})


@pytest.mark.usefixtures("plain_link_after")
def test_the_bar_counts_down_to_the_loss_of_signal(console: ConsoleApp, link: ServiceProcess) -> None:
    set_link(
        console,
        link,
        {"schedule": {"contacts": [{"start": 0.0, "end": 45.0}, {"start": 75.0, "end": 600.0}]}},
    )
    line = console.status.inputs().schedule
    assert "signal lost in 4" in line and "for 30 s" in line  # 45 s less the poll's age
    assert console.status.inputs().lost_since is None


@pytest.mark.usefixtures("plain_link_after")
def test_a_send_that_may_outlast_the_contact_offers_valid_until_sim_time(
    console: ConsoleApp, link: ServiceProcess, server: ServiceProcess
) -> None:
    set_link(
        console,
        link,
        {
            "uplink": 0.1,
            "downlink": 0.1,
            "schedule": {"contacts": [{"start": 0.0, "end": 8.0}, {"start": 60.0, "end": 600.0}]},
        },
    )
    with viser_client(console) as desk, RobotClient(server.url) as robot:
        console.seat.take(desk.client_id)
        params = {**desk.panel.ptwl.params(), "duration": 1.0, "watchdog": 9.0}  # 0.1 + 9 + 0.1 > ~7.9 s
        plan, valid_until = console.commanding.plan_send("ptwl", params)
        assert plan.ask_first and plan.los_at is not None and valid_until is not None
        state, _ = console.link.latest()
        assert state is not None
        expected = float(state["sim_time"]) + (plan.los_at - 0.1 - 1.0 - float(state["sent_at"]))
        assert valid_until == pytest.approx(expected, abs=1e-6)
        before = len(robot.commands(limit=100))
        opened: list[str] = []
        real_modal = desk.client.gui.add_modal
        desk.client.gui.add_modal = lambda title: opened.append(title) or real_modal(title)  # type: ignore[method-assign]
        try:
            desk._send_typed("ptwl", lambda: params)
        finally:
            del desk.client.gui.add_modal
        assert opened == ["Signal may be lost before it finishes"]
        assert len(robot.commands(limit=100)) == before  # nothing sent until the operator says
        console.commanding.send(desk, "ptwl", {**params, "valid_until_sim_time": round(valid_until, 3)})
        sent = robot.commands(limit=1)[-1]
        assert sent.params["valid_until_sim_time"] == pytest.approx(valid_until, abs=1e-3)
        robot.stop()


@pytest.mark.usefixtures("plain_link_after")
def test_a_command_sent_while_the_uplink_is_closed_is_held_and_said_so(
    console: ConsoleApp, link: ServiceProcess, server: ServiceProcess
) -> None:
    schedule = {
        "contacts": [
            {"start": 3.0, "end": 600.0, "direction": "uplink"},
            {"start": 0.0, "end": 600.0, "direction": "downlink"},
        ]
    }
    put_at = time.monotonic()  # the schedule's clock starts when the link takes the profile
    set_link(console, link, {"schedule": schedule})
    shown: list[str] = []
    real_changed = console.log.changed
    console.log.changed = lambda view: (shown.append(view.detail), real_changed(view))  # type: ignore[method-assign]
    try:
        with viser_client(console) as desk, RobotClient(server.url) as robot:
            console.seat.take(desk.client_id)
            sent_at = time.monotonic()
            console.commanding.send(desk, "rwe", {**desk.panel.rwe.params(), "duration": 0.2})
            answered_at = time.monotonic()
            sent = robot.commands(limit=1)[-1]
    finally:
        del console.log.changed
    assert any(d.startswith("held by the link for the next contact at ") for d in shown)
    # Held until the uplink's contact opens, 3 s after the PUT (timed from the PUT, not from the
    # send: under load the set-up between them took over a second), and not for long after it.
    assert sent_at - put_at < 3.0 and answered_at - put_at >= 3.0 - 0.05
    assert answered_at - put_at < 3.0 + 2.0
    # Its max_age covers the hold: judged at the robot, it is not expired for having waited.
    assert sent.params["max_age"] > 2.0 and sent.exit != "expired"


@pytest.mark.usefixtures("plain_link_after")
def test_through_a_loss_of_signal_the_robot_is_grey_with_the_time_since_contact(
    console: ConsoleApp, link: ServiceProcess
) -> None:
    set_link(console, link, {"schedule": {"contacts": [{"start": 4.0, "end": 600.0}]}})
    inputs = console.status.inputs()
    assert inputs.lost_since is not None and "LOSS OF SIGNAL" in inputs.schedule
    deadline = time.monotonic() + 2.0
    while not console.status._los_label and time.monotonic() < deadline:
        time.sleep(0.05)
    arm = console.status._view.arm
    assert arm.stale and arm._stale_label.text.startswith("LOSS OF SIGNAL since ")
    time.sleep(4.5)  # contact is back; the next poll says so and states flow again
    console.link.poller.poll()  # type: ignore[union-attr]
    deadline = time.monotonic() + 5.0
    while arm.stale and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not arm.stale and console.status.inputs().lost_since is None


@pytest.mark.usefixtures("plain_link_after")
def test_a_thinned_downlink_is_not_counted_as_lost(console: ConsoleApp, link: ServiceProcess) -> None:
    """At 2 kB/s the robot sends a state every ~len/1000 s and says how many it left out: the
    console shows that interval and counts none of them lost."""
    set_link(console, link, {"downlink": 0.05, "downlink_bytes_per_s": 2000.0})
    assert console.link.poller is not None and console.link.poller.replaces_states  # judged at the poll
    lost_before = console.link.health.lost
    time.sleep(6.0)
    health = console.link.health
    state, _ = console.link.latest()
    assert state is not None and health.every_s is not None
    assert 0.2 < health.every_s < 5.0
    assert health.lost == lost_before
    assert f"states every {health.every_s:.1f} s" in console.status.inputs().link.text


def test_a_gap_on_a_link_that_replaces_states_is_not_called_a_loss() -> None:
    health = TelemetryHealth()
    health.on_transport(True, "connected")
    health.on_state(10, NOW, NOW)
    health.on_state(40, NOW + 0.6, NOW + 0.6, link_replaces=True)  # 29 replaced on a narrow link
    health.on_state(45, NOW + 0.7, NOW + 0.7)  # 4 lost on a plain one
    assert (health.lost, health.replaced) == (4, 29)
    health.on_state(60, NOW + 1.0, NOW + 1.0, skipped=14, every_s=0.3)  # the robot left out 14
    assert (health.lost, health.replaced) == (4, 29)
    health.on_state(90, NOW + 1.5, NOW + 1.5, link_replaces=True)  # a replaced gap is not "late"
    assert health.line(0.0, NOW + 1.6).level == "fresh"
    health.on_state(95, NOW + 1.6, NOW + 1.6)
    assert health.line(0.0, NOW + 1.7).level == "late"  # a lost one is
    text = health.line(0.0, NOW + 1.7).text
    assert "(8 lost in all, 58 replaced by the link)" in text
    health.on_state(100, NOW + 2.0, NOW + 2.0, skipped=4, every_s=0.3)
    assert "states every 0.3 s" in health.line(0.0, NOW + 2.1).text
    # A thinned socket is silent only past its interval: 1.2 s after the last state is not silent.
    assert "telemetry flowing" in health.line(0.0, NOW + 3.2).text
    assert "no telemetry for" in health.line(0.0, NOW + 3.4).text
    assert link_replaces_states({"downlink_bytes_per_s": 2000.0})
    assert link_replaces_states({"schedule": {"contacts": [{"start": 0.0, "end": 1.0}], "mode": "store"}})
    assert not link_replaces_states({"schedule": {"contacts": [{"start": 0.0, "end": 1.0}], "mode": "drop"}})
    assert not link_replaces_states({"blackouts": [{"start": 1.0, "duration": 1.0, "mode": "hold"}]})
    assert not link_replaces_states(None)  # no profile read yet: a gap is states lost


def test_silence_through_a_loss_of_signal_is_said_as_such_not_as_losses() -> None:
    health = TelemetryHealth()
    health.on_transport(True, "connected")
    health.on_state(1, NOW, NOW)
    health.on_state(2, NOW + 0.02, NOW + 0.02)  # the robot's period, measured: 20 ms
    assert health.line(0.0, NOW + 9.0, out_of_contact=True).text.endswith(
        "no telemetry for 9.0 s: the link is out of contact"
    )
    assert "(~449 messages lost)" in health.line(0.0, NOW + 9.0).text  # 8.98 s / 20 ms
    closed = schedule_line(
        outlook(up_open=False, down_open=False, up_change_in=30.0, down_change_in=30.0), NOW, None
    )
    assert closed.endswith("downlink closed")


def test_a_command_that_cannot_leave_before_the_uplink_closes_waits_for_the_next_contact() -> None:
    """Found by review: the uplink closing in 0.2 s with a 400 B command at 1 kB/s (0.4 s on
    the wire) is held for the next contact, as the link's rule does; in drop mode it is lost."""
    o = outlook(up_change_in=0.2, down_change_in=0.2, gap_s=60.0)
    o["uplink"]["rate_bytes_per_s"] = 1000.0
    held = plan_send(o, NOW, (2.0, 7.0), command_bytes=400)
    assert held.held_until == NOW + 60.2
    fits = plan_send(o, NOW, (2.0, 7.0), command_bytes=100)  # 0.1 s on the wire: it leaves
    assert fits.held_until is None
    lost = plan_send(o, NOW, (2.0, 7.0), command_bytes=400, mode="drop")
    assert lost.ask_first and "it will be lost" in lost.text and lost.held_until is None
    # Held past the downlink's loss of signal: that loss is not its own, so it is not judged.
    assert not held.ask_first
