"""A preview drawn in one browser's 3D view: the attractor's path (orange), the port's
(cyan, the twin's colour) and a label at the port's end saying how it ends."""

import numpy as np
import viser

from web.preview import PreviewResult

ORANGE = (247, 103, 7)
CYAN = (21, 170, 191)
MAX_SEGMENTS = 24


class PreviewMarks:
    def __init__(self, scene: viser.SceneApi, root: str = "/preview") -> None:
        empty = np.zeros((1, 2, 3))
        self.attractor = scene.add_line_segments(
            f"{root}/attractor", empty, ORANGE, thickness=2.0, visible=False
        )
        self.port = scene.add_line_segments(f"{root}/port", empty, CYAN, thickness=3.0, visible=False)
        self.label = scene.add_label(f"{root}/end", "", visible=False, anchor="bottom-left")

    def show(self, result: PreviewResult) -> None:
        self.attractor.points = _segments(result.attractor_path)
        self.port.points = _segments(result.port_path)
        self.label.position = tuple(result.port_path[-1])
        self.label.text = f"preview: {result.exit}, peak {result.peak_force_n:.1f} N"
        for handle in (self.attractor, self.port, self.label):
            handle.visible = True

    def hide(self) -> None:
        for handle in (self.attractor, self.port, self.label):
            handle.visible = False


def _segments(path: np.ndarray) -> np.ndarray:
    """(n, 3) points as at most MAX_SEGMENTS segments, (m, 2, 3), ends kept (one point: a zero-length
    one). Thick lines cost the browser per segment every frame: a 10 s path at 20 ms is 500."""
    if len(path) < 2:
        path = np.vstack([path, path])
    if len(path) > MAX_SEGMENTS + 1:
        path = path[np.linspace(0, len(path) - 1, MAX_SEGMENTS + 1).round().astype(int)]
    return np.stack([path[:-1], path[1:]], axis=1).astype(np.float32)
