"""The replay's transport, shown when the robot is a recording (`ptwl replay`): play/pause, speed
and a time slider, driving the replay's playhead (GET/PUT /_replay).

The slider follows the playhead 4 times a second; only a browser's own move of it seeks (a
value the console sets itself comes with no client). After a seek the console re-reads the
history as it was at the new time (`on_jump`).
"""

import math
from collections.abc import Callable
from typing import Any, cast

import httpx
import viser

from guard.access import bearer_header
from web.markup import Markup, add_html, show
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
    ) -> None:
        self._url = robot_url + "/_replay"
        self._headers = bearer_header(token)
        self._on_jump = on_jump
        self.status = status
        speeds = [f"{s:g}x" for s in status["speeds"]]
        with gui.add_folder("Replay", expand_by_default=True, order=PLAYBACK_ORDER):
            self.title = add_html(gui, _title_html(status))
            self.play = gui.add_button("Pause" if status["playing"] else "Play")
            self.speed = gui.add_dropdown("Speed", speeds, initial_value=f"{status['speed']:g}x")
            self.slider = gui.add_slider(
                "Time [s]",
                min=0.0,
                max=max(_slider_end(status["duration_s"]), 0.01),
                step=0.01,
                initial_value=0.0,
            )
        self.play.on_click(lambda _: self.put(playing=not self.status["playing"]))

        @self.speed.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:
                self.put(speed=float(self.speed.value[:-1]))

        @self.slider.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:  # a browser moved it: seek
                self._seek(float(self.slider.value))

        super().__init__("ptwl-playback", join_timeout_s=POLL_S + 2.0)

    def put(self, **change: Any) -> None:
        try:
            response = httpx.put(self._url, json=change, headers=self._headers, timeout=5.0)
        except httpx.HTTPError:
            return  # the next poll shows where the playhead really is
        if response.status_code == 200:
            self._show(response.json())

    def _seek(self, position_s: float) -> None:
        # The slider's end is the duration rounded down to its step: there, seek to the very end.
        end_s = self.status["duration_s"]
        self.put(position_s=end_s if position_s >= _slider_end(end_s) else position_s)
        self._on_jump()

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
        cast(Any, self.slider).value = round(status["position_s"], 2)  # no client: not a seek
        show(self.title, _title_html(status))


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
