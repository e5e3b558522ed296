"""The replay's transport, shown when the robot is a recording (`ptwl replay`): play/pause, speed
and a time slider, driving the replay's playhead (GET/PUT /_replay), with the recording's commands
marked on it (web/replay_marks.py).

The slider follows the playhead 4 times a second; only a browser's own move of it seeks (a
value the console sets itself comes with no client). After a seek the console re-reads the
history as it was at the new time (`on_jump`), and the plots take the recording's force/torque
up to it (web/replay_record.py): paused, nothing else would come to draw.
"""

import math
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import httpx
import viser

from guard.access import bearer_header
from web.markup import Markup, add_html, show
from web.plots import WrenchPlots
from web.replay_marks import marks_html, slider_marks
from web.replay_record import CommandSpan, ReplayRecord
from web.worker import Worker

POLL_S = 0.25
PLAYBACK_ORDER = 1.5  # just under the pinned status bar


def replay_status(robot_url: str, token: str | None) -> dict[str, Any] | None:
    """The playhead if the robot is a replay, else None (a live robot has no /_replay)."""
    try:
        response = httpx.get(robot_url + "/_replay", headers=bearer_header(token), timeout=5.0)
    except httpx.HTTPError:
        return None
    return response.json() if response.status_code == 200 else None


class Playback(Worker):
    def __init__(
        self,
        gui: viser.GuiApi,
        robot_url: str,
        token: str | None,
        status: dict[str, Any],
        on_jump: Callable[[], None],
        plots: WrenchPlots | None = None,
    ) -> None:
        self._url = robot_url + "/_replay"
        self._headers = bearer_header(token)
        self._on_jump = on_jump
        self._plots = plots
        self._gui = gui
        self.status = status
        self.record: ReplayRecord | None = None  # once the console has read the file
        self._marked: list[CommandSpan] | None = None  # the commands marked on the timeline
        self._note = "reading the recording"
        self._slider_lock = threading.Lock()  # the slider is made again when the marks are known
        self._fill_lock = threading.RLock()  # the plots filled by one seek (or the first read) at a time
        speeds = [f"{s:g}x" for s in status["speeds"]]
        with gui.add_folder("Replay", expand_by_default=True, order=PLAYBACK_ORDER) as folder:
            self._folder = folder
            self.title = add_html(gui, _title_html(status))
            self.play = gui.add_button("Pause" if status["playing"] else "Play")
            self.speed = gui.add_dropdown("Speed", speeds, initial_value=f"{status['speed']:g}x")
            self.slider = self._add_slider(None, None)
            self.marks = add_html(gui, self._marks_html())

        @self.play.on_click
        def _(_: viser.GuiEvent) -> None:
            self.put(playing=not self.status["playing"])

        @self.speed.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:
                self.put(speed=float(self.speed.value[:-1]))

        super().__init__("ptwl-playback", join_timeout_s=POLL_S + 2.0)
        self._reader = threading.Thread(target=self._read_record, name="ptwl-replay-record", daemon=True)

    def _add_slider(self, marks: tuple[float | tuple[float, str], ...] | None, order: float | None) -> Any:
        slider = self._gui.add_slider(
            "Time [s]",
            min=0.0,
            max=max(_slider_end(self.status["duration_s"]), 0.01),
            step=0.01,
            initial_value=round(self.status["position_s"], 2) if marks is not None else 0.0,
            marks=marks,
            order=order,
        )

        @slider.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:  # a browser moved it: seek
                self._seek(float(slider.value))

        return slider

    def start(self) -> None:
        super().start()
        self._reader.start()

    def _read_record(self) -> None:
        """(its own thread) Index the recording; then mark its commands on the timeline and, if
        paused, fill the plots up to the playhead."""
        try:
            record = ReplayRecord(Path(self.status["file"]))
        except (OSError, ValueError) as err:  # a RecordingError is a ValueError
            self._note = f"not shown: the console cannot read {self.status['file']} ({err})"
            show(self.marks, self._marks_html())
            return
        if self._closed.is_set():
            return
        with self._fill_lock:  # a seek from now on fills after this, never before
            self.record = record
            if not self.status["playing"]:
                self._fill_plots(float(self.status["position_s"]))
        with self._slider_lock, self._folder:
            old = self.slider
            marks = slider_marks(record.commands, _slider_end(record.duration_s))
            self.slider = self._add_slider(marks, old.order)
            old.remove()
        self._marked = record.commands  # the strip after the slider: both show them, or neither
        show(self.marks, self._marks_html())

    def _fill_plots(self, position_s: float) -> None:
        """The plots as they were at `position_s`, from the recording."""
        with self._fill_lock:
            record, plots = self.record, self._plots
            if record is None or plots is None:
                return
            window = record.window(position_s, plots.window_s)
            plots.set_thresholds(window.thresholds)
            plots.jump(window.samples, window.marks_s)

    def _marks_html(self) -> Markup:
        return marks_html(
            self._marked,
            self.status["duration_s"],
            self.status["position_s"],
            self._note,
        )

    def put(self, **change: Any) -> dict[str, Any] | None:
        """The change made: the playhead as the replay answered (None if it did not)."""
        try:
            response = httpx.put(self._url, json=change, headers=self._headers, timeout=5.0)
        except httpx.HTTPError:
            return None  # the next poll shows where the playhead really is
        if response.status_code != 200:
            return None
        status: dict[str, Any] = response.json()
        self._show(status)
        return status

    def _seek(self, position_s: float) -> None:
        # The slider's end is the duration rounded down to its step: there, seek to the very end.
        end_s = self.status["duration_s"]
        status = self.put(position_s=end_s if position_s >= _slider_end(end_s) else position_s)
        self._on_jump()
        if status is not None:  # its answer, not `self.status`: a poll answered late may be older
            self._fill_plots(float(status["position_s"]))

    def _run(self) -> None:
        while not self._closed.wait(POLL_S):
            try:
                response = httpx.get(self._url, headers=self._headers, timeout=2.0)
            except httpx.HTTPError:
                continue
            if response.status_code == 200:
                self._show(response.json())

    def _show(self, status: dict[str, Any]) -> None:
        self.status = status
        self.play.label = "Pause" if status["playing"] else "Play"
        with self._slider_lock:
            cast(Any, self.slider).value = round(status["position_s"], 2)  # no client: not a seek
        show(self.title, _title_html(status))
        show(self.marks, self._marks_html())


def _slider_end(duration_s: float) -> float:
    """The slider's last value: the duration rounded down to its 0.01 s step (never past the end)."""
    return math.floor(duration_s * 100.0) / 100.0


def _title_html(status: dict[str, Any]) -> Markup:
    return Markup(
        '<div id="ptwl-replay" data-position="{position:.3f}" data-playing="{playing}" '
        'data-speed="{speed:g}" style="padding:2px 8px;border-left:6px solid #7048e8">'
        "<b>Replay</b> of {name}: "
        "{position:.2f} / {duration:.2f} s, {state} at {speed:g}x. Nothing can be sent to a recording.</div>"
    ).format(
        position=status["position_s"],
        playing=int(status["playing"]),
        speed=status["speed"],
        name=status["file"].rsplit("/", 1)[-1],
        duration=status["duration_s"],
        state="playing" if status["playing"] else "paused",
    )
