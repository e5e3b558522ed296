"""Where each 3D label sits: an offset in its frame's axes and the corner of its text that is
pinned there. One table, so the layout can be checked: tests/test_label_layout.py projects every
label through the console's initial camera on a 1366x768 screen and finds none on another.

At rest the port, the attractor, the ghost's port and the contemplated target are all in one
place, so their texts go to four different sides: the port's right and down, the attractor's left
and up, the ghost's right and up above them, the targets' along their shafts, higher still.
"""

from dataclasses import dataclass
from typing import Literal

Anchor = Literal["top-left", "top-right", "bottom-left", "bottom-right", "center-left", "bottom-center"]


@dataclass(frozen=True)
class LabelPlace:
    offset_m: tuple[float, float, float]  # [m] in the parent frame's axes (a port's z is the tool's)
    anchor: Anchor  # the text's corner at that point


PORT = LabelPlace((0.0, 0.0, 0.015), "top-left")
ATTRACTOR = LabelPlace((0.0, 0.0, 0.015), "bottom-right")
GHOST = LabelPlace((0.0, 0.0, -0.03), "bottom-left")
COMMANDED = LabelPlace((0.0, 0.0, -0.12), "center-left")  # also the predicted (outline) one
CONTEMPLATED = LabelPlace((0.0, 0.0, -0.16), "center-left")
MIN_DISTANCE_LABEL_MM = 1.0  # a target closer to the port gets no line and no "0.0 mm" on it
