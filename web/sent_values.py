"""What a view last sent to the browsers, per key: each assignment to a viser handle is a message
to every browser, so a pose or a line that has not moved is not sent again."""

import numpy as np
import viser

from web.markers import MOVE_EPSILON


class SentValues:
    def __init__(self) -> None:
        self._sent: dict[str, np.ndarray] = {}

    def clear(self) -> None:
        self._sent.clear()

    def moved(self, key: str, values: np.ndarray) -> bool:
        """True (and remembered) if `values` differ from the last sent under `key`."""
        last = self._sent.get(key)
        if last is not None and float(np.max(np.abs(last - values))) < MOVE_EPSILON:
            return False
        self._sent[key] = values
        return True

    def place(self, key: str, handle: viser.FrameHandle, pose: np.ndarray) -> bool:
        """Put a frame at pose [x y z qw qx qy qz] if it moved; True if it was sent."""
        if not self.moved(key, pose):
            return False
        handle.position, handle.wxyz = pose[0:3], pose[3:7]
        return True
