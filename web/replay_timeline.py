"""The replay's time slider and, under it, the strip of the recording's commands
(web/replay_marks.py). The commands are marked on the slider once the recording is read; only a
browser's own move of it seeks (a value the console sets itself comes with no client)."""

import math
import threading
from collections.abc import Callable
from typing import Any, cast

import viser
from viser._gui_api import _build_slider_marks

from web.markup import Markup, add_html, show
from web.replay_marks import marks_html, slider_marks
from web.replay_record import CommandSpan


class Timeline:
    def __init__(
        self,
        gui: viser.GuiApi,
        folder: viser.GuiFolderHandle,
        status: dict[str, Any],
        on_seek: Callable[[], None],
    ) -> None:
        self._gui, self._on_seek = gui, on_seek
        self._status = status
        self._lock = threading.Lock()  # the poll and the reader both change the slider
        self._marked: list[CommandSpan] | None = None  # the commands marked on the timeline
        self._note = "reading the recording"
        self._requested_s = 0.0  # [s] where a browser last moved the slider
        self._requests = 0  # how many moves a browser has made
        with folder:
            self._slider = self._add_slider()
            self._strip = add_html(gui, self._strip_html())

    def _add_slider(self) -> Any:
        slider = self._gui.add_slider(
            "Time [s]",
            min=0.0,
            max=max(slider_end(self._status["duration_s"]), 0.01),
            step=0.01,
            initial_value=0.0,
        )

        # viser sets the value, then awaits async callbacks on its event loop and hands the others
        # to its thread pool, where the playhead's poll may have set its older position over the
        # value meanwhile: the move is taken here, first (registered first), and the seek
        # (blocking HTTP) runs on the pool, to the newest move (request()).
        @slider.on_update
        async def _(event: viser.GuiEvent) -> None:
            if event.client is not None:
                self._requested_s = float(slider.value)
                self._requests += 1

        @slider.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:  # a browser moved it: seek
                self._on_seek()

        return slider

    def request(self) -> tuple[int, float]:
        """(how many moves a browser has made, where [s] the newest one put the slider)."""
        return self._requests, self._requested_s

    def mark(self, commands: list[CommandSpan], duration_s: float) -> None:
        """The recording's commands, on the slider and the strip: both show them, or neither."""
        marks = slider_marks(commands, slider_end(duration_s))
        with self._lock:
            # Marked in place: a slider made again would take the operator's focus or drag away
            # (viser 1.1 keeps them in its `_marks` prop, built as add_slider(marks=...) builds them).
            slider = cast(Any, self._slider)
            slider.max = max(slider_end(duration_s), 0.01)
            slider._marks = _build_slider_marks(marks)
        self._marked = commands
        show(self._strip, self._strip_html())

    def cannot_mark(self, note: str) -> None:
        self._note = note
        show(self._strip, self._strip_html())

    def show(self, status: dict[str, Any]) -> None:
        """The playhead as the replay said."""
        self._status = status
        with self._lock:
            cast(Any, self._slider).value = round(status["position_s"], 2)  # no client: not a seek
        show(self._strip, self._strip_html())

    def _strip_html(self) -> Markup:
        return marks_html(self._marked, self._status["duration_s"], self._status["position_s"], self._note)


def slider_end(duration_s: float) -> float:
    """The slider's last value: the duration rounded down to its 0.01 s step (never past the end)."""
    return math.floor(duration_s * 100.0) / 100.0
