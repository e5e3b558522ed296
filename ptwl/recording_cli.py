"""`ptwl report FILE.mcap`, `ptwl replay FILE.mcap` (and its robot stand-in, `replay-serve`)."""

import argparse
import json
import signal
import threading
from pathlib import Path

from ptwl.launcher import free_port, start

REPLAY_STARTUP_S = 120.0  # [s] the stand-in may take to index a file and answer


def add_recording_parsers(sub: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    report = sub.add_parser("report", help="the paper's per-trial figures from a recording")
    report.add_argument("file", type=Path, metavar="FILE.mcap")
    report.add_argument("--json", action="store_true", help="one JSON object per trial, for scripts")
    report.set_defaults(func=cmd_report)
    replay = sub.add_parser("replay", help="open the console on a recording: play, pause, speed, seek")
    replay.add_argument("file", type=Path, metavar="FILE.mcap")
    replay.add_argument("--port", type=int, default=8080, help="the console's port")
    replay.add_argument("--paused", action="store_true", help="start paused at the beginning")
    replay.add_argument("--speed", type=float, default=1.0, help="x real time (0.1-16)")
    replay.set_defaults(func=cmd_replay)
    stand_in = sub.add_parser("replay-serve", help=argparse.SUPPRESS)
    stand_in.add_argument("file", type=Path)
    stand_in.add_argument("--host", default="127.0.0.1")
    stand_in.add_argument("--port", type=int, default=0)
    stand_in.add_argument("--paused", action="store_true")
    stand_in.add_argument("--speed", type=float, default=1.0)
    stand_in.set_defaults(func=cmd_replay_serve)


def cmd_report(args: argparse.Namespace) -> int:
    """Streams the file (ptwl/recording/reader.py's bounds); a file no writer of ours made is a
    RecordingError (a ValueError): one line naming it, exit 2."""
    from ptwl.recording.report import report_json, report_text

    _check_file(args.file)
    if args.json:
        print(json.dumps(report_json(args.file), indent=2))
    else:
        print(report_text(args.file), end="")
    return 0


def cmd_replay_serve(args: argparse.Namespace) -> int:
    from server.replay.serve import serve_replay

    _check_file(args.file)
    serve_replay(args.file, args.host, args.port, play=not args.paused, speed=args.speed)
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    """The recording as a robot, and the console on it; Ctrl-C stops both."""
    from ptwl.recording.replay.player import MAX_SPEED, SPEEDS

    _check_file(args.file)
    if not min(SPEEDS) <= args.speed <= MAX_SPEED:
        raise ValueError(f"--speed must be in [{min(SPEEDS):g}, {MAX_SPEED:g}], got {args.speed:g}")
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    flags = ["--speed", f"{args.speed}", *(["--paused"] if args.paused else [])]
    # Not echoed: the first "on http://" a launcher sees must be the console's.
    try:
        robot = start(  # it indexes the file first: ~18 s for an hour of recording (docs/recording.md)
            "replay-serve",
            str(args.file),
            "--port",
            str(free_port()),
            *flags,
            health="/_replay",
            startup_timeout=REPLAY_STARTUP_S,
        )
    except RuntimeError as err:  # it said why (a file that is no recording) as it exited
        raise ValueError(str(err).rsplit("ptwl: ", 1)[-1].strip()) from None
    for line in robot.output:  # what it said besides its URL (a file cut short)
        if " on http://" not in line:
            print(f"[replay] {line}", end="", flush=True)
    try:
        console = start(
            "console",
            "--replay",
            "--robot",
            robot.url,
            "--port",
            str(args.port),
            health="/",
            startup_timeout=120.0,
            echo="[console] ",
        )
    except BaseException:
        robot.stop()
        raise
    print(
        f"ptwl replay: open {console.url}, replaying {args.file} from robot {robot.url} (Ctrl-C stops)",
        flush=True,
    )
    try:
        while not stop.wait(0.2):
            if robot.process.poll() is not None or console.process.poll() is not None:
                print("ptwl replay: a process exited; stopping", flush=True)
                return 1
        return 0
    finally:
        console.stop()
        robot.stop()


def _check_file(path: Path) -> None:
    if not path.is_file():
        raise ValueError(f"no recording {str(path)!r}")
