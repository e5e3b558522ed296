"""The twin's thread: every 20 ms, run the ground twin to "now" and move its ghost; stoppable."""

import time
import traceback
from collections.abc import Callable

import viser

from web.ghost import GhostView
from web.twin import GroundTwin, Prediction, describe_error
from web.worker import Worker

TICK_S = 0.02


def error_text(summary: tuple[float, float] | None) -> str:
    """The ghost's label: how far its predictions of the port were off when telemetry showed them."""
    return f"predicted · {describe_error(summary)}"


class TwinWorker(Worker):
    def __init__(
        self,
        twin: GroundTwin,
        ghost: GhostView,
        server: viser.ViserServer,
        on_prediction: Callable[[Prediction], None],
    ) -> None:
        self._twin, self._ghost, self._server = twin, ghost, server
        self._on_prediction = on_prediction
        self.failure = ""
        super().__init__("ptwl-twin", join_timeout_s=2.0)

    def _run(self) -> None:
        while not self._closed.wait(TICK_S):
            try:
                prediction = self._twin.advance(time.time())
            except Exception:  # a display aid must never take the console down: say it, go on
                self.failure = traceback.format_exc(limit=3)
                continue
            if prediction is None:
                continue
            with self._server.atomic():
                self._ghost.show(prediction, error_text(self._twin.error_summary()))
            self._on_prediction(prediction)
