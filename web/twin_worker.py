"""The twin's thread: every 20 ms, run the ground twin to "now" and move its ghost; stoppable.

Below a round trip of `min_rtt_s` the delayed picture is the present: the twin idles and the
ghost hides, and the core it would take stays free for the rest (on a 2-core machine running the
robot, the console and a browser, that is most of the difference)."""

import time
import traceback
from collections.abc import Callable

import viser

from web.ghost import GhostView
from web.twin import GroundTwin, Prediction
from web.worker import Worker

TICK_S = 0.02


class TwinWorker(Worker):
    def __init__(
        self,
        twin: GroundTwin,
        ghost: GhostView,
        server: viser.ViserServer,
        on_prediction: Callable[[Prediction | None], None],
        rtt_s: Callable[[], float],
        min_rtt_s: float,
    ) -> None:
        self._twin, self._ghost, self._server = twin, ghost, server
        self._on_prediction = on_prediction
        self._rtt_s, self.min_rtt_s = rtt_s, min_rtt_s
        self.idle = False
        self.failure = ""
        super().__init__("ptwl-twin", join_timeout_s=2.0)

    def _run(self) -> None:
        while not self._closed.wait(TICK_S):
            if self._rtt_s() < self.min_rtt_s:
                if not self.idle:
                    self.idle = True
                    self._twin.pause()
                    self._ghost.hide()
                    self._on_prediction(None)
                continue
            self.idle = False
            try:
                prediction = self._twin.advance(time.time())
            except Exception:  # a display aid must never take the console down: say it, go on
                self.failure = traceback.format_exc(limit=3)
                continue
            if prediction is None:
                continue
            with self._server.atomic():
                self._ghost.show(prediction)
            self._on_prediction(prediction)
