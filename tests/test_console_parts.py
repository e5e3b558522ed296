"""The console's small parts on their own: the ground twin's judge and inbox
(web/twin_judge.py, web/twin_inbox.py), the commanded marker pair, the arm's stale grey, the
replay slider's end and the control line: rules a whole-console run only shows blurred (issue
28's mutation pass found each of these unguarded)."""

import numpy as np
import pytest
import viser

from robot_sim.params import RweParams
from tests.worker_rounds import Rounds
from web.commanded_marker import CommandedMarker
from web.twin_inbox import TwinInbox
from web.twin_judge import ERROR_WINDOW_S, MATCH_S, RECORD_S, PredictionJudge
from web.twin_sim import Sent


def state(sim_time: float, x_m: float) -> dict:
    return {"sim_time": sim_time, "port": {"position": [x_m, 0.0, 0.0]}}


def test_a_prediction_judges_only_a_state_within_match_s_of_it() -> None:
    judge = PredictionJudge()
    judge.record(1.0, np.array([0.1, 0.0, 0.0]))
    assert judge.judge(state(1.0 + 0.9 * MATCH_S, 0.103), 100.0) == pytest.approx(0.003)
    assert judge.judge(state(1.0 + 1.5 * MATCH_S, 0.103), 100.0) is None  # nothing predicted then


def test_the_readouts_max_covers_only_the_last_error_window() -> None:
    judge = PredictionJudge()
    judge.record(1.0, np.array([0.1, 0.0, 0.0]))
    judge.record(2.0, np.array([0.2, 0.0, 0.0]))
    judge.judge(state(1.0, 0.110), arrived_wall=100.0)  # 10 mm off
    assert judge.summary() == pytest.approx((0.010, 0.010))
    judge.judge(state(2.0, 0.201), arrived_wall=100.0 + ERROR_WINDOW_S + 0.1)  # 1 mm, 5.1 s later
    assert judge.summary() == pytest.approx((0.001, 0.001))  # the 10 mm has left the window
    assert judge.judged_wall() == 100.0 + ERROR_WINDOW_S + 0.1


def test_a_prediction_is_kept_every_record_s_and_a_scene_reload_forgets_them() -> None:
    judge = PredictionJudge()
    assert judge.due(0.0)
    judge.record(0.0, np.zeros(3))
    assert not judge.due(0.5 * RECORD_S) and judge.due(RECORD_S)
    judge.judge(state(0.0, 0.0), 1.0)
    judge.forget()
    assert judge.summary() is None and judge.judged_wall() is None and judge.due(0.0)


def test_the_next_prediction_is_due_from_the_latest_one_kept() -> None:
    judge = PredictionJudge()
    assert judge.next_due_s() == -np.inf
    for sim_time in (0.0, 0.01, 0.02):
        judge.record(sim_time, np.zeros(3))
    assert judge.next_due_s() == pytest.approx(0.03)
    assert not judge.due(0.025) and judge.due(0.03)


def test_at_most_6000_predictions_are_kept_the_oldest_thousand_go_first() -> None:
    judge = PredictionJudge()
    for i in range(6000):
        judge.record(i * RECORD_S, np.array([i * 1e-3, 0.0, 0.0]))
    assert judge.judge(state(0.0, 0.0), 1.0) == 0.0  # the first still judges at 6000
    judge.record(6000 * RECORD_S, np.array([6.0, 0.0, 0.0]))
    assert len(judge._times) == 5001
    assert judge._times[0] == pytest.approx(1000 * RECORD_S)  # the first 1000 gone
    assert judge.judge(state(998 * RECORD_S, 0.998), 1.0) is None  # nothing kept within MATCH_S
    assert judge.judge(state(1000 * RECORD_S, 1.0), 1.0) == pytest.approx(0.0)


def test_a_scene_reload_makes_the_twin_restart_from_it() -> None:
    inbox = TwinInbox()
    assert not inbox.state_arrived(state(5.0, 0.0))
    assert not inbox.take().resync_due
    assert not inbox.state_arrived(state(5.1, 0.0))  # time went on: no restart due
    assert not inbox.take().resync_due
    assert inbox.state_arrived(state(0.2, 0.0))  # back to the start: a reset or a fault's reload
    assert inbox.take().resync_due


def test_a_send_whose_done_event_came_without_its_running_one_is_not_replayed() -> None:
    """A lost `running` event: the `done` event alone says the robot has started (and ended) it."""
    inbox = TwinInbox()
    inbox.sent(Sent(RweParams(duration=0.5), 100.0, lambda: True))
    inbox.sent(Sent(RweParams(duration=0.5), 101.0, lambda: True))
    assert [s.sent_wall for s in inbox.take().sent] == [100.0, 101.0]
    inbox.command_event({"id": 7, "status": "done", "params": {"sent_at": 100.0}})
    assert [s.sent_wall for s in inbox.take().sent] == [101.0]


def test_only_a_started_command_leaves_the_prediction_and_only_its_own_end_clears_running() -> None:
    inbox = TwinInbox()
    inbox.sent(Sent(RweParams(duration=0.5), 100.0, lambda: True))
    inbox.command_event({"id": 7, "status": "queued", "params": {"sent_at": 100.0}})  # not started
    assert [s.sent_wall for s in inbox.take().sent] == [100.0]
    inbox.command_event({"id": 7, "status": "running", "params": {"sent_at": 100.0}})
    heard = inbox.take()
    assert heard.sent == [] and heard.running is not None and heard.running["id"] == 7
    inbox.command_event({"id": 8, "status": "done", "params": {}})  # another command's end
    assert inbox.take().running["id"] == 7  # type: ignore[index]
    inbox.command_event({"id": 7, "status": "done", "params": {"sent_at": 100.0}})
    assert inbox.take().running is None


def test_the_started_stamps_kept_are_the_newest_256() -> None:
    inbox = TwinInbox()
    for i in range(300):
        inbox.command_event({"id": i, "status": "done", "params": {"sent_at": float(i)}})
    inbox.sent(Sent(RweParams(duration=0.5), 43.0, lambda: True))  # its start long forgotten
    inbox.sent(Sent(RweParams(duration=0.5), 44.0, lambda: True))  # the oldest remembered
    assert [s.sent_wall for s in inbox.take().sent] == [43.0]


def test_the_commanded_marker_is_solid_or_an_outline_never_both() -> None:
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        marker = CommandedMarker(server.scene)
        target = (np.array([0.4, 0.0, 0.3]), np.array([0.0, 1.0, 0.0, 0.0]))
        marker.show(target, resolved=False)
        assert marker.outline.frame.visible and not marker.solid.frame.visible
        marker.show(target, resolved=True)  # the robot said where it resolved it
        assert marker.solid.frame.visible and not marker.outline.frame.visible
        marker.show(None, resolved=True)
        assert not marker.solid.frame.visible and not marker.outline.frame.visible
    finally:
        server.stop()


def test_a_stale_picture_greys_every_mesh_and_a_fresh_one_gives_the_colours_back() -> None:
    from robot_sim.geometry import scene_geometry
    from robot_sim.sim import Simulation
    from server.models import GeometryModel
    from web.arm_bodies import STALE_GREY, ArmBodies

    sim = Simulation("surface")
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        arm = ArmBodies(server.scene)
        arm.load(GeometryModel(scene="surface", **scene_geometry(sim.model, sim.data)))
        own = [tuple(handle.color) for handle, _ in arm._meshes]
        assert own and any(color != STALE_GREY for color in own)
        arm.set_stale(True, "STALE")
        assert all(tuple(handle.color) == STALE_GREY for handle, _ in arm._meshes)
        arm.set_stale(False, "STALE")
        assert [tuple(handle.color) for handle, _ in arm._meshes] == own
    finally:
        server.stop()


def test_the_replay_slider_ends_on_its_step_at_or_before_the_recordings_end() -> None:
    from web.replay_timeline import slider_end

    assert slider_end(12.349) == pytest.approx(12.34)  # rounding would seek past the end
    assert slider_end(12.34) == pytest.approx(12.34) and slider_end(0.004) == 0.0


def test_take_control_is_offered_only_to_a_browser_without_control() -> None:
    from web.control_line import ControlLine

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        line = ControlLine(server.gui, order=1.0)
        # Before the seat says anything: watching, with the button under the line.
        assert not line.mine and 'data-mine="0"' in line._line.content and line.take_control.visible
        assert line.take_control.order > line._line.order
        line.show(mine=False, holder="operator 2")
        assert line.take_control.visible and not line.mine
        line.show(mine=True, holder="operator 1")
        assert not line.take_control.visible and line.mine
    finally:
        server.stop()


def test_a_paused_replay_fills_its_plots_once_the_recording_is_read() -> None:
    """Paused, nothing else would come to draw them; playing, the telemetry does."""
    from types import SimpleNamespace
    from typing import Any, cast

    from web.replay_plots import ReplayPlots

    drawn: list[tuple[str, Any]] = []
    plots = SimpleNamespace(
        window_s=10.0,
        set_thresholds=lambda thresholds: drawn.append(("thresholds", thresholds)),
        jump=lambda samples, marks_s: drawn.append(("samples", samples)),
    )
    record = SimpleNamespace(
        window=lambda at_s, span_s: SimpleNamespace(
            thresholds=(25.0, 2.5), samples=[at_s, span_s], marks_s=[]
        )
    )
    ReplayPlots(cast(Any, plots)).read(cast(Any, record), lambda: None)
    assert drawn == []
    ReplayPlots(cast(Any, plots)).read(cast(Any, record), lambda: 3.0)
    assert drawn == [("thresholds", (25.0, 2.5)), ("samples", [3.0, 10.0])]


def test_playback_asks_the_playhead_paused_or_playing() -> None:
    from typing import Any, cast

    from web.playback import Playback

    class Status:
        status: dict[str, Any]

    at = Status()
    at.status = {"playing": False, "position_s": 4.25}
    assert Playback._paused_at_s(cast(Any, at)) == 4.25
    at.status = {"playing": True, "position_s": 4.25}
    assert Playback._paused_at_s(cast(Any, at)) is None


def test_a_seek_goes_where_the_browser_moved_the_slider_though_the_poll_moved_it_back() -> None:
    """viser sets a moved slider's value, awaits its async callbacks, then runs the others on its
    thread pool; the playhead's poll (another thread) may set the old position in between. On
    main the seek read the slider when its thread ran, and went back to where the playhead was."""
    import asyncio
    import inspect
    from types import SimpleNamespace
    from typing import Any, cast

    from web.replay_timeline import Timeline

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        seeks: list[tuple[int, float]] = []
        status = {"duration_s": 20.0, "position_s": 19.0}
        timeline = Timeline(server.gui, server.gui.add_folder("Replay"), status, lambda: None)
        timeline._on_seek = lambda: seeks.append(timeline.request())  # type: ignore[method-assign]
        slider = cast(Any, timeline)._slider
        event = viser.GuiEvent(cast(Any, SimpleNamespace()), 1, slider)
        # viser runs them in this order: the move must be taken by the first, on its loop.
        assert [inspect.iscoroutinefunction(c) for c in slider._impl.update_cb] == [True, False]
        slider._impl.value = 7.5  # the browser's move, as viser applies it
        later = []
        for callback in slider._impl.update_cb:
            if inspect.iscoroutinefunction(callback):
                asyncio.run(callback(event))
            else:
                later.append(callback)
        timeline.show({**status, "position_s": 19.0})  # the poll, answered before the seek
        for callback in later:  # the pool's turn
            callback(event)
        assert seeks == [(1, 7.5)]
    finally:
        server.stop()


def test_a_playhead_polled_across_a_seek_is_not_shown() -> None:
    """The poll asked where the playhead was, a seek moved it meanwhile, then the poll's older
    answer came: on main it was shown, and the slider went back to where the playhead had been
    until the next poll."""
    from typing import Any

    from web.playback import Playback

    status = {"file": "/r.mcap", "duration_s": 20.0, "position_s": 19.0, "playing": False}
    status |= {"speed": 1.0, "speeds": [1.0]}
    playback: Any = None

    puts: list[dict[str, Any]] = []

    class Api:
        def get(self) -> dict[str, Any]:
            playback.timeline._requested_s, playback.timeline._requests = 5.0, 1  # a browser's move
            playback._seek()  # its seek lands while this answer is on its way
            return {**status, "position_s": 19.0}

        def put(self, **change: Any) -> dict[str, Any]:
            puts.append(change)
            return {**status, **change}

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        playback = Playback(server.gui, Api(), status, on_jump=lambda: None)  # type: ignore[arg-type]
        playback._closed = Rounds(1)  # one round of the loop, then closed
        playback._run()
        assert playback.status["position_s"] == 5.0  # the seek's answer, not the older poll's
        playback._seek()  # a second thread for the same move (a burst of moves): one seek only
        assert puts == [{"position_s": 5.0}]
    finally:
        server.stop()


def test_a_playhead_polled_while_a_seek_is_on_its_way_is_not_shown() -> None:
    """The poll asked while the seek's PUT was in flight and was answered first, with the old
    position: that answer came after the seek's and must not undo it."""
    import threading
    from typing import Any

    from web.playback import Playback

    status = {"file": "/r.mcap", "duration_s": 20.0, "position_s": 19.0, "playing": False}
    status |= {"speed": 1.0, "speeds": [1.0]}
    put_sent, put_answered = threading.Event(), threading.Event()

    class Api:
        def get(self) -> dict[str, Any]:
            put_answered.set()  # the replay answers the PUT just after this GET
            return {**status, "position_s": 19.0}

        def put(self, **change: Any) -> dict[str, Any]:
            put_sent.set()
            put_answered.wait(5.0)
            return {**status, **change}

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        playback: Any = Playback(server.gui, Api(), status, on_jump=lambda: None)  # type: ignore[arg-type]
        playback.timeline._requested_s, playback.timeline._requests = 5.0, 1
        seek = threading.Thread(target=playback._seek)
        seek.start()
        assert put_sent.wait(5.0)
        playback._closed = Rounds(1)  # one round of the loop, then closed
        playback._run()  # asks now, mid-PUT; shows only once the seek is done
        seek.join(5.0)
        assert playback.status["position_s"] == 5.0
    finally:
        server.stop()
