"""The replay's transport, shown when the robot is a recording (`ptwl replay`): play/pause, speed
and a time slider, driving the replay's playhead (GET/PUT /_replay), with the recording's commands
marked on it (web/replay_marks.py).

The slider follows the playhead 4 times a second; only a browser's own move of it seeks (a
value the console sets itself comes with no client). After a seek the console re-reads the
history as it was at the new time (`on_jump`), and the plots take the recording's force/torque
up to it (web/replay_record.py): paused, nothing else would come to draw.
"""

import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import viser

from web.markup import Markup, add_html, show
from web.plots import WrenchPlots
from web.replay_api import ReplayApi
from web.replay_plots import ReplayPlots
from web.replay_record import ReplayRecord
from web.replay_timeline import Timeline, slider_end
from web.worker import Worker

POLL_S = 0.25
READ_JOIN_S = 5.0  # [s] past it (an hour of recording takes ~18 s to index) the daemon reader is
# left to finish on its own: it drops what it read once it sees the console closed
PLAYBACK_ORDER = 1.5  # just under the pinned status bar


class Playback(Worker):
    def __init__(
        self,
        gui: viser.GuiApi,
        api: ReplayApi,
        status: dict[str, Any],
        on_jump: Callable[[], None],
        plots: WrenchPlots | None = None,
    ) -> None:
        self._api = api
        self._on_jump = on_jump
        self._plots = ReplayPlots(plots)
        self.status = status
        # viser runs each slider update on a thread of its pool: seeks in quick succession would
        # interleave (the plots filled for one, the playhead at the other). One change at a time,
        # each seek to the newest move (a burst of moves is one seek); a poll whose answer may
        # predate a change (asked before it ended) is not shown.
        self._changing = threading.RLock()
        self._changes = 0  # counted as each change is sent and as it is answered
        self._seeks_done = 0  # the timeline's move the last seek went to
        speeds = [f"{s:g}x" for s in status["speeds"]]
        with gui.add_folder("Replay", expand_by_default=True, order=PLAYBACK_ORDER) as folder:
            self.title = add_html(gui, _title_html(status))
            self.play = gui.add_button("Pause" if status["playing"] else "Play")
            self.speed = gui.add_dropdown("Speed", speeds, initial_value=f"{status['speed']:g}x")
        self.timeline = Timeline(gui, folder, status, self._seek)

        @self.play.on_click
        def _(_: viser.GuiEvent) -> None:
            self.put(playing=not self.status["playing"])

        @self.speed.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:
                self.put(speed=float(self.speed.value[:-1]))

        super().__init__("ptwl-playback", join_timeout_s=POLL_S + 2.0)
        self._reader = threading.Thread(target=self._read_record, name="ptwl-replay-record", daemon=True)

    @property
    def record(self) -> ReplayRecord | None:
        return self._plots.record

    def start(self) -> None:
        super().start()
        self._reader.start()

    def close(self) -> None:
        super().close()
        if self._reader.is_alive():  # indexing a long file: it checks `_closed` once done
            self._reader.join(timeout=READ_JOIN_S)
        self._api.close()  # after its poller has stopped (joined above)

    def _read_record(self) -> None:
        """(its own thread) Index the recording; then mark its commands on the timeline and, if
        paused, fill the plots up to the playhead."""
        try:
            record = ReplayRecord(Path(self.status["file"]))
        except (OSError, ValueError) as err:  # a RecordingError is a ValueError
            self.timeline.cannot_mark(f"not shown: the console cannot read {self.status['file']} ({err})")
            return
        if self._closed.is_set():
            return
        self._plots.read(record, self._paused_at_s)
        self.timeline.mark(record.commands, record.duration_s)

    def _paused_at_s(self) -> float | None:
        """[s] the playhead if paused; None while playing (the telemetry draws the plots)."""
        status = self.status
        return None if status["playing"] else float(status["position_s"])

    def put(self, **change: Any) -> dict[str, Any] | None:
        """The change made: the playhead as the replay answered (None if it did not: the next
        poll shows where the playhead really is)."""
        with self._changing:
            self._changes += 1
            status = self._api.put(**change)
            self._changes += 1
            if status is not None:
                self._show(status)
            return status

    def _seek(self) -> None:
        with self._changing:
            move, position_s = self.timeline.request()
            if move == self._seeks_done:
                return  # a seek on another thread already went to this move or a newer one
            self._seeks_done = move
            # The slider's end is the duration rounded down to its step: there, the very end.
            end_s = self.status["duration_s"]
            status = self.put(position_s=end_s if position_s >= slider_end(end_s) else position_s)
            self._on_jump()
            if status is not None:  # its answer, not `self.status`: a poll answered late may be older
                self._plots.fill(float(status["position_s"]))

    def _run(self) -> None:
        while not self._closed.wait(POLL_S):
            changes = self._changes
            status = self._api.get()
            with self._changing:
                if status is not None and changes == self._changes:
                    self._show(status)

    def _show(self, status: dict[str, Any]) -> None:
        self.status = status
        self.play.label = "Pause" if status["playing"] else "Play"
        self.timeline.show(status)
        show(self.title, _title_html(status))


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
