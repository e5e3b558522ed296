"""The pinned status bar: how old the robot's state is, the link, the scene, the running command,
the task's progress and STOP, in a panel of its own that never scrolls away.

The age is recomputed by a ticker whether or not data arrives (teleoperation paper: awareness of
delay): a blackout or a dead link shows as a growing age that turns amber, then red, never as a
frozen "1.50 s old - connected".
"""

import contextlib
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import viser

from web.markup import Markup, add_html, show
from web.monitor_line import monitor_html
from web.stop_sender import StopState
from web.telemetry_health import LinkLine
from web.worker import Worker

TICK_S = 0.08  # the bar's refresh period: 12.5 updates/s whether or not telemetry arrives
LATE_AFTER_RTT_S = 1.0  # amber: state older than the round trip plus this
STALE_AFTER_RTT_S = 5.0  # red: older than the round trip plus this, or the link is down
BAR_WIDTH_PX = 540
PAGE_DEAD_AFTER_S = 2.5  # no bar update for this long: the console or the page's socket is gone
# A page cannot tick when the console that feeds it is dead, so the page itself keeps time: every
# update re-creates this banner, restarting its hidden CSS countdown; if updates stop, it appears.
DEAD_MAN_HTML = Markup(
    "<style>@keyframes ptwl-dead {{ to {{ visibility: visible; max-height: 4em; }} }}</style>"
    '<div id="ptwl-dead" style="visibility:hidden;max-height:0;overflow:hidden;'
    "animation:ptwl-dead 0s linear {}s forwards;"
    'background:#e03131;color:white;font-weight:700;padding:2px 6px">'
    "CONSOLE NOT RESPONDING: nothing on this page is current</div>"
).format(PAGE_DEAD_AFTER_S)
# What the bar says while its ticks fail (the error, from our own code, escaped all the same).
# The count changes the content each tick, so the page's dead-man countdown restarts as usual.
FAILED_HTML = Markup(
    '<div id="ptwl-telemetry" data-level="stale" style="color:#e03131"><b>STATUS UNKNOWN</b>: the '
    "console cannot show the robot's state ({error}); tried {count} times, trying again</div>"
)
LOG = logging.getLogger(__name__)
LOG_EVERY_S = 10.0  # [s] at most one failed tick logged in this long
Level = Literal["fresh", "late", "stale"]
LEVEL_COLORS = {"fresh": "#2f9e44", "late": "#f08c00", "stale": "#e03131"}


def staleness(age_s: float | None, rtt_s: float, link_up: bool) -> Level:
    """How much to trust the robot's state on screen, from its age and the link's round trip."""
    if not link_up or age_s is None or age_s > rtt_s + STALE_AFTER_RTT_S:
        return "stale"
    if age_s > rtt_s + LATE_AFTER_RTT_S:
        return "late"
    return "fresh"


@dataclass(frozen=True)
class BarInputs:
    """What the bar shows, read once per tick from the console."""

    state: dict[str, Any] | None  # the latest telemetry state
    arrived: float | None  # [s] Unix time it arrived
    link_up: bool  # the transport is connected (telemetry may still be silent: `link`)
    link: LinkLine  # what the telemetry stream shows of the link
    rtt_s: float  # the link's configured round trip (0 without a link)
    command: str  # the running or latest command, one line
    note: str  # e.g. "robot restarted at 12:00:01"
    scene_note: str = ""  # a reset on its way, or a new scene not drawn yet
    stop: StopState = field(default_factory=StopState)
    holder: str = ""  # who has control ("" nobody)
    predicted_port: tuple[float, float, float] | None = None  # [m] the ground twin's, if it runs
    prediction_error: tuple[float, float] | None = None  # [m] its last and 5 s max error
    twin_readout: str = ""  # how far its predictions were off, or why it is unsure now
    twin_sure: bool = False
    twin_note: str = ""  # why there is no prediction (the twin idles on a short link)
    recording: str = ""  # a replay: what is played (then nothing here reaches a robot)
    schedule: str = ""  # the link's schedule now and next (web/link_plan.py); "" on a plain link
    lost_since: float | None = None  # [s] Unix: the downlink closed then (loss of signal)
    state_every_s: float = 0.0  # [s] between states on a thinned socket (0: every state comes)


class StatusBar(Worker):
    """One window, drawn from one `BarInputs` per tick. STOP is its last row, and the window is
    anchored at the bottom with the height of its content: STOP stays where it is however many
    lines the text above wraps into, and nothing is cut off."""

    def __init__(
        self,
        gui: viser.GuiApi,
        inputs: Callable[[], BarInputs],
        on_level: Callable[[Level], None],
        on_tick: Callable[[BarInputs], None] = lambda _: None,
    ) -> None:
        self._inputs = inputs
        self._on_level = on_level
        self._on_tick = on_tick  # what else draws this model each tick (the ghost's label)
        self._level_shown: Level | None = None
        self._stop_shown: StopState | None = None
        self._failed_ticks = 0  # in a row
        self._logged_at = -math.inf  # [s] monotonic: when a failed tick was last logged
        self.panel = gui.add_panel()
        first = inputs()
        with self.panel.add_tab("Robot status"):
            self.html = add_html(gui, _render(first, *_judge(first, time.time())))
            self.stop_html = add_html(gui, _stop_html(first.stop))
            self.stop = gui.add_button(
                "STOP", color="red", hint="abort the running command, drop the queue, hold (anyone may stop)"
            )
        # Over the 3D view's bottom right, beside the docked control panel (notifications stack
        # top left, the arm stands mid-view): it never scrolls away, and no dropdown of the
        # control panel can cover STOP. No height: the window grows upward with its content.
        gui.main_panel.dock_right()
        self.panel.float(x=-12, y=-12, width=BAR_WIDTH_PX)
        super().__init__("ptwl-status-bar", join_timeout_s=2.0)

    def _run(self) -> None:
        while not self._closed.wait(TICK_S):
            try:
                self._tick()
            except Exception as error:  # one failed tick must not freeze the bar for every page
                self._failed(error)

    def _tick(self) -> None:
        inputs = self._inputs()
        age, level = _judge(inputs, time.time())
        show(self.html, _render(inputs, age, level))
        self._on_tick(inputs)
        if inputs.stop != self._stop_shown:
            self._stop_shown = inputs.stop
            show(self.stop_html, _stop_html(inputs.stop))
        self._show_level(level)
        self._failed_ticks = 0

    def _failed(self, error: Exception) -> None:
        """The bar says in red that it cannot show the robot's state, and the robot is drawn
        stale; the next tick tries again. A failed tick is logged with its traceback, at most one
        every LOG_EVERY_S (not 12 a second)."""
        said = f"{type(error).__name__}: {error}"[:200]
        self._failed_ticks += 1
        now = time.monotonic()
        if now - self._logged_at >= LOG_EVERY_S:
            LOG.exception("the status bar's tick failed; it tries again every %.2f s", TICK_S)
            self._logged_at = now
        with contextlib.suppress(Exception):  # e.g. the page's handles already removed
            body = FAILED_HTML.format(error=said, count=self._failed_ticks)
            show(self.html, _framed(LEVEL_COLORS["stale"], body, self._failed_ticks))
            self._show_level("stale")

    def _show_level(self, level: Level) -> None:
        if level != self._level_shown:
            self._level_shown = level
            self._on_level(level)


def _render(inputs: BarInputs, age: float | None, level: Level) -> Markup:
    color = LEVEL_COLORS[level]
    state = inputs.state
    seq = state["seq"] if state else ""
    if state is None:
        robot = Markup("no robot state yet")
    else:
        x, y, z = (1000.0 * v for v in state["port"]["position"])
        force_n = math.hypot(*state["wrench"][0:3])
        robot = Markup(
            "robot state #{} is <b>{:.2f} s old</b> · port ({:.1f}, {:.1f}, {:.1f}) mm · "
            "<b>|f| {:.1f} N</b> · scene <b>{}</b>{}"
        ).format(seq, age, x, y, z, force_n, state["scene"], _scene_note_html(inputs.scene_note))
    stale = Markup(" · <b>STALE</b>: the robot may have moved since") if level == "stale" else ""
    if inputs.recording:
        link = Markup(
            '<div id="ptwl-link" data-level="fresh" style="color:#7048e8"><b>REPLAY</b> of {}: '
            "what was recorded, nothing here reaches a robot</div>"
        ).format(inputs.recording)
    else:
        link = Markup('<div id="ptwl-link" data-level="{}" style="color:{}">{}{}</div>').format(
            inputs.link.level, LEVEL_COLORS[inputs.link.level], inputs.link.text, inputs.note
        )
    body = Markup(
        '<div id="ptwl-telemetry" data-seq="{seq}" data-arrived="{arrived}" data-age="{age}" '
        'data-level="{level}" data-link="{link_up}" data-rtt="{rtt}">{robot}{stale}</div>'
        "{link}{schedule}"
        '<div id="ptwl-running">{command} · <span id="ptwl-holder">control: {holder}</span></div>'
        "{prediction}{task}{monitor}"
    ).format(
        seq=seq,
        arrived=inputs.arrived or "",
        age="" if age is None else age,
        level=level,
        link_up=int(inputs.link_up),
        rtt=inputs.rtt_s,
        robot=robot,
        stale=stale,
        link=link,
        schedule=_schedule_html(inputs.schedule, inputs.lost_since),
        command=inputs.command,
        holder=inputs.holder or "nobody",
        prediction=_prediction_html(
            inputs.predicted_port,
            inputs.prediction_error,
            inputs.twin_readout,
            inputs.twin_sure,
            inputs.twin_note,
        ),
        task=_task_html(state.get("task") if state else None),
        monitor=monitor_html(
            state.get("monitor") if state else None, bool(state and state.get("active_command") is not None)
        ),
    )
    return _framed(color, body)


def _framed(color: str, body: Markup, failed_ticks: int = 0) -> Markup:
    """The bar's window: its level's colour down the left, and the dead-man banner in every
    update (each one restarts the page's countdown); `failed_ticks` in a row, if any."""
    failed = Markup(' data-failed="{}"').format(failed_ticks) if failed_ticks else ""
    return Markup(
        '<div id="ptwl-bar"{} style="border-left:8px solid {};padding:2px 8px;font-size:0.85em">{}{}</div>'
    ).format(failed, color, DEAD_MAN_HTML, body)


def _schedule_html(line: str, lost_since: float | None) -> Markup:
    """The link schedule's line: red through a loss of signal."""
    if not line:
        return Markup("")
    lost = lost_since is not None
    return Markup('<div id="ptwl-schedule" data-los="{}" style="color:{};{}">{}</div>').format(
        int(lost), LEVEL_COLORS["stale"] if lost else "#495057", "font-weight:700" if lost else "", line
    )


def _scene_note_html(note: str) -> Markup:
    if not note:
        return Markup("")
    return Markup(' · <b id="ptwl-scene-note" style="color:#f08c00">{}</b>').format(note)


def _prediction_html(
    port: tuple[float, float, float] | None,
    error: tuple[float, float] | None,
    readout: str,
    sure: bool,
    note: str = "",
) -> Markup:
    """The ground twin's line: where it puts the port now, and how far off it has been or why it
    cannot be believed now (or why there is no prediction)."""
    if port is None:
        return Markup(
            '<div id="ptwl-prediction" data-x="" data-error-mm="" data-max-mm="" data-sure="0" '
            'style="color:#868e96">{}</div>'
        ).format(note)
    x, y, z = (1000.0 * v for v in port)
    error_mm, max_mm = ("", "") if error is None else (f"{1000.0 * error[0]:.3f}", f"{1000.0 * error[1]:.3f}")
    return Markup(
        '<div id="ptwl-prediction" data-x="{x:.2f}" data-y="{y:.2f}" data-z="{z:.2f}" '
        'data-error-mm="{error}" data-max-mm="{max}" data-sure="{sure}" style="color:{color}">'
        "twin: port ({x:.1f}, {y:.1f}, {z:.1f}) mm · {readout}</div>"
    ).format(
        x=x,
        y=y,
        z=z,
        error=error_mm,
        max=max_mm,
        sure=int(sure),
        color="#0c8599" if sure else "#e8590c",
        readout=readout,
    )


def _judge(inputs: BarInputs, now: float) -> tuple[float | None, Level]:
    """([s] how old the state is now, from when the robot sent it and counting on while nothing
    comes; how far to trust it)."""
    age = None if inputs.state is None else now - float(inputs.state["sent_at"])
    # A thinned socket's next state is due state_every_s after the last: not late before then.
    return age, staleness(age, inputs.rtt_s + inputs.state_every_s, inputs.link_up)


def _fraction_done(progress: float | None, target: float, at_most: bool) -> float:
    """How full the task's bar is: progress over target, or for an error to shrink (at_most),
    target over progress."""
    if progress is None:
        return 0.0
    if at_most:
        return 1.0 if progress <= target else max(0.0, target / progress)
    return 0.0 if target == 0 else max(0.0, min(1.0, progress / target))


def _task_html(task: dict[str, Any] | None) -> Markup:
    if not task:
        return Markup('<div id="ptwl-task" data-success="" data-progress="">task: unknown</div>')
    progress, target, unit = task["progress"], task["target"], task["unit"]
    # Three significant digits of the target's size (12.3 / 30 mm, 0.00 / 5 N): no noise digits.
    decimals = max(0, 2 - math.floor(math.log10(abs(target)))) if target else 3
    shown = "—" if progress is None else f"{round(progress, decimals) + 0.0:.{decimals}f}"  # never "-0"
    fraction = _fraction_done(progress, target, bool(task.get("at_most")))
    badge = (
        Markup('<span style="background:#2f9e44;color:white;padding:0 6px;border-radius:4px">SUCCESS</span>')
        if task["success"]
        else Markup('<span style="color:#868e96">not yet</span>')
    )
    return Markup(
        '<div id="ptwl-task" data-success="{success}" data-progress="{progress}" data-target="{target}" '
        'title="{predicate}">task: {shown} / {target:g} {unit} {badge}'
        '<div style="height:6px;background:#e9ecef;border-radius:3px">'
        '<div style="height:6px;width:{width:.0f}%;background:#1971c2;border-radius:3px"></div>'
        "</div></div>"
    ).format(
        success=int(task["success"]),
        progress=progress,
        target=target,
        predicate=task["predicate"],
        shown=shown,
        unit=unit,
        badge=badge,
        width=100 * fraction,
    )


def _stop_html(stop: StopState) -> Markup:
    styles = {
        "idle": "color:#868e96",
        "pending": "color:white;background:#f08c00;font-weight:700",
        "confirmed": "color:#2f9e44;font-weight:600",
        "failed": "color:white;background:#e03131;font-weight:700",
    }
    return Markup(
        '<div id="ptwl-stop" data-phase="{}" data-attempts="{}" style="padding:2px 6px;{}">{}</div>'
    ).format(stop.phase, stop.attempts, styles[stop.phase], stop.text)
