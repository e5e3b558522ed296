"""What every `ptwl` entry point shares: how a command's error reaches the user, and the flags
that say who else may reach a server. Imports nothing heavier than the config layer, so an entry
point that needs only the link (ptwl/proxy_cli.py) stays light."""

import argparse
import sys

from ptwl_config import PtwlError

# A mistake the user can fix (a setting, a file, a port in use): one line and exit code 2, not a
# traceback. Every error we raise on purpose is a PtwlError; OSError and ValueError come from the
# standard library's own checks of paths, ports and numbers.
USER_ERRORS = (PtwlError, OSError, ValueError)


def run_command(args: argparse.Namespace) -> int:
    """Run the parsed command (`args.func`); a user's mistake is printed as `ptwl: ...`, code 2."""
    try:
        return int(args.func(args))
    except USER_ERRORS as err:
        print(f"ptwl: {err}", file=sys.stderr)
        return 2


def add_access_flags(parser: argparse.ArgumentParser, hosts: bool = True) -> None:
    """Who else may reach a server: the Host and Origin checks' allow-lists (ptwl/guard/access.py)."""
    if hosts:
        parser.add_argument(
            "--allow-host", action="append", default=[], metavar="NAME", help="answer to this Host name too"
        )
    parser.add_argument(
        "--allow-origin",
        action="append",
        default=[],
        metavar="URL",
        help="let browser pages from this origin in (e.g. https://ops.example:8443)",
    )
