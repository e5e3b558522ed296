"""Running a `ptwl` command to its end, as a user's shell would, for the tests of what it prints and
how it exits."""

import os
import subprocess
import sys

import ptwl.launcher
from tests.zygote import Zygote


def run_ptwl(
    *args: str, module: str = "ptwl.cli", timeout: float = 60.0, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """`python -m MODULE ARGS` to its end, as `subprocess.run(capture_output=True, text=True)`
    gives it: exit code, stdout and stderr apart; `env` replaces the environment, as there.

    Forked from the suite's zygote when one runs (tests/zygote.py: the imports, ~2 CPU-s a
    command, are already done); a fresh interpreter otherwise. Tests of what an interpreter does as
    it starts (its imports, its memory, numba's cache) start one themselves."""
    zygote = getattr(ptwl.launcher.SPAWN, "__self__", None)
    if isinstance(zygote, Zygote):
        return zygote.run(module, list(args), dict(os.environ) if env is None else env, timeout)
    command = [sys.executable, "-m", module, *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=env)
