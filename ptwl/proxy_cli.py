"""`ptwl proxy`: the delay-line link between operator and robot, alone.

`python -m ptwl.proxy_cli proxy ...` (what the launcher starts for `ptwl up` and the tests) takes
the same arguments as `ptwl proxy` but imports only the link: none of the robot's physics, its
compiled tick or the sweeps, which `ptwl.cli` imports for its other commands. Measured on a 2-core
machine: 0.7 s of CPU to import instead of 1.6 s, on every start of a link."""

import argparse
import os
import sys
from pathlib import Path

from ptwl.cli_common import add_access_flags, run_command


def cmd_proxy(args: argparse.Namespace) -> int:
    # Imported here: only this command needs the link (aiohttp and its delay line).
    from latency.serve import ProxyConfig, serve_proxy

    serve_proxy(
        ProxyConfig(
            upstream=args.upstream,
            host=args.host,
            port=args.port,
            profile=args.profile,
            schedule=args.schedule,
            ground_node=args.ground_node,
            robot_node=args.robot_node,
            uplink=args.uplink,
            downlink=args.downlink,
            record=args.record,
            token=args.token or None,
            allow_hosts=tuple(args.allow_host),
            allow_origins=tuple(args.allow_origin),
        )
    )
    return 0


def add_proxy_parser(sub: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    proxy = sub.add_parser("proxy", help="run the delay-line link between operator and robot")
    proxy.add_argument("--upstream", default="http://127.0.0.1:8000", help="the robot server")
    proxy.add_argument("--host", default="127.0.0.1")
    proxy.add_argument("--port", type=int, default=8001, help="0 picks a free port (printed)")
    proxy.add_argument("--profile", help="a named profile from config/links.toml")
    proxy.add_argument(
        "--schedule",
        type=Path,
        metavar="FILE",
        help="contact windows, delay over time and rates: a .toml schedule, or an ION contact plan "
        "(`a contact`/`a range` lines); over the profile's own",
    )
    proxy.add_argument("--ground-node", type=int, default=1, help="an ION plan's ground node (default 1)")
    proxy.add_argument("--robot-node", type=int, default=2, help="an ION plan's robot node (default 2)")
    proxy.add_argument("--uplink", type=float, help="[s] one-way delay, operator to robot")
    proxy.add_argument("--downlink", type=float, help="[s] one-way delay, robot to operator")
    proxy.add_argument(
        "--record", type=Path, help="record each message's delay: MCAP if FILE ends in .mcap, else JSON lines"
    )
    proxy.add_argument(
        "--token", default=os.environ.get("PTWL_TOKEN"), help="needed on every route and socket (PTWL_TOKEN)"
    )
    add_access_flags(proxy)
    proxy.set_defaults(func=cmd_proxy)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="ptwl", description="the delay-line link alone")
    add_proxy_parser(parser.add_subparsers(dest="command", required=True))
    return run_command(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
