"""`ptwl up`: robot server, link proxy and console as three processes on 127.0.0.1.

Each is its own `ptwl` subprocess, so no package imports another to launch it. Ctrl-C (or
SIGTERM) stops all three; if one dies, the others are stopped and the exit names it.
"""

import signal
import sys
import threading
from contextlib import ExitStack

from ptwl.launcher import ServiceProcess, running

POLL_S = 0.2


def up(
    scene: str,
    link_args: list[str],
    server_port: int = 8000,
    proxy_port: int = 8001,
    console_port: int = 8080,
) -> int:
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    children: dict[str, ServiceProcess] = {}
    with ExitStack() as stack:
        try:
            children["robot server"] = stack.enter_context(
                running(
                    "serve",
                    "--port",
                    str(server_port),
                    "--scene",
                    scene,
                    health="/api/health",
                    echo="[robot] ",
                )
            )
            children["link proxy"] = stack.enter_context(
                running(
                    "proxy",
                    "--upstream",
                    children["robot server"].url,
                    "--port",
                    str(proxy_port),
                    *link_args,
                    health="/_link/profile",
                    echo="[link]  ",
                )
            )
            children["console"] = stack.enter_context(
                running(
                    "console",
                    "--robot",
                    children["link proxy"].url,
                    "--port",
                    str(console_port),
                    health="/",
                    startup_timeout=120.0,
                    echo="[console] ",
                )
            )
        except RuntimeError as err:
            print(f"ptwl up: a process did not start: {err}", file=sys.stderr, flush=True)
            return 1
        print(f"ptwl up: open {children['console'].url} (Ctrl-C stops all three)", flush=True)
        while not stop.wait(POLL_S):
            for name, child in children.items():
                code = child.process.poll()
                if code is not None:
                    print(
                        f"ptwl up: the {name} exited with code {code}; stopping the others", file=sys.stderr
                    )
                    return 1
        print("ptwl up: stopping", flush=True)
    return 0
