"""Each command's life as the console sees it, and the counts the paper's tables use.

A command sent from this console is `sent` at once (the operator sees it immediately), then
`queued` when the robot's 202 comes back over the link, `running` and `done` from telemetry.
Commands from other consoles or scripts appear from their telemetry events alone.

Ids are the robot's and never repeat, but a restarted robot has forgotten the commands it had
queued or running: when the robot's `instance` changes those are shown `lost`, never as the
result of a later command, and the history starts again from them.

Bounded: at most MAX_VIEWS commands are kept (a script can send commands for as long as it likes);
the oldest finished ones are then folded into the counts and forgotten, so the paper's counts
still cover the whole session. While a send's 202 is on its way, events of commands of the same
behavior that this console does not know yet are held (one may be that send's): at most MAX_VIEWS
of them, the newest. When no send waits any more (each 202 or refusal that lands), what is held
is applied, oldest first: to the send it turned out to be, else as someone else's command.
"""

import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from ptwl.recording.topics import command_event
from robot_sim.exit_severity import Severity, severity
from robot_sim.limits import COMMAND_HISTORY_MAX

SEVERITY_COLORS = {  # Mantine's green, violet, orange and red (the phases are blue)
    Severity.SUCCESS: "#2f9e44",
    Severity.NOTICE: "#ae3ec9",
    Severity.WARNING: "#e8590c",
    Severity.ERROR: "#e03131",
}
PHASE_COLORS = {"sent": "#1971c2", "queued": "#1971c2", "running": "#7048e8"}


def exit_color_hex(exit_condition: str | None) -> str:
    """An exit's colour in the history and the replay's marks, by its severity."""
    return SEVERITY_COLORS[severity(exit_condition)]


@dataclass
class CommandView:
    local: int
    behavior: str
    phase: str  # sent | queued | running | done | refused
    id: int | None = None
    exit: str | None = None
    sent_at: float = field(default_factory=time.time)
    peak_force: float | None = None
    peak_torque: float | None = None
    duration: float | None = None
    detail: str = ""
    target: Any = None  # (position, wxyz): predicted at Send, then as the robot resolved it
    resolved: bool = False  # target is the goal the robot computed when the command started
    sender: str | None = None
    steps: list[dict[str, Any]] = field(default_factory=list)  # a state machine's, as they end
    scene: str = ""  # the robot's scene when the console first knew of it

    @property
    def short_label(self) -> str:
        """The id's last 4 digits (ids are 16 digits long: the table's space is for the numbers)."""
        return f"#…{self.id % 10_000:04d}" if self.id is not None else f"(local {self.local})"

    @property
    def label(self) -> str:
        return f"#{self.id}" if self.id is not None else f"(local {self.local})"

    @property
    def status(self) -> str:
        return self.exit if self.phase == "done" and self.exit else self.phase

    @property
    def color(self) -> str:
        return exit_color_hex(self.exit) if self.phase == "done" else PHASE_COLORS.get(self.phase, "#495057")


MAX_VIEWS = COMMAND_HISTORY_MAX  # commands kept: as many as the robot's own history keeps


@dataclass
class _Folded:
    """What the paper's counts need of the finished commands no longer kept."""

    ptwl: Counter[str] = field(default_factory=Counter)
    rwe: int = 0
    dither: int = 0
    peak_force: float = 0.0
    peak_torque: float = 0.0


class CommandHistory:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._folded: dict[str, _Folded] = {}  # per scene
        self.scene = ""  # the scene new commands are counted under
        self._views: list[CommandView] = []
        self._by_id: dict[int, CommandView] = {}
        self._early: dict[int, dict[str, Any]] = {}  # events that beat their 202 back
        self._next_local = 1
        self._instance: str | None = None

    def sent(self, behavior: str, target: Any = None, sender: str | None = None) -> CommandView:
        with self._lock:
            view = CommandView(
                self._next_local, behavior, "sent", target=target, sender=sender, scene=self.scene
            )
            self._next_local += 1
            self._views.append(view)
            self._trim()
            return view

    def accepted(self, view: CommandView, command_id: int) -> list[tuple[CommandView, bool]]:
        """The robot's 202 for `view`; returns the held events it released, as `event` would."""
        with self._lock:
            view.id = command_id
            if view.phase == "sent":
                view.phase = "queued"
            other = self._by_id.get(command_id)
            if other is not None and other is not view:  # a reconcile showed it first: one line
                self._views.remove(other)
                _take_over(view, other)
            self._by_id[command_id] = view
            # Under the same lock: a newer event the feed delivers next comes after these.
            return self._release_held()

    def refused(self, view: CommandView, detail: str) -> list[tuple[CommandView, bool]]:
        """`view` never reached the robot; returns the held events that no send waits for now."""
        with self._lock:
            view.phase, view.exit, view.detail = "done", "refused", detail
            return self._release_held()

    def _release_held(self) -> list[tuple[CommandView, bool]]:
        """(under the lock) Apply the held events no send waits for any more (a known id's, or of
        a behavior no send of which is on its way), oldest first (by each id's newest event)."""
        waiting = {v.behavior for v in self._views if v.phase == "sent"}
        released = [
            message
            for command_id, message in self._early.items()
            if command_id in self._by_id or message["behavior"] not in waiting
        ]
        applied = []
        for message in released:
            del self._early[int(message["id"])]
            applied.append(self._apply_event(message))
        return [(view, ended) for view, ended in applied if view is not None]

    def stopped(self, aborted: int | None, dropped: list[int]) -> list[CommandView]:
        """A STOP the robot confirmed ended these commands `aborted`: shown at once, so no line
        keeps saying "running" while the end events are still on their way down (or lost).
        Returns the views that ended here."""
        ended = []
        with self._lock:
            for command_id in [*([] if aborted is None else [aborted]), *dropped]:
                view = self._by_id.get(command_id)
                if view is not None and view.phase != "done":
                    view.phase, view.exit = "done", "aborted"
                    view.detail = view.detail or "ended by a STOP the robot confirmed"
                    ended.append(view)
        return ended

    def event(self, message: dict[str, Any]) -> tuple[CommandView | None, bool]:
        """Apply a telemetry command event; (the view, whether it just ended)."""
        with self._lock:
            return self._apply_event(message)

    def _apply_event(self, message: dict[str, Any]) -> tuple[CommandView | None, bool]:
        """(under the lock)"""
        command_id = int(message["id"])
        view = self._by_id.get(command_id)
        if view is None:
            # Ours, with the 202 still on its way? Keep it until it lands; else someone else's.
            if any(v.phase == "sent" and v.behavior == message["behavior"] for v in self._views):
                self._early.pop(command_id, None)  # its newest event, last in the order
                self._early[command_id] = message
                while len(self._early) > MAX_VIEWS:  # a flood while ours is on its way
                    self._early.pop(next(iter(self._early)))  # the oldest goes first
                return None, False
            view = CommandView(0, message["behavior"], "queued", id=command_id, scene=self.scene)
            self._views.append(view)
            self._by_id[command_id] = view
            self._trim()
        self._early.pop(command_id, None)  # a copy held before the id was known is older
        was_done = view.phase == "done"
        _apply(view, message)
        return view, view.phase == "done" and not was_done

    def reconcile(self, records: list[dict[str, Any]]) -> list[CommandView]:
        """Take the robot's own records (GET /api/commands, after a reconnect or lost messages) as
        the truth: every command shown here gets its real state, and live commands not shown yet
        are added. Returns the views that ended here (their end event never arrived)."""
        ended = []
        with self._lock:
            for record in records:
                if self._instance is not None and record.get("instance", self._instance) != self._instance:
                    continue  # read from a run of the robot that has since restarted: stale
                view = self._by_id.get(int(record["id"]))
                self._early.pop(int(record["id"]), None)  # the robot's record is newer
                if view is None:
                    if record["status"] == "done":
                        continue  # finished before this console knew of it: not news
                    view = self._add_record_view(record)
                was_done = view.phase == "done"
                _apply_record(view, record)
                if view.phase == "done" and not was_done:
                    ended.append(view)
        return ended

    def replace(self, records: list[dict[str, Any]]) -> None:
        """Become exactly these records (GET /api/commands): a replay jumped to another time, so
        what was shown may not have happened yet."""
        with self._lock:
            self._views, self._by_id, self._early = [], {}, {}
            for record in records:
                _apply_record(self._add_record_view(record), record)

    def _add_record_view(self, record: dict[str, Any]) -> CommandView:
        """(under the lock) A view for a record of the robot's this console had not shown."""
        view = CommandView(0, record["type"], "queued", id=int(record["id"]), scene=self.scene)
        self._views.append(view)
        self._by_id[int(record["id"])] = view
        self._trim()
        return view

    def _trim(self) -> None:
        """(under the lock) Past MAX_VIEWS, fold the oldest finished commands into the counts."""
        excess = len(self._views) - MAX_VIEWS
        if excess <= 0:
            return
        old = [v for v in self._views if v.phase == "done"][:excess]
        for view in old:
            _fold(self._folded.setdefault(view.scene, _Folded()), view)
            if view.id is not None:
                self._by_id.pop(view.id, None)
        gone = {id(v) for v in old}
        self._views = [v for v in self._views if id(v) not in gone]

    def live(self) -> list[CommandView]:
        """Commands this console shows as queued or running."""
        with self._lock:
            return [v for v in self._views if v.phase in ("queued", "running")]

    def robot_instance(self, instance: str) -> list[CommandView] | None:
        """Note which run of the robot is reporting; if it changed, the commands the old run had
        queued or running are lost (returned, and kept as the start of a fresh history)."""
        with self._lock:
            previous, self._instance = self._instance, instance
            if previous is None or previous == instance:
                return None
            lost = [v for v in self._views if v.phase in ("queued", "running")]
            for view in lost:
                view.phase, view.exit = "done", "lost"
                view.detail = f"the robot restarted (run {previous} -> {instance}) before it ended"
            waiting = [v for v in self._views if v.phase == "sent"]  # their POST reaches the new run
            self._views = lost + waiting
            self._by_id = {}
            self._early = {}
            return lost

    def recent(self, n: int = 8) -> list[CommandView]:
        with self._lock:
            return list(self._views[-n:])

    def latest(self) -> CommandView | None:
        with self._lock:
            return self._views[-1] if self._views else None

    def set_scene(self, scene: str) -> None:
        """The robot loaded `scene`: commands from now on count toward it (a task's table)."""
        with self._lock:
            self.scene = scene

    def counts(self, scene: str | None = None) -> dict[str, Any]:
        """The paper's counts (Tables 1-3) for `scene` (None: every scene): PTWL by exit condition,
        RWE, Dither and their total, with the steps of state machines counted as the behaviors they
        ran; peak force and torque."""
        with self._lock:
            total = _Folded()
            for name, folded in self._folded.items():
                if scene is None or name == scene:
                    _merge(total, folded)
            for view in self._views:
                if scene is None or view.scene == scene:
                    _fold(total, view)
            return {
                "ptwl": dict(total.ptwl),
                "ptwl_total": sum(total.ptwl.values()),
                "rwe": total.rwe,
                "dither": total.dither,
                "behaviors": sum(total.ptwl.values()) + total.rwe + total.dither,
                "peak_force": total.peak_force,
                "peak_torque": total.peak_torque,
            }


def _fold(into: _Folded, view: "CommandView") -> None:
    """Count a command: a finished behavior (refused ones never ran: not counted), or each step a
    state machine has finished so far (the paper counts the behaviors a task took)."""
    if view.behavior == "state_machine":
        for step in view.steps:
            _count(into, step["behavior"], step["exit"], step.get("peak_force"), step.get("peak_torque"))
        return
    if view.phase != "done" or view.exit == "refused":
        return
    _count(into, view.behavior, view.exit, view.peak_force, view.peak_torque)


def _count(into: _Folded, behavior: str, exit: str | None, force: float | None, torque: float | None) -> None:
    if behavior == "ptwl":
        into.ptwl[str(exit)] += 1
    into.rwe += behavior == "rwe"
    into.dither += behavior == "dither"
    into.peak_force = max(into.peak_force, force or 0.0)
    into.peak_torque = max(into.peak_torque, torque or 0.0)


def _merge(into: _Folded, other: _Folded) -> None:
    into.ptwl.update(other.ptwl)
    into.rwe += other.rwe
    into.dither += other.dither
    into.peak_force = max(into.peak_force, other.peak_force)
    into.peak_torque = max(into.peak_torque, other.peak_torque)


def _apply_record(view: CommandView, record: dict[str, Any]) -> None:
    """A record (GET /api/commands) as the event it would have been."""
    _apply(view, command_event(record))


def _apply(view: CommandView, message: dict[str, Any]) -> None:
    """A robot record or event (the same fields) onto its view."""
    view.phase = message["status"]
    view.exit = message.get("exit")
    view.peak_force = message.get("peak_force")
    view.peak_torque = message.get("peak_torque")
    view.duration = message.get("duration")
    view.detail = message.get("detail") or ""
    view.sender = message.get("sender") or view.sender
    view.steps = message.get("steps") or view.steps
    goal = message.get("goal")
    if goal is not None:
        view.target = (goal["position"], goal["quaternion"])
        view.resolved = True


def _take_over(view: CommandView, shown: CommandView) -> None:
    """The robot's state of a command a reconcile showed before its 202 came back, onto the line
    of the send it was (one line per command, with the send's own number and target)."""
    view.phase, view.exit, view.detail, view.duration = shown.phase, shown.exit, shown.detail, shown.duration
    view.peak_force, view.peak_torque = shown.peak_force, shown.peak_torque
    view.sender, view.steps = shown.sender or view.sender, shown.steps or view.steps
    if shown.resolved:
        view.target, view.resolved = shown.target, True
