"""Serve a recording as the robot (`ptwl replay-serve`, started by `ptwl replay`)."""

import signal
from pathlib import Path

import uvicorn

from ptwl.guard.access import AccessPolicy, check_token_setting
from ptwl.guard.listen import bind, listening_url
from ptwl.recording.replay.player import Player
from ptwl.recording.replay.timeline import Timeline
from server.replay.app import create_replay_app


def load(path: Path) -> Timeline:
    timeline = Timeline(path)  # an index of the file, in bounded memory
    if not timeline.complete:
        print(f"ptwl replay: {path} was cut short ({timeline.problem}); replaying what is whole", flush=True)
    return timeline


def serve_replay(path: Path, host: str, port: int, play: bool, speed: float) -> None:
    check_token_setting(None, host)  # no token here: loopback only, as every server of ours
    timeline = load(path)
    player = Player(timeline.start_ns, timeline.end_ns)
    player.set(playing=play, speed=speed)
    sock = bind(host, port)
    bound_port = sock.getsockname()[1]
    print(
        f"ptwl replay-serve: {path.name} ({timeline.duration_s:.1f} s) as a robot on {listening_url(sock)}",
        flush=True,
    )
    app = create_replay_app(timeline, player, AccessPolicy(host, bound_port))
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="off"))
    for sig in (signal.SIGINT, signal.SIGTERM):  # uvicorn re-raises after its graceful stop
        signal.signal(sig, lambda signum, frame: None)
    server.run(sockets=[sock])
