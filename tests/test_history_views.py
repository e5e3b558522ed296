"""A command's line in the console's history: its colour by phase and exit, its label before the
robot gave it an id, and the robot's records taken as the truth once its run is known."""

import pytest

from web.history import CommandHistory

BLUE, VIOLET, GREEN, PURPLE, ORANGE, RED = "#1971c2", "#7048e8", "#2f9e44", "#ae3ec9", "#e8590c", "#e03131"


@pytest.mark.parametrize(
    ("events", "colour"),
    [
        ([], BLUE),  # sent: the 202 not back yet
        (["queued"], BLUE),
        (["queued", "running"], VIOLET),
        (["queued", "running", "goal_reached"], GREEN),  # success
        (["queued", "running", "aborted"], PURPLE),  # notice
        (["queued", "running", "wrench_breach"], ORANGE),  # warning
        (["queued", "running", "lost"], RED),  # error
    ],
)
def test_a_line_is_coloured_by_its_phase_then_by_its_exits_severity(events: list[str], colour: str) -> None:
    history = CommandHistory()
    view = history.sent("ptwl")
    for event in events:
        if event == "queued":
            history.accepted(view, 7)
        elif event == "running":
            history.event({"id": 7, "behavior": "ptwl", "status": "running"})
        else:
            history.event({"id": 7, "behavior": "ptwl", "status": "done", "exit": event})
    assert view.color == colour


def test_a_refused_send_is_red_and_says_refused() -> None:
    history = CommandHistory()
    view = history.sent("rwe")
    history.refused(view, "422: duration must be > 0")
    assert (view.status, view.color, view.detail) == ("refused", RED, "422: duration must be > 0")


def test_sends_without_an_id_are_numbered_from_1_in_this_console() -> None:
    history = CommandHistory()
    first, second = history.sent("ptwl"), history.sent("dither")
    assert (first.label, second.label) == ("(local 1)", "(local 2)")
    assert first.short_label == "(local 1)"
    history.accepted(first, 1795000000001234)
    assert (first.label, first.short_label) == ("#1795000000001234", "#…1234")


def test_records_of_the_run_the_console_knows_are_taken_as_the_truth() -> None:
    """Once the robot's run is known, its records (with that run's instance, or none) are
    applied; only a restarted run's are stale (test_console_logic holds that side)."""
    history = CommandHistory()
    history.robot_instance("aaaa0001")
    mine = history.sent("ptwl")
    history.accepted(mine, 21)
    records = [
        {"id": 21, "type": "ptwl", "status": "done", "exit": "timeout", "instance": "aaaa0001"},
        {"id": 22, "type": "rwe", "status": "running"},  # no instance: the same run's
    ]
    assert history.reconcile(records) == [mine] and mine.status == "timeout"
    assert [(v.id, v.status) for v in history.recent()] == [(21, "timeout"), (22, "running")]


def test_events_waiting_for_a_202_are_bounded_at_1000_the_newest_kept() -> None:
    """While a send's 202 is on its way, events of the same behavior are held for it (one may be
    its own); a script's flood in that time keeps the newest 1000, never more."""
    history = CommandHistory()
    mine = history.sent("ptwl")
    for command_id in range(1, 1501):
        assert history.event({"id": command_id, "behavior": "ptwl", "status": "queued"}) == (None, False)
    assert len(history._early) == 1000 and min(history._early) == 501
    # A held id's newer event moves it to the newest: not the next to go.
    assert history.event({"id": 501, "behavior": "ptwl", "status": "running"}) == (None, False)
    history.event({"id": 1501, "behavior": "ptwl", "status": "queued"})
    assert 501 in history._early and 502 not in history._early
    history.accepted(mine, 1500)
    assert history._early == {}  # nothing waits any more: all of it applied


def test_a_held_event_is_applied_to_the_send_it_turned_out_to_be_and_its_end_announced() -> None:
    history = CommandHistory()
    mine = history.sent("ptwl")
    history.event({"id": 7, "behavior": "ptwl", "status": "running"})
    history.event({"id": 7, "behavior": "ptwl", "status": "done", "exit": "goal_reached"})
    assert mine.phase == "sent"  # not applied before the 202 says whose it is
    assert history.accepted(mine, 7) == [(mine, True)]  # applied, and it just ended
    assert (mine.phase, mine.exit) == ("done", "goal_reached")
    assert [v.id for v in history.recent()] == [7]  # one line, not a second for id 7


def test_someone_elses_command_held_during_a_send_is_shown_once_no_send_waits() -> None:
    """A script's PTWL that ran while this console's 202 was on its way: shown as the script's
    line when the 202 lands, not held (and hidden) for ever."""
    history = CommandHistory()
    mine = history.sent("ptwl")
    history.event({"id": 3, "behavior": "ptwl", "status": "running"})
    history.event({"id": 3, "behavior": "ptwl", "status": "done", "exit": "timeout"})
    released = history.accepted(mine, 4)
    assert [(v.id, v.status, ended) for v, ended in released] == [(3, "timeout", True)]
    assert [(v.id, v.phase) for v in history.recent()] == [(4, "queued"), (3, "done")]


def test_a_refused_send_releases_what_was_held_for_it_and_a_send_still_waiting_keeps_it() -> None:
    history = CommandHistory()
    first, second = history.sent("rwe"), history.sent("rwe")
    history.event({"id": 9, "behavior": "rwe", "status": "running"})
    assert history.refused(first, "link: ConnectError") == []  # the second may still be id 9
    assert list(history._early) == [9]
    released = history.refused(second, "link: ConnectError")
    assert [(v.id, v.phase, ended) for v, ended in released] == [(9, "running", False)]
    assert history._early == {}


def test_a_held_copy_is_dropped_once_its_id_is_known_and_never_applied_over_a_newer_state() -> None:
    """Held "running" for #5 (a send of the same behavior was on its way), then the robot's records
    show #5 done: a later 202 must not bring "running" back (nor announce its end twice)."""
    history = CommandHistory()
    mine = history.sent("ptwl")
    history.event({"id": 5, "behavior": "ptwl", "status": "running"})
    records = [{"id": 5, "type": "ptwl", "status": "running"}]
    history.reconcile(records)  # the robot's records, read while our 202 is on its way
    done = history.event({"id": 5, "behavior": "ptwl", "status": "done", "exit": "goal_reached"})
    assert done[1] is True
    assert history.accepted(mine, 6) == []  # nothing held for #5 any more
    five = next(v for v in history.recent() if v.id == 5)
    assert (five.phase, five.exit) == ("done", "goal_reached")


def test_a_send_a_reconcile_showed_before_its_202_keeps_one_line() -> None:
    history = CommandHistory()
    mine = history.sent("rwe", sender="desk 1 at console a")
    history.reconcile([{"id": 8, "type": "rwe", "status": "running", "sender": "desk 1 at console a"}])
    assert [v.id for v in history.recent()] == [None, 8]  # ours (no id yet) and the record's
    history.accepted(mine, 8)
    assert history.recent() == [mine] and (mine.id, mine.phase, mine.local) == (8, "running", 1)


def test_a_held_event_of_a_command_the_robots_records_show_finished_is_not_shown_running() -> None:
    history = CommandHistory()
    mine = history.sent("dither")
    history.event({"id": 7, "behavior": "dither", "status": "running"})  # maybe ours: held
    history.reconcile([{"id": 7, "type": "dither", "status": "done", "exit": "completed"}])
    assert history.accepted(mine, 9) == []  # #7 ended before this console knew of it: not news
    assert [(v.id, v.phase) for v in history.recent()] == [(9, "queued")]
