"""Benchmark: `ptwl report` and `ptwl replay`'s index over a long session recording: wall time
and peak memory (each in a fresh process: its peak RSS is its own).

The session is written by the recorder the robot uses (ptwl/recording/writer.py), as `ptwl serve
--record` fills it: a 50 Hz telemetry state (a real simulation state, its numbers moving), a
command every 20 s (queued, running, done, and its step), the task frames whole on each scene
load and on each frame added (one every 10 s), and a scene reset every 10 min (a new trial).

    python -m bench.recording [--minutes 60] [--file session.mcap]

Prints JSON: minutes, file_mb, messages, decompressed_mb, trials, report_s (wall),
report_cpu_s, report_peak_rss_mb, and the same for the replay's index (what `ptwl replay-serve`
does before it serves), with replay_states.
"""

import argparse
import json
import math
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ptwl.recording.writer import SessionRecorder
from robot_sim.geometry import moving_bodies, scene_geometry
from robot_sim.sim import Simulation
from robot_sim.telemetry import frames_message, state_fields

T0_NS = 1_800_000_000_000_000_000  # a Unix time, as a live session's log times are
HZ = 50  # the robot's default telemetry rate
COMMAND_EVERY_S = 20
FRAME_EVERY_S = 10
RESET_EVERY_S = 600


def write_session(path: Path, seconds: float, reset_every_s: float = RESET_EVERY_S) -> int:
    """A session of `seconds` at HZ, written as the robot's recorder writes one, a scene load
    every `reset_every_s`; returns how many states it holds."""
    sim = Simulation("surface", None)
    template = {"type": "state", **state_fields(sim, moving_bodies(sim.model)), "active_command": None}
    geometry = {"scene": "surface", **scene_geometry(sim.model, sim.data)}
    base_frames = frames_message(sim.frames)
    out = SessionRecorder(path, {"source": "bench.recording"})
    frames: list[dict[str, Any]] = []
    command = 0
    states = int(seconds * HZ)
    for i in range(states):
        t = i / HZ
        ns = T0_NS + int(t * 1e9)
        if i % round(reset_every_s * HZ) == 0:  # a scene load: a trial starts
            out.geometry(geometry, ns)
            frames = list(base_frames["frames"])
            out.frames({**base_frames, "frames": frames}, ns)
        elif i % (FRAME_EVERY_S * HZ) == 0:  # an operator's frame: the whole list recorded
            frames = [*frames, {**frames[0], "name": f"mark_{i}", "source": "operator"}]
            out.frames({**base_frames, "rev": len(frames), "frames": frames}, ns)
        out.state(_moved(template, i, t), ns)
        phase = i % (COMMAND_EVERY_S * HZ)
        if phase in (HZ, HZ + 5, 6 * HZ):
            if phase == HZ:
                command += 1
            status = {HZ: "queued", HZ + 5: "running", 6 * HZ: "done"}[phase]
            done = status == "done"
            event = {
                "type": "command",
                "id": command,
                "behavior": "ptwl",
                "status": status,
                "sender": "bench",
                "exit": "goal_reached" if done else None,
                "params": {"translation": [0.0, 0.0, 0.01], "duration": 5.0},
                "peak_force": 3.0 + command % 7 if done else None,
                "peak_torque": 0.1 if done else None,
            }
            out.command(event, ns + 1)
            if done:
                step = {
                    "index": 0,
                    "behavior": "ptwl",
                    "why": "",
                    "exit": "goal_reached",
                    "started_at": t - 5.0,
                    "ended_at": t,
                    "peak_force": 3.0 + command % 7,
                    "peak_torque": 0.1,
                }
                out.step(command, step, ns + 2)
    out.close()
    return states


def _moved(template: dict[str, Any], i: int, t: float) -> dict[str, Any]:
    """The template state at time t: every number a state carries moves, as a live one does."""
    wobble = 1e-4 * math.sin(0.7 * t)
    port = template["port"]
    return {
        **template,
        "seq": i + 1,
        "sim_time": t,
        "port": {**port, "position": [p + wobble for p in port["position"]]},
        "wrench": [0.5 * math.sin(t), 0.3 * math.cos(t), -2.0 + math.sin(3 * t), 0.01, 0.02, 0.03],
        "joint_positions": [q + wobble for q in template["joint_positions"]],
        "bodies": {name: [v + wobble for v in pose] for name, pose in template["bodies"].items()},
    }


PEAK_KB_DEF = (
    "def PEAK_KB():\n"
    "    status = open('/proc/self/status').read().split('VmHWM:')[1]\n"
    "    return int(status.split()[0])"
)


def measure(code: str, path: Path) -> tuple[float, float, float, str]:
    """Wall seconds, CPU seconds (what a loaded machine cannot inflate) and peak RSS [MB] of a
    fresh interpreter running `code` on `path` (as sys.argv[1]), and what it printed."""
    # VmHWM, not ru_maxrss: the latter keeps the forking parent's RSS across exec.
    report_peak = "print(PEAK_KB(), file=sys.stderr)"
    script = f"import atexit, sys\n{PEAK_KB_DEF}\natexit.register(lambda: exec({report_peak!r}))\n{code}"
    cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", script, str(path)], capture_output=True, text=True, check=False
    )
    elapsed = time.perf_counter() - started
    if done.returncode != 0:
        raise RuntimeError(f"{code!r} failed: {done.stderr.strip()}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = after.ru_utime + after.ru_stime - cpu.ru_utime - cpu.ru_stime
    peak_kb = int(done.stderr.strip().splitlines()[-1])
    return elapsed, cpu_s, peak_kb / 1024, done.stdout


REPORT = "from ptwl.cli import main\nrc = main(['report', '--json', sys.argv[1]])\nassert rc == 0"
REPLAY_INDEX = (
    "from pathlib import Path\nfrom ptwl.recording.replay.timeline import Timeline\n"
    "timeline = Timeline(Path(sys.argv[1]))\nprint(len(timeline.telemetry.values))"
)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--minutes", type=float, default=60.0)
    parser.add_argument("--file", type=Path, help="write here, or measure this file if it exists")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = args.file or Path(tmp) / "session.mcap"
        if not path.exists():
            write_session(path, args.minutes * 60)
        from ptwl.recording.reader import Scan

        scan = Scan(path, ())  # counts, decodes nothing
        for _ in scan.located():
            pass
        report_s, report_cpu_s, report_mb, text = measure(REPORT, path)
        index_s, index_cpu_s, index_mb, states = measure(REPLAY_INDEX, path)
        print(
            json.dumps(
                {
                    "minutes": args.minutes,
                    "file_mb": round(path.stat().st_size / 1e6, 1),
                    "messages": scan.count,
                    "decompressed_mb": round(scan.decompressed_bytes / 1e6, 1),
                    "trials": len(json.loads(text)),
                    "report_s": round(report_s, 2),
                    "report_cpu_s": round(report_cpu_s, 2),
                    "report_peak_rss_mb": round(report_mb, 1),
                    "replay_index_s": round(index_s, 2),
                    "replay_index_cpu_s": round(index_cpu_s, 2),
                    "replay_peak_rss_mb": round(index_mb, 1),
                    "replay_states": int(states),
                },
                indent=2,
            )
        )


if __name__ == "__main__":
    main()
