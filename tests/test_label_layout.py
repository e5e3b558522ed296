"""3D labels that do not overlap at 1366x768 (issue 27.5): on main "attractor" and the contemplated
target's "0.0 mm" were drawn on one another and read "at0.0ctor". Every label is projected here
through the console's initial camera as viser draws it (12 px em at an 800 px tall view, the
text's anchored corner on its point) and no two text boxes may meet."""

import itertools

import numpy as np
import pytest
import viser
import viser.transforms as tf

from robot_sim.sim import Simulation
from web.ghost import GhostView
from web.label_places import ATTRACTOR, COMMANDED, CONTEMPLATED, GHOST, PORT, LabelPlace
from web.robot_view import INITIAL_CAMERA, RobotView

VIEW_W_PX, VIEW_H_PX = 1366 - 400, 768  # the 3D view beside the docked control panel
FOV_Y_RAD = np.radians(75.0)  # viser's default
EM_PX = 12.0 * VIEW_H_PX / 800.0
CHAR_W_EM, BOX_H_EM = 0.6, 1.4  # a generous sans-serif glyph and the label's box


def project(point_world: np.ndarray) -> np.ndarray:
    eye, look_at = (np.asarray(v, dtype=float) for v in INITIAL_CAMERA)
    forward = (look_at - eye) / np.linalg.norm(look_at - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = point_world - eye
    focal_px = (VIEW_H_PX / 2.0) / np.tan(FOV_Y_RAD / 2.0)
    depth = d @ forward
    return np.array(
        [VIEW_W_PX / 2 + focal_px * (d @ right) / depth, VIEW_H_PX / 2 - focal_px * (d @ up) / depth]
    )


def box(place: LabelPlace, frame_p: np.ndarray, frame_q: np.ndarray, text: str) -> tuple[float, ...]:
    """(left, top, right, bottom) [px] of a label's text on screen."""
    x, y = project(frame_p + tf.SO3(frame_q).apply(np.asarray(place.offset_m)))
    w, h = len(text) * CHAR_W_EM * EM_PX, BOX_H_EM * EM_PX
    left = x - w if place.anchor.endswith("right") else x
    top = {"top": y, "bottom": y - h, "center": y - h / 2}[place.anchor.split("-")[0]]
    return left, top, left + w, top + h


def overlapping(boxes: dict[str, tuple[float, ...]]) -> list[tuple[str, str]]:
    return [
        (a, b)
        for (a, p), (b, q) in itertools.combinations(boxes.items(), 2)
        if p[0] < q[2] and q[0] < p[2] and p[1] < q[3] and q[1] < p[3]
    ]


@pytest.fixture(scope="module")
def port() -> tuple[np.ndarray, np.ndarray]:
    state = Simulation("free_space").state()
    return np.asarray(state.port.position), np.asarray(state.port.quaternion)


def test_at_rest_the_labels_of_the_port_attractor_ghost_and_target_are_apart(port) -> None:  # type: ignore[no-untyped-def]
    p, q = port
    boxes = {
        "port": box(PORT, p, q, "port"),
        "attractor": box(ATTRACTOR, p, q, "attractor"),
        "ghost": box(GHOST, p, q, "predicted · off 0.3 mm (max 0.9 over 5 s)"),
        "contemplated": box(CONTEMPLATED, p, q, "contemplated"),
        "commanded": box(COMMANDED, p, q, "commanded"),  # a move that ended where it began
    }
    assert overlapping(boxes) == []
    assert all(b[0] >= 0 and b[2] <= VIEW_W_PX and b[1] >= 0 and b[3] <= VIEW_H_PX for b in boxes.values())


@pytest.mark.parametrize(
    "move_mm", [(0.0, 40.0, 0.0), (0.0, -40.0, 0.0), (40.0, 0.0, 0.0), (0.0, 0.0, -30.0)]
)
def test_with_a_move_pending_the_targets_labels_are_apart_from_the_ports(port, move_mm) -> None:  # type: ignore[no-untyped-def]
    p, q = port
    target = p + np.asarray(move_mm) / 1000.0
    boxes = {
        "port": box(PORT, p, q, "port"),
        "attractor": box(ATTRACTOR, p, q, "attractor"),
        "ghost": box(GHOST, p, q, "predicted · UNSURE (the status bar says why)"),
        "contemplated": box(CONTEMPLATED, target, q, "contemplated"),
        "predicted": box(COMMANDED, target, q, "commanded: relative to port at start"),
    }
    assert overlapping(boxes) == []


def test_the_views_place_their_labels_as_the_table_says() -> None:
    """The layout above is the one drawn: each view takes its label's place from the table."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        view, ghost = RobotView(server, 0.001), GhostView(server)
        drawn = {
            "ghost": ghost.label,
            "commanded": view.commanded.solid.label,
            "predicted": view.commanded.outline.label,
        }
        places = {
            "ghost": GHOST,
            "commanded": COMMANDED,
            "predicted": COMMANDED,
            "contemplated": CONTEMPLATED,
        }
        for name, handle in drawn.items():
            place = places[name]
            assert tuple(handle.position) == place.offset_m and handle.anchor == place.anchor, name
    finally:
        server.stop()
