"""`ptwl console`: run the operator console until SIGINT/SIGTERM."""

import signal
import threading

from robot_sim.warm import warm_up
from web.app import ConsoleApp


def run_console(
    robot_url: str,
    host: str,
    port: int,
    token: str | None,
    allow_origins: tuple[str, ...] = (),
    replay: bool = False,
) -> None:
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    warm_s = warm_up()  # the twin and the preview run the compiled tick: not on a first click
    print(f"ptwl console: compiled tick loaded in {warm_s:.1f} s", flush=True)
    app = ConsoleApp(robot_url, host=host, port=port, token=token, allow_origins=allow_origins, replay=replay)
    print(f"ptwl console: operator console on {app.url} (robot via {robot_url})", flush=True)
    try:
        app.connect()
        stop.wait()
    finally:
        app.close()
        print("ptwl console: stopped", flush=True)
