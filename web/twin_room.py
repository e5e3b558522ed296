"""The predictive display's parts: the ground twin (web/twin.py), its ghost and the thread that
runs one and moves the other, and the latest prediction."""

import viser

from web.ghost import GhostView
from web.robot_link import RobotLink
from web.twin import GroundTwin, Prediction
from web.twin_worker import TwinWorker


class TwinRoom:
    def __init__(self, server: viser.ViserServer, link: RobotLink, min_rtt_s: float) -> None:
        self.twin = GroundTwin(link.uplink_s)
        self.ghost = GhostView(server)
        self.prediction: Prediction | None = None
        self.worker = TwinWorker(self.twin, self.ghost, server, self._predicted, link.rtt_s, min_rtt_s)

    def _predicted(self, prediction: Prediction | None) -> None:
        self.prediction = prediction

    def idle_note(self) -> str:
        """Why there is no prediction: the twin idles on a short link."""
        if not self.worker.idle:
            return ""
        return f"twin: idle below a {self.worker.min_rtt_s:g} s round trip (the picture is the present)"
