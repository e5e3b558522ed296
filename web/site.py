"""The console's web surface: the viser server (GUI, 3D scene, toasts) behind its front door,
opened and closed in the one order that works."""

import contextlib
import io

import viser

from web.front_door import FrontDoor, admit_only_through
from web.notifier import Notifier
from web.robot_view import INITIAL_CAMERA


class ConsoleSite:
    def __init__(self, host: str, port: int, allow_origins: tuple[str, ...]) -> None:
        # viser checks no Origin: it listens on an ephemeral loopback port behind the front door,
        # which checks Host, Origin and the token (web/front_door.py). The front door binds first,
        # so that viser's ephemeral port cannot be the one asked for.
        self.front_door = FrontDoor(host, port, allow_origins)
        self.front_door.start()
        try:
            # Not printed: viser's own box names its inner port, which refuses a browser (only
            # the front door's URL, printed by the caller, opens the console).
            with contextlib.redirect_stdout(io.StringIO()):
                self.viser = viser.ViserServer(host="127.0.0.1", port=0, label="ptwl console", verbose=False)
        except BaseException:
            self.front_door.close()
            raise
        try:
            admit_only_through(self.front_door, self.viser)
            self.front_door.inner_port = self.viser.get_port()
            self.viser.initial_camera.position, self.viser.initial_camera.look_at = INITIAL_CAMERA
            self.viser.gui.configure_theme(control_width="large", dark_mode=False)
            self.notifier = Notifier(self.viser)
        except BaseException:
            self.close()
            raise

    @property
    def url(self) -> str:
        return f"http://{self.front_door.address}"

    def close(self) -> None:
        # viser first, while the front door still carries its close handshake to the browsers:
        # closed the other way round, viser waited out its close timeout (6 s) on pipes nobody
        # read any more.
        self.viser.stop()
        self.front_door.close()
