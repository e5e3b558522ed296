"""The `ptwl` command line.

    ptwl up [--scene NAME] [--rtt S | --profile NAME] [--schedule FILE]    robot, link and console
    ptwl serve | ptwl proxy | ptwl console               each of those alone
    ptwl sim [--scene NAME] [--demo] [--seconds S]        the robot alone, headless, real time
    ptwl scenes | ptwl presets                            what exists
    ptwl task list | run TASK | bench TASK                the tasks' onboard state machines

`ptwl sim --demo` drives the paper's sleeve-on-peg sequence (a 3 degree tilt, then the task's
state machine: PTWL jams, RWE, a dither backs out, a PTWL turns the approach, PTWL again, until
inserted) and prints one status line a second.
"""

import argparse
import json
import os
import signal
import sys
from collections.abc import Generator
from pathlib import Path

from ptwl.cli_common import add_access_flags, run_command
from ptwl.proxy_cli import add_proxy_parser
from ptwl.recording_cli import add_recording_parsers
from ptwl.sweep_cli import add_sweep_parser
from ptwl.task_cli import add_task_parser
from robot_sim.behaviors import Behavior, BehaviorReport, behavior_for
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.params import PtwlParams
from robot_sim.policies import Machine, Step
from robot_sim.policies.sleeve_on_peg import SleeveOnPeg
from robot_sim.presets import default_presets
from robot_sim.scenes import SCENES
from robot_sim.sim import Simulation
from robot_sim.warm import warm_up
from server.config import MAX_SENT_AT_SKEW_S, SENT_AT_SKEW_S, ConfigError
from server.pacing import RealTimePacer

DEMO_TILT_RAD = 0.052  # 3 degrees about the tool x axis: enough to jam the 0.089 mm fit


Strategy = Generator[Behavior, BehaviorReport, None]  # the next behavior, sent how the last ended


def demo_sequence(sim: Simulation) -> Strategy:
    """Paper 2.3.5 on `sleeve_on_peg`: a tilt jams plain PTWL; the state machine backs out and
    re-aims ("retract and attempt to reinsert with a new alignment") until it is in."""
    yield Ptwl(
        PtwlParams(
            rotation=[DEMO_TILT_RAD, 0.0, 0.0], duration=1.0, preset="medium", orientation_tolerance=1e-3
        )
    )
    machine = Machine(SleeveOnPeg())
    step: Step | None = machine.start(sim.state().port)
    while step is not None:
        step = machine.advance((yield behavior_for(step.params)))


def status_line(sim: Simulation) -> str:
    state = sim.state()
    task = sim.task()
    x, y, z = state.port.position
    fx, fy, fz = state.wrench[0:3]
    running = state.behavior or "idle"
    return (
        f"t={state.sim_time:7.2f} s  port=({x:+.4f}, {y:+.4f}, {z:+.4f}) m  "
        f"f=({fx:+6.2f}, {fy:+6.2f}, {fz:+6.2f}) N  {running:7s}  "
        f"task: {task.progress:+.4f} {task.unit} ({'done' if task.success else 'not yet'})"
    )


def report_line(report: BehaviorReport) -> str:
    return (
        f"  -> {report.behavior} ended {report.exit.value} after {report.duration:.2f} s "
        f"(peak {report.peak_force:.1f} N, {report.peak_torque:.2f} N m)"
        + (f" {report.detail}" if report.detail else "")
    )


def _stop_on_sigterm(signum: int, frame: object) -> None:
    raise KeyboardInterrupt  # same clean stop as Ctrl-C


def cmd_up(args: argparse.Namespace) -> int:
    from latency.plan_file import read_schedule
    from ptwl.recording.paths import check_record_path
    from ptwl.up import link_record, up

    if args.rtt < 0:
        raise ConfigError(f"--rtt must be >= 0 s, got {args.rtt:g}")
    link_args = (
        ["--profile", args.profile]
        if args.profile
        else ["--uplink", f"{args.rtt / 2}", "--downlink", f"{args.rtt / 2}"]
    )
    if args.schedule is not None:
        read_schedule(args.schedule)  # refused here, naming the file and line, before anything starts
        link_args += ["--schedule", str(args.schedule.resolve())]
    if args.record is not None:
        check_record_path(args.record)
        check_record_path(link_record(args.record))
    warm_up()  # compiled once here, into the cache the robot and the console then load
    return up(args.scene, link_args, args.server_port, args.proxy_port, args.console_port, args.record)


def cmd_console(args: argparse.Namespace) -> int:
    # Imported here: only this command needs viser.
    from ptwl.guard.access import is_loopback
    from web.cli import run_console

    if not is_loopback(args.host):
        # viser has no login: anyone who reaches the page could drive the robot.
        raise ConfigError(
            f"refusing to bind {args.host}: the console has no login of its own; keep it on 127.0.0.1 "
            "and reach it through an SSH tunnel (ssh -L 8080:127.0.0.1:8080 host)"
        )
    run_console(args.robot, args.host, args.port, args.token or None, tuple(args.allow_origin), args.replay)
    return 0


def cmd_sim(args: argparse.Namespace) -> int:
    signal.signal(signal.SIGTERM, _stop_on_sigterm)
    scene = args.scene or ("sleeve_on_peg" if args.demo else "surface")
    sim = Simulation(scene, seed=args.seed)
    pacer = RealTimePacer(sim)
    pending: Strategy | None = demo_sequence(sim) if args.demo else None
    reports: list[BehaviorReport] = []

    def on_report(report: BehaviorReport) -> None:
        reports.append(report)
        print(report_line(report), flush=True)

    print(f"ptwl: robot up on scene {scene!r} (real time, Ctrl-C to stop)", flush=True)
    next_status = 0.0
    try:
        while args.seconds is None or sim.time < args.seconds:
            if sim.behavior is None and pending is not None:
                try:
                    behavior = pending.send(reports[-1]) if reports else next(pending)
                except StopIteration:
                    pending = None
                else:
                    print(f"  <- {behavior.kind}", flush=True)
                    sim.start(behavior)
            pacer.advance(on_report=on_report)
            if sim.time >= next_status:
                print(status_line(sim), flush=True)
                next_status += 1.0
    except KeyboardInterrupt:
        print("\nptwl: stopped", flush=True)
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    from server.config import ServerConfig, default_data_dir
    from server.serve import serve

    config = ServerConfig(
        host=args.host,
        port=args.port,
        scene=args.scene,
        seed=args.seed,
        telemetry_hz=args.telemetry_hz,
        token=args.token or None,
        fault_injection=args.fault_injection,
        allow_hosts=tuple(args.allow_host),
        allow_origins=tuple(args.allow_origin),
        record=args.record,
        data_dir=args.data_dir or default_data_dir(),
        sent_at_skew_s=args.sent_at_skew,
    )
    serve(config)
    return 0


def cmd_scenes(_: argparse.Namespace) -> int:
    for name, scene in SCENES.items():
        print(f"{name:15s} {scene.description}")
    return 0


def cmd_presets(_: argparse.Namespace) -> int:
    presets = default_presets()
    out = {
        "stiffness": {name: spec.model_dump() for name, spec in presets.stiffness.items()},
        "dither": {name: p.model_dump(exclude={"type", "preset"}) for name, p in presets.dither.items()},
    }
    print(json.dumps(out, indent=2))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="ptwl", description="PTWL supervisory control console")
    sub = parser.add_subparsers(dest="command", required=True)
    up = sub.add_parser("up", help="robot server, link and console on 127.0.0.1; prints the console URL")
    up.add_argument("--scene", choices=list(SCENES), default="surface")
    link = up.add_mutually_exclusive_group()
    link.add_argument("--rtt", type=float, default=0.0, help="[s] round trip, split evenly (default 0)")
    link.add_argument("--profile", help="a named link profile from config/links.toml")
    up.add_argument(
        "--schedule",
        type=Path,
        metavar="FILE",
        help="the link's contact windows, delay over time and rates (a .toml schedule or an ION plan)",
    )
    up.add_argument("--server-port", type=int, default=8000)
    up.add_argument("--proxy-port", type=int, default=8001)
    up.add_argument("--console-port", type=int, default=8080)
    up.add_argument(
        "--record",
        type=Path,
        metavar="FILE.mcap",
        help="record the robot's session (and the link's to FILE.link.mcap)",
    )
    up.set_defaults(func=cmd_up)
    sim = sub.add_parser("sim", help="the robot alone, headless, in real time, printing its status")
    sim.add_argument("--scene", choices=list(SCENES), help="default: surface (sleeve_on_peg with --demo)")
    sim.add_argument("--seed", type=int, default=None, help="jitter the fixture (default: nominal)")
    sim.add_argument("--demo", action="store_true", help="run the paper's sleeve-on-peg sequence")
    sim.add_argument("--seconds", type=float, default=None, help="stop after this much sim time")
    sim.set_defaults(func=cmd_sim)
    console = sub.add_parser("console", help="the operator console (viser) for a robot or link URL")
    console.add_argument("--robot", default="http://127.0.0.1:8001", help="the link proxy (or robot server)")
    console.add_argument(
        "--host", default="127.0.0.1", help="where browsers connect (non-loopback needs --token)"
    )
    console.add_argument("--port", type=int, default=8080)
    console.add_argument("--token", default=os.environ.get("PTWL_TOKEN"), help="the robot's access token")
    console.add_argument("--replay", action="store_true", help=argparse.SUPPRESS)  # started by `ptwl replay`
    add_access_flags(console, hosts=False)
    console.set_defaults(func=cmd_console)
    serve = sub.add_parser("serve", help="run the robot server (REST + WebSocket telemetry)")
    serve.add_argument("--host", default="127.0.0.1", help="bind address (non-loopback needs --token)")
    serve.add_argument("--port", type=int, default=8000, help="0 picks a free port (printed)")
    serve.add_argument("--scene", choices=list(SCENES), default="surface")
    serve.add_argument("--seed", type=int, default=None)
    serve.add_argument("--telemetry-hz", type=float, default=50.0, help="state messages per second")
    serve.add_argument("--token", default=os.environ.get("PTWL_TOKEN"), help="access token (or PTWL_TOKEN)")
    serve.add_argument(
        "--record", type=Path, metavar="FILE.mcap", help="record the session to this new MCAP file"
    )
    serve.add_argument(
        "--data-dir", type=Path, help="kept across runs (command ids); default $XDG_STATE_HOME/ptwl"
    )
    serve.add_argument(
        "--sent-at-skew",
        type=float,
        default=SENT_AT_SKEW_S,
        metavar="S",
        help=f"[s] refuse commands whose sent_at leads the robot's clock by more (0-{MAX_SENT_AT_SKEW_S:g})",
    )
    serve.add_argument("--fault-injection", action="store_true", help=argparse.SUPPRESS)
    add_access_flags(serve)
    serve.set_defaults(func=cmd_serve)
    add_proxy_parser(sub)
    add_task_parser(sub)
    add_sweep_parser(sub)
    add_recording_parsers(sub)
    sub.add_parser("scenes", help="list scenes").set_defaults(func=cmd_scenes)
    sub.add_parser("presets", help="print stiffness and dither presets").set_defaults(func=cmd_presets)
    return parser


def main(argv: list[str] | None = None) -> int:
    return run_command(build_parser().parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
