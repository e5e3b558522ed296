"""Each command's life on screen: the history and its counts, the latest command's line, the
commanded marker of the last PTWL this console sent, the plots' marks and thresholds, and the
notification when a command ends. Fed by the robot's command events, this console's sends, STOP's
answer, and a re-read of the robot's records after any gap; a replay's seek replaces it all."""

import threading
import time
from typing import Any

import httpx

from server.client import RobotClient, RobotError
from web.board import Board
from web.errands import Errands
from web.history import CommandHistory, CommandView
from web.notifier import Notifier, exit_color
from web.robot_view import RobotView

RECORDS_ON_RECONNECT = 100  # how many of the robot's recent records to re-read


class CommandLog:
    def __init__(self, client: RobotClient, board: Board, view: RobotView, notifier: Notifier) -> None:
        self.history = CommandHistory()
        self.commanded: CommandView | None = None  # the last PTWL this console sent
        self.restart_note = ""  # e.g. " · robot restarted at 12:00:01"
        self.closed = False
        self.errands = Errands()
        self._client, self._board, self._view, self._notifier = client, board, view, notifier
        self._reconciling = threading.Lock()

    # -------------------------------------------------------------- news
    def sent(self, behavior: str, target: Any, sender: str) -> CommandView:
        view = self.history.sent(behavior, target, sender)
        if behavior == "ptwl":
            self.commanded = view  # shown at once, as predicted: intent does not wait for the link
        self.changed(view)
        return view

    def on_command(self, message: dict[str, Any]) -> None:
        """(the feed's thread) A command event from the robot."""
        self.check_instance(message["instance"])
        self._plot_event(message)
        view, ended = self.history.event(message)
        if view is not None:
            self._show_applied([(view, ended)])

    def accepted(self, view: CommandView, command_id: int) -> None:
        """The robot's 202 for a send from here: its line, and the events held until it landed."""
        self._show_applied(self.history.accepted(view, command_id))
        self.changed(view)

    def refused(self, view: CommandView, detail: str) -> None:
        """A send that never reached the robot: its line, and the events no send waits for now."""
        self._show_applied(self.history.refused(view, detail))
        self.changed(view)

    def _show_applied(self, applied: list[tuple[CommandView, bool]]) -> None:
        """Events the history applied (`history.event`, or released by a 202 or a refusal):
        each line redrawn, each end announced."""
        for view, ended in applied:
            self.changed(view)
            if ended:
                self.announce_end(view)

    def stopped(self, aborted: int | None, dropped: list[int]) -> None:
        """STOP's answer: what it ended, said on every line at once."""
        for view in self.history.stopped(aborted, dropped):
            self.changed(view)
            self.announce_end(view)

    def check_instance(self, instance: str) -> None:
        """The robot restarted if its instance changed: say so, and show its cut-off commands lost."""
        lost = self.history.robot_instance(instance)
        if lost is None:
            return
        if any(v is self.commanded for v in lost):
            self._hide_commanded()
        labels = ", ".join(f"{v.behavior.upper()} {v.label}" for v in lost) or "none"
        self._notifier.notify("Robot restarted", f"commands it had not finished are lost: {labels}", "red")
        self.show(self.history.latest())
        # Last: the bar (its own thread) says "restarted" only once the command line says "lost".
        self.restart_note = f" · robot restarted at {time.strftime('%H:%M:%S')}"

    def set_scene(self, scene: str) -> None:
        self.history.set_scene(scene)  # the counts are per scene, as the paper's tables
        self._show_history()

    # ---------------------------------------------------------- drawing
    def changed(self, view: CommandView) -> None:
        """Show a command's new state: its line, the history, and the commanded marker."""
        if view is self.commanded:
            live = view.phase != "done" and view.target is not None
            self._view.show_commanded(view.target if live else None, view.resolved)
            marker = self._view.commanded.marker(view.resolved)
            self._board.show_commanded(view, marker.distance_mm)
        self.show(view)

    def announce_end(self, view: CommandView) -> None:
        said = (  # why an expired command never ran, what the monitor saw: that is what matters
            view.detail
            if view.exit in ("expired", "anomaly")
            else f"peak {view.peak_force or 0.0:.1f} N, {view.peak_torque or 0.0:.2f} N m"
        )
        title = f"{view.behavior.upper()} {view.label}: {view.exit}"
        self._notifier.notify(title, said, exit_color(view.exit))

    def show(self, view: CommandView | None) -> None:
        self._board.show_command(view)
        self._show_history()

    def _show_history(self) -> None:
        scene = self.history.scene
        self._board.show_history(self.history.counts(scene), list(reversed(self.history.recent(8))), scene)

    def _plot_event(self, message: dict[str, Any]) -> None:
        """Mark starts and exits on the plots; draw the running command's thresholds."""
        if message.get("started_at") is None:
            return  # queued, or dropped before it ran
        plots = self._board.plots
        plots.mark()
        params = message.get("params") or {}
        running = message["status"] == "running" and "force_threshold" in params
        plots.set_thresholds((params["force_threshold"], params["torque_threshold"]) if running else None)

    def _hide_commanded(self) -> None:
        """No commanded target on screen: its command is lost, or a replay left its time."""
        self._view.show_commanded(None)
        self._board.show_commanded(None)

    # ------------------------------------------------- the robot's records
    def reconcile_soon(self) -> None:
        """Re-read the robot's records in the background (at most one re-read at a time)."""
        if self._reconciling.acquire(blocking=False) and not self.errands.run(
            "ptwl-reconcile", self._reconcile
        ):
            self._reconciling.release()  # closed: nothing more is read

    def _reconcile(self) -> None:
        try:
            records = self._client.commands(limit=RECORDS_ON_RECONNECT)
        except (RobotError, httpx.HTTPError):
            return  # the next reconnect or gap tries again
        finally:
            self._reconciling.release()
        if self.closed:
            return
        for view in self.history.reconcile([r.model_dump() for r in records]):
            self.changed(view)
            self.announce_end(view)
        if self.commanded is not None:
            self.changed(self.commanded)
        self.show(self.history.latest())

    def replay_jumped(self) -> None:
        """A replay seek: the history and plots become what they were at the new time."""
        try:
            records = self._client.commands(limit=RECORDS_ON_RECONNECT)
        except (RobotError, httpx.HTTPError):
            return
        self.history.replace([r.model_dump() for r in records])
        self.commanded = None
        self._hide_commanded()
        self._board.plots.clear()
        self.show(self.history.latest())
