"""The task frames' 3D marks (web/frames_view.py) on a real viser scene."""

import warnings

import viser

from ptwl.launcher import free_port
from web.frames_view import FramesView

POSE = {"position": [0.1, 0.0, 0.2], "quaternion": [1.0, 0.0, 0.0, 0.0]}


def frame(name: str, x_m: float = 0.1) -> dict[str, object]:
    return {"name": name, "pose": {**POSE, "position": [x_m, 0.0, 0.2]}}


def test_a_frame_gone_from_the_list_is_removed_with_its_label_and_the_rest_stay() -> None:
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        view = FramesView(server.scene)
        view.show([frame("plate_normal"), frame("peg_axis", 0.3)])
        assert server.scene.get_handle_by_name("/task_frames/plate_normal/label") is not None
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # viser warns when a removed node is removed again
            view.show([frame("peg_axis", 0.4)])
        assert server.scene.get_handle_by_name("/task_frames/plate_normal") is None
        assert server.scene.get_handle_by_name("/task_frames/plate_normal/label") is None
        peg = server.scene.get_handle_by_name("/task_frames/peg_axis")
        assert peg is not None and tuple(peg.position) == (0.4, 0.0, 0.2)  # moved, not redrawn
        assert server.scene.get_handle_by_name("/task_frames/peg_axis/label") is not None
    finally:
        server.stop()
