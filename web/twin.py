"""The ground twin behind the predictive display (issue 14; the teleoperation paper's commanded
and predicted displays): the console's own copy of the robot model, started from the latest
delayed telemetry and fed every command sent since, simulated forward to "now".

"Now" is the robot at the moment a command sent now would reach it: robot sim time
t(W) = t_state + (W - taken_at_state) (the robot runs paced to its wall clock), taken at
W = now + uplink. So the twin leads the delayed picture by a round trip, and a command starts
moving it as soon as it is sent; telemetry shows the same instant a round trip later, which is
when the twin's prediction for it is judged (`errors`).

Every `RESYNC_S` the twin restarts from the latest state (Simulation.sync_to), re-issues the
robot's running PTWL (its remaining part, toward the goal the robot resolved) and this console's
commands the robot has not started, each no earlier than it can arrive, one after another; in
between it runs on in real time. It knows the nominal scene only (no seeded misalignment), RWE,
Dither and state machines the robot is running are not replayed (the twin holds), and other
senders' commands are seen only once they run: the prediction error readout says how far to
trust it.
"""

import threading
from collections.abc import Callable
from typing import Any

from robot_sim.task_frames import TaskFrames
from web.twin_inbox import TwinInbox
from web.twin_judge import PredictionJudge
from web.twin_registration import Registered
from web.twin_sim import Prediction, Sent, TwinPoint, TwinSim, arrival_sim_s, robot_wall_s

RESYNC_S = 0.5  # [s] wall time between restarts from the latest telemetry
SHOWN_FROM_MM = 0.1  # a fixture the twin moved less than this is where its model says: not shown


class GroundTwin:
    def __init__(self, uplink_s: Callable[[], float], register: bool = True) -> None:
        """`register`: move the twin's fixture to where the robot's contacts say it is
        (web/twin_registration.py); False keeps the nominal model (for comparison)."""
        self._uplink_s = uplink_s
        self._lock = threading.Lock()  # the inbox and the judge: fed from any thread
        self._inbox = TwinInbox()
        self._judge = PredictionJudge()
        self._sim = TwinSim(register)  # the twin's thread's alone
        self.registered: Registered | None = None  # where the twin put its fixture, if it moved it
        self._resynced_wall = float("-inf")
        self.latest: Prediction | None = None
        self.point: TwinPoint | None = None
        self.advanced_wall: float | None = None  # [s] the "now" of the last advance
        # The robot's task frames as the console last heard (its scene's are where the seed put
        # the fixtures, which the twin's nominal scene does not know).
        self.frames = TaskFrames()

    # ----------------------------------------------------------- inputs (any thread)
    def on_state(self, state: dict[str, Any], arrived_wall: float) -> float | None:
        """A telemetry state arrived: the twin's next start, and a judge of what it predicted.
        Returns |predicted - reported| port position [m], if it had predicted that instant."""
        with self._lock:
            if self._inbox.state_arrived(state):
                self._judge.forget()  # a scene (re)loaded: the twin restarts from this state
            return self._judge.judge(state, arrived_wall)

    def on_command(self, message: dict[str, Any]) -> None:
        """A command event from the robot: which command runs (replayed at each restart)."""
        with self._lock:
            self._inbox.command_event(message)

    def on_sent(self, sent: Sent) -> None:
        """This console sent a command: the twin starts it now (it is at the robot's "now" + uplink)."""
        with self._lock:
            self._inbox.sent(sent)

    def pause(self) -> None:
        """The worker stops advancing the twin (a short link): it restarts from telemetry when
        it goes on, and says nothing of the now meanwhile."""
        with self._lock:
            self._inbox.resync_due = True
            self.point = None

    def on_stop(self, sent_wall: float) -> None:
        """STOP sent: this console's commands will not run; until the robot confirms, the
        twin still replays the robot's running move (the ghost is unsure: web/twin_trust.py)."""
        with self._lock:
            self._inbox.stop_sent(sent_wall)

    def on_stop_confirmed(self, aborted: int | None) -> None:
        """The robot confirmed a STOP: the command it aborted is not replayed any more."""
        with self._lock:
            self._inbox.stop_confirmed(aborted)

    @property
    def stop_sent_wall(self) -> float | None:
        """[s] a STOP sent, not confirmed yet."""
        with self._lock:
            return self._inbox.stop_sent_wall

    def judged_wall(self) -> float | None:
        """[s] when a prediction was last judged against the robot's state; None: not since the
        start or the last scene reset."""
        with self._lock:
            return self._judge.judged_wall()

    def error_summary(self) -> tuple[float, float] | None:
        """(last, max over the last ERROR_WINDOW_S) |prediction error| [m]; None before any."""
        with self._lock:
            return self._judge.summary()

    # ------------------------------------------------------------- the twin's thread
    def advance(self, now_wall: float) -> Prediction | None:
        """Run the twin to the robot's sim time at now + uplink; restart it from the latest state
        every RESYNC_S. Returns the prediction for now (None before any telemetry)."""
        with self._lock:
            heard = self._inbox.take()
        state = heard.state
        if state is None:
            return None
        uplink_s = self._uplink_s()
        t_state, taken_at = float(state["sim_time"]), robot_wall_s(state)
        target_s = arrival_sim_s(t_state, taken_at, now_wall, uplink_s)  # a command sent now
        new_model = self._sim.load(state["scene"])
        if heard.reloaded and not new_model:  # the same scene again: its fixture may be elsewhere now
            self._sim.forget_registration()
        if new_model or heard.resync_due or now_wall - self._resynced_wall >= RESYNC_S:
            self._sim.restart(state, heard.running, heard.sent, uplink_s, self.frames)
            self._resynced_wall = now_wall
        else:
            # At their arrival, not at the twin's time now: a starved twin thread stands behind
            # the send, and would start the command early by as long as it was held up.
            self._sim.queue_at_arrival(heard.new, t_state, taken_at, uplink_s)
        # What the ghost shows, every RECORD_S: a restart's replay up to there is not recorded.
        self._sim.run_to(target_s, self._keep, self._judge.next_due_s)
        self.latest = self._sim.prediction()
        registration = self._sim.registration
        registered = registration.registered() if registration is not None else None
        self.registered = (
            registered if registered is not None and registered.moved_mm >= SHOWN_FROM_MM else None
        )
        self.advanced_wall = now_wall
        self.point = self._sim.point(self.frames)
        return self.latest

    def _keep(self, sim_time: float, port_position: Any) -> None:
        """Called after each stretch of steps, which run_to ends on every instant a prediction is
        due (`next_due_s`, read without the lock like `due`; once forgotten, the next is kept at
        the stretch's end, at most RECORD_S late): the lock only when one is due, and then asked
        again under it (a state's arrival may have forgotten the predictions)."""
        if not self._judge.due(sim_time):  # only this thread records
            return
        with self._lock:
            if self._judge.due(sim_time):
                self._judge.record(sim_time, port_position.copy())
