"""One trial in virtual time: the ground operator waits a round trip and a think time between
behaviors, the onboard one only once; lost messages are asked about, never waited on forever."""

import itertools
import math
from pathlib import Path

import pytest

from latency.profile import Blackout, LinkProfile, Loss
from ptwl.experiments.sweep.operators import PATIENCE_S, THINK_SPREAD, UNSTARTED_MAX, latest_end_s
from ptwl.experiments.sweep.robot import VIRTUAL_EPOCH_S, Accepted, Post, Query, Status, VirtualRobot
from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import blackout_s, row, run_trial, simulate
from robot_sim.params import PtwlParams
from robot_sim.policies import policy_for

TICK_S = 0.001  # the ground acts on the 1 ms tick; the robot starts a command on the next one


def starts_and_ends(trial) -> list[tuple[float, float]]:  # type: ignore[no-untyped-def]
    return [(s.report.started_at, s.report.ended_at) for s in trial.robot.figures.steps]


def test_ground_waits_a_round_trip_and_its_think_time_between_behaviors() -> None:
    spec = TrialSpec("lid", "ground", rtt_s=2.0, jitter_s=0.0, loss=0.0, seed=1, think_s=2.0)
    trial = simulate(spec)
    times = starts_and_ends(trial)
    assert len(times) == 5 and trial.robot.sim.task().success
    thinks = spec.rng("think")  # the operator's own draws, in order
    assert times[0][0] == pytest.approx(1.0, abs=2 * TICK_S)  # the first POST's one-way trip
    for (_, end), (start, _) in itertools.pairwise(times):
        think = thinks.uniform(*THINK_SPREAD) * 2.0
        assert 1.0 <= think <= 3.0
        # down (1 s), think, up (1 s): the robot idles exactly that long
        assert start - end == pytest.approx(2.0 + think, abs=3 * TICK_S)
    r = row(trial)
    assert r["operator_time_s"] == pytest.approx(times[-1][1] + 1.0, abs=2 * TICK_S)
    assert r["task_time_s"] == pytest.approx(times[-1][1] - times[0][0])
    assert (r["commands_sent"], r["wait_cycles"], r["requeries"]) == (5, 5, 0)
    assert r["think_total_s"] == pytest.approx(trial.operator.think_s)


def test_onboard_task_time_does_not_grow_with_delay_only_the_news_of_it() -> None:
    rows = {rtt: run_trial(TrialSpec("quick_connect", "onboard", rtt, 0.0, 0.0, 3)) for rtt in (0.0, 10.0)}
    assert rows[0.0]["success"] and rows[10.0]["success"]
    assert rows[10.0]["task_time_s"] == pytest.approx(rows[0.0]["task_time_s"], abs=0.05)
    # It started 5 s after the send and was known 5 s after it ended.
    assert rows[10.0]["operator_time_s"] == pytest.approx(rows[10.0]["task_time_s"] + 10.0, abs=3 * TICK_S)
    assert (rows[10.0]["commands_sent"], rows[10.0]["wait_cycles"]) == (1, 1)


def test_a_post_lost_in_a_drop_blackout_is_asked_about_then_sent_again_and_run_once() -> None:
    spec = TrialSpec("quick_connect", "ground", rtt_s=1.0, jitter_s=0.0, loss=0.0, seed=2, think_s=0.0)
    profile = LinkProfile(
        uplink=0.5, downlink=0.5, blackouts=[Blackout(start=0.0, duration=0.2, mode="drop")]
    )
    trial = simulate(spec, profile)
    r = row(trial)
    assert r["success"] and r["end"] == "completed"
    assert r["lost_messages"] == 1 and r["requeries"] == 1
    assert r["commands_sent"] == r["wait_cycles"] + 1 == r["behaviors"] + 1
    # Asked once the report was overdue (round trip + watchdog + patience), heard "unknown" a
    # round trip later, sent it again: it started half a round trip after that.
    first = policy_for("quick_connect").first(trial.robot.sim.state().port).params
    overdue = 1.0 + (latest_end_s(first) or 0.0) + PATIENCE_S
    assert starts_and_ends(trial)[0][0] == pytest.approx(overdue + 1.0 + 0.5, abs=3 * TICK_S)
    assert r["blackout_s"] == pytest.approx(0.2)


@pytest.mark.parametrize("operator", ["ground", "onboard"])
def test_with_every_event_lost_the_operator_still_finishes_by_asking(operator: str) -> None:
    spec = TrialSpec("quick_connect", operator, rtt_s=1.0, jitter_s=0.0, loss=0.0, seed=2, think_s=0.0)
    lossy = LinkProfile(uplink=0.5, downlink=0.5, loss=Loss(model="bernoulli", probability=1.0))
    r = row(simulate(spec, lossy))
    clean = run_trial(spec)
    assert r["success"] and r["end"] == clean["end"] == "completed"
    assert r["lost_messages"] >= r["wait_cycles"] >= 1  # every command's end event was lost
    assert r["requeries"] >= r["wait_cycles"]  # each was learned by asking
    assert r["operator_time_s"] > clean["operator_time_s"] + 1.0  # the cost of not hearing


def test_the_same_settings_give_the_same_row_and_jitter_and_loss_change_it() -> None:
    spec = TrialSpec("quick_connect", "ground", rtt_s=2.0, jitter_s=0.3, loss=0.2, seed=5, think_s=1.0)
    first, again = run_trial(spec), run_trial(spec)
    assert first == again
    plain = run_trial(TrialSpec("quick_connect", "ground", 2.0, 0.0, 0.0, 5, 1.0))
    assert first["operator_time_s"] != plain["operator_time_s"]


def test_a_hold_blackout_delays_the_command_to_its_end_and_a_named_profile_applies() -> None:
    spec = TrialSpec("quick_connect", "ground", rtt_s=1.0, jitter_s=0.0, loss=0.0, seed=2, think_s=0.0)
    held = LinkProfile(uplink=0.5, downlink=0.5, blackouts=[Blackout(start=0.0, duration=3.0, mode="hold")])
    trial = simulate(spec, held)
    assert starts_and_ends(trial)[0][0] == pytest.approx(3.0 + 0.5, abs=2 * TICK_S)  # held, then sent
    assert row(trial)["success"] and row(trial)["lost_messages"] == 0
    lossy = TrialSpec("quick_connect", "ground", 1.0, 0.0, 0.0, 2, 0.0, profile="earth_moon_lossy")
    profile = lossy.link_profile()
    assert (profile.uplink, profile.downlink) == (0.5, 0.5)  # the RTT replaces its delays
    assert profile.loss.model == "gilbert_elliott" and profile.blackouts[0].period == 300.0
    assert (
        profile.jitter.seed
        != TrialSpec("quick_connect", "ground", 1.0, 0.0, 0.0, 3, 0.0, "earth_moon_lossy")
        .link_profile()
        .jitter.seed
    )
    assert run_trial(lossy)["success"]


def test_a_post_that_arrives_twice_runs_once_and_a_status_says_what_the_robot_knows() -> None:
    robot = VirtualRobot("quick_connect", 0)
    params = PtwlParams(translation=[0.0, 0.0, 0.005], duration=0.2)
    assert robot.handle(Post("ground-1", params)) == Accepted("ground-1")
    assert robot.handle(Post("ground-1", params)) == Accepted("ground-1")  # a resend that did arrive
    assert robot.book.queued_count() == 1
    assert robot.handle(Query("ground-1")) == Status("ground-1", True, None)
    assert robot.handle(Query("ground-2")) == Status("ground-2", False, None)  # never got it
    done = None
    while done is None:
        done = robot.tick()
    assert done.tag == "ground-1" and robot.handle(Query("ground-1")).outcome == done.outcome


def test_blackout_time_counts_each_repeat_of_a_window_inside_the_trial() -> None:
    every_100 = LinkProfile(blackouts=[Blackout(start=10.0, duration=5.0, period=100.0)])
    assert blackout_s(every_100, 9.0) == 0.0
    assert blackout_s(every_100, 12.0) == pytest.approx(2.0)
    assert blackout_s(every_100, 250.0) == pytest.approx(15.0)  # 10-15, 110-115, 210-215
    assert blackout_s(every_100, 212.5) == pytest.approx(12.5)


def test_think_times_are_paired_across_delays() -> None:
    """The same seed thinks the same at every RTT: only the delay differs between grid points."""
    near, far = (simulate(TrialSpec("quick_connect", "ground", rtt, 0.0, 0.0, 4, 2.0)) for rtt in (0.0, 5.0))
    assert near.operator.think_s == far.operator.think_s > 0.0


@pytest.mark.parametrize(
    ("spec", "profile"),
    [
        (TrialSpec("quick_connect", "ground", 2.0, 0.3, 0.2, 5, 1.0), None),
        (
            TrialSpec("quick_connect", "ground", 1.0, 0.0, 0.0, 2, 0.0),
            LinkProfile(uplink=0.5, downlink=0.5, blackouts=[Blackout(start=0.0, duration=0.2, mode="drop")]),
        ),
    ],
)
def test_skipping_quiet_ticks_changes_no_figure(
    spec: TrialSpec, profile: LinkProfile | None, tmp_path: Path
) -> None:
    """A recorded trial is stepped tick by tick (the recorder looks at every one); an unrecorded
    one skips from event to event (VirtualRobot.tick_until). Both give the same row to the bit,
    with jitter, loss, a resend and a requery on the way."""
    trial = simulate(spec, profile)
    skipped = row(trial)
    ticked = row(simulate(spec, profile, record=tmp_path / "trial.mcap"))
    assert skipped == ticked
    assert skipped["commands_sent"] >= 2
    # ... and it stops a tick after the operator learned the outcome, as the tick-by-tick loop.
    assert trial.robot.sim.time == pytest.approx(skipped["operator_time_s"] + TICK_S, abs=TICK_S / 2)


def test_a_quiet_stretch_ends_at_the_next_event_or_the_first_command_that_ends() -> None:
    robot = VirtualRobot("quick_connect", 0)
    assert robot.tick_until(0.0105) is None
    assert robot.sim.time == pytest.approx(0.011)  # ticks while before the instant, then stops
    robot.handle(Post("ground-1", PtwlParams(translation=[0.0, 0.0, 0.005], duration=0.2)))
    done = robot.tick_until(5.0)
    assert done is not None and done.tag == "ground-1"
    report = done.outcome.report
    assert report is not None
    assert robot.sim.time == pytest.approx(report.ended_at + TICK_S, abs=TICK_S)  # not 5 s


# --------------------------------------------------------------------------- --max-age
def test_a_command_older_than_its_max_age_at_its_start_ends_expired_unrun_and_is_announced() -> None:
    """The virtual robot runs the server's expiry: judged when the command would start (after
    its wait in the queue), announced as it ends, with no report (it never ran)."""
    robot = VirtualRobot("quick_connect", 0)
    long_move = PtwlParams(translation=[0.0, 0.0, 0.005], duration=0.5)
    stamp = VIRTUAL_EPOCH_S  # sent at the trial's t = 0
    robot.handle(Post("ground-1", long_move))
    robot.handle(Post("ground-2", long_move.model_copy(update={"sent_at": stamp, "max_age": 0.2})))
    first = robot.tick_until(10.0)
    assert first is not None and first.tag == "ground-1" and first.outcome.report is not None
    second = robot.tick()  # ground-2 waited 0.5 s in the queue: 0.2 s was its age limit
    assert second is not None and second.tag == "ground-2"
    assert second.outcome.exit == "expired" and second.outcome.report is None
    assert "max_age" in second.outcome.detail
    assert robot.handle(Query("ground-2")) == Status("ground-2", True, second.outcome)
    assert robot.figures.steps[-1].report.started_at < 0.6  # only ground-1 ran


def test_max_age_is_stamped_on_every_command_and_one_that_expires_is_sent_again() -> None:
    spec = TrialSpec("lid", "ground", rtt_s=2.0, jitter_s=0.0, loss=0.0, seed=1, think_s=2.0, max_age_s=1.5)
    trial = simulate(spec)
    stamps = [(r.params.sent_at, r.params.max_age) for r in trial.robot.submitted.values()]
    assert all(max_age == 1.5 and sent_at is not None for sent_at, max_age in stamps)
    # Each arrives 1 s after its stamp and starts at once: younger than 1.5 s, none expires.
    assert row(trial)["unstarted"] == 0 and trial.robot.sim.task().success
    plain = simulate(TrialSpec("lid", "ground", 2.0, 0.0, 0.0, 1, 2.0))
    assert row(trial)["task_time_s"] == row(plain)["task_time_s"]  # expiry changed nothing here


def test_an_operator_whose_every_command_expires_on_the_way_gives_up_after_three() -> None:
    """At 4 s round trip each command is 2 s old when it arrives: a 1 s max age expires every
    one; the operator sends it again, freshly stamped, and gives up after UNSTARTED_MAX."""
    spec = TrialSpec("lid", "ground", rtt_s=4.0, jitter_s=0.0, loss=0.0, seed=1, think_s=2.0, max_age_s=1.0)
    trial = simulate(spec)
    r = row(trial)
    assert (r["end"], r["unstarted"], r["commands_sent"]) == ("expired", UNSTARTED_MAX, UNSTARTED_MAX)
    assert f"{UNSTARTED_MAX} commands in a row ended unrun" in r["why"] and not r["success"]
    assert r["behaviors"] == 0 and trial.robot.figures.first_start_s is None  # nothing ran
    stamps = [rec.params.sent_at for rec in trial.robot.submitted.values()]
    # Sent at 0, then each a round trip later (the expiry's news comes down 2 s after it arrived;
    # each turn costs the ticks the robot takes to judge and announce it).
    assert [s - VIRTUAL_EPOCH_S for s in stamps if s is not None] == pytest.approx(
        [0.0, 4.0, 8.0], abs=6 * TICK_S
    )
    assert r["operator_time_s"] == pytest.approx(12.0, abs=6 * TICK_S)


def test_jitter_past_the_max_age_expires_some_commands_and_the_task_still_completes() -> None:
    """The question expiry exists for: with +-1 s jitter on a 2 s round trip some commands are
    older than 1.6 s when they arrive; they expire instead of running late, and are sent again."""
    spec = TrialSpec("lid", "ground", rtt_s=2.0, jitter_s=1.0, loss=0.0, seed=3, think_s=2.0, max_age_s=1.6)
    r = row(simulate(spec))
    assert r["success"] and r["unstarted"] >= 1
    assert r["commands_sent"] == r["behaviors"] + r["gripper"] + r["unstarted"]  # each expiry sent again


def test_only_expiries_in_a_row_make_the_operator_give_up() -> None:
    """A command that ran in between starts the count again."""
    from ptwl.experiments.sweep.operators import Operator
    from ptwl.experiments.sweep.robot import Done, Outcome
    from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose
    from robot_sim.params import RweParams

    class Repeater(Operator):
        """Sends one RWE after another, for ever."""

        def begin(self, now: float, port: Pose) -> list:  # type: ignore[type-arg]
            return [self._post(now, RweParams(duration=0.1))]

        def _ended(self, now: float, report: BehaviorReport) -> None:
            self._next = (now, RweParams(duration=0.1))

    operator = Repeater(TrialSpec("lid", "ground", 2.0, 0.0, 0.0, 1, 2.0, None, 1.0), VIRTUAL_EPOCH_S)
    operator.begin(0.0, Pose((0.4, 0.0, 0.3), (0.0, 1.0, 0.0, 0.0)))
    expired = Outcome("expired", "2.00 s old at its start, over its max_age 1 s", None)
    home = Pose((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    ran = Outcome(
        "completed", "", BehaviorReport("rwe", ExitCondition.COMPLETED, 0, 1, 0, 0, (0.0,) * 6, home)
    )
    for now, outcome in enumerate([expired, expired, ran, expired, expired]):
        assert operator.pending is not None
        operator.on_message(float(now), Done(operator.pending.tag, outcome))
        operator.on_wake(float(now))  # after a run: the next command
    assert not operator.finished and operator.unstarted == 4
    assert operator.pending is not None
    operator.on_message(9.0, Done(operator.pending.tag, expired))  # the third in a row
    assert operator.finished and operator.end == "expired" and operator.unstarted == 5


def test_a_recorded_expired_command_ended_without_a_start(tmp_path: Path) -> None:
    """As the server's record: exit expired, an end, no start (a replay marks only what ran)."""
    from ptwl.recording.reader import read

    path = tmp_path / "expired.mcap"
    spec = TrialSpec("lid", "ground", rtt_s=4.0, jitter_s=0.0, loss=0.0, seed=1, think_s=2.0, max_age_s=1.0)
    simulate(spec, record=path)
    done = [e for e in read(path).values("/commands") if e["status"] == "done"]
    assert [e["exit"] for e in done] == ["expired"] * UNSTARTED_MAX
    assert all(e.get("started_at") is None and e["ended_at"] is not None for e in done)
    assert "max_age" in done[0]["detail"]


def test_a_recorded_trial_replays_as_the_virtual_robots_own_records(tmp_path: Path) -> None:
    """One rule from record to event and back: every command a replay lists at the end is the
    virtual robot's record as the server's API lists it (server.commands.status_model), but for
    who sent it; each event was logged when its status changed, at the record's own times."""
    from ptwl.recording.reader import read
    from ptwl.recording.replay.timeline import Timeline
    from server.commands import status_model

    path = tmp_path / "trial.mcap"
    spec = TrialSpec("lid", "ground", rtt_s=1.0, jitter_s=0.0, loss=0.0, seed=2, think_s=0.5)
    trial = simulate(spec, record=path)
    timeline = Timeline(path)
    replayed = timeline.commands_at(timeline.end_ns)
    robot = [status_model(r).model_dump() for r in trial.robot.submitted.values()]
    assert len(replayed) == len(robot) >= 4
    assert replayed == [{**r, "sender": "ground operator"} for r in robot]
    # Each command's life in order, each event at its record's time on the trial's clock.
    for record in robot:
        events = [m for m in read(path).on("/commands") if m.value["id"] == record["id"]]
        assert [m.value["status"] for m in events] == ["queued", "running", "done"]
        times = [record["queued_at"], record["started_at"], record["ended_at"]]
        assert [m.log_time_ns for m in events] == [round(t * 1e9) for t in times]


def test_a_fault_keeps_the_force_sums_the_robot_had_added_up() -> None:
    """The mean force a trial reports is over every tick from the first start: a fault, which
    reloads the scene and its controller, loses none of the ticks before it."""
    robot = VirtualRobot("quick_connect", 0)
    robot.handle(Post("ground-1", PtwlParams(translation=[0.0, 0.0, 0.02], duration=2.0)))
    robot.tick_until(robot.sim.time + 0.5)
    figures = robot.figures
    force_sum, torque_sum, ticks = figures.force_sum, figures.torque_sum, figures.ticks
    assert ticks >= 500 and force_sum > 0.0 and torque_sum > 0.0
    robot.sim.data.qvel[2] = math.nan
    done = robot.tick_until(robot.sim.time + 0.5)
    assert done is not None and done.outcome.exit == "fault"
    assert figures.force_sum >= force_sum and figures.torque_sum >= torque_sum
    assert figures.ticks > ticks
