"""The suite's services are forked from a preloaded process (tests/zygote.py): each child must
start as `python -m MODULE ARGS` from the launcher would, and end as it would be seen to."""

import json
import os
import signal
import socket
import subprocess
import sys

import pytest

from tests.zygote import Zygote


@pytest.fixture
def zygote(forked_services: Zygote | None) -> Zygote:
    if forked_services is None:
        pytest.skip("PTWL_TEST_FORK=0: services start as fresh interpreters")
    return forked_services


def started(zygote: Zygote, *args: str) -> tuple[object, dict[str, object]]:
    child = zygote.spawn("tests.zygote_probe", list(args), {**os.environ, "ZYGOTE_PROBE": "yes"})
    assert child.stdout is not None
    return child, json.loads(child.stdout.readline())


def test_a_child_gets_its_own_argv_environment_directory_group_and_input(zygote: Zygote) -> None:
    child, said = started(zygote, "3", "extra")
    assert said == {
        "argv": ["3", "extra"],
        "cwd": os.getcwd(),
        "probe_env": "yes",  # the asker's environment, not the zygote's
        "leader": True,  # its own process group, as the launcher's process_group=0
        "stdin_closed": True,
        # Its module in `ps -o comm` (15 bytes), not the zygote's name: Linux names it; elsewhere
        # there is no /proc to read it from.
        "comm": "tests.zygote_pr" if sys.platform.startswith("linux") else None,
    }
    assert child.stdout is not None
    assert child.stdout.readline() == "to stderr\n"  # stderr joins stdout, as the launcher's pipe
    assert child.wait(timeout=10) == 3  # its exit code
    assert child.poll() == 3


def test_a_child_ended_by_a_signal_says_which_and_a_handled_one_exits_as_handled(zygote: Zygote) -> None:
    killed, _ = started(zygote, "wait")
    assert killed.poll() is None
    with pytest.raises(subprocess.TimeoutExpired):
        killed.wait(timeout=0.2)
    killed.kill()
    assert killed.wait(timeout=10) == -signal.SIGKILL
    killed.kill()  # after its end, a signal goes nowhere (its pid may be someone else's)
    handled, _ = started(zygote, "wait")
    handled.send_signal(signal.SIGTERM)
    assert handled.wait(timeout=10) == 7


def test_an_unhandled_ctrl_c_ends_the_child_by_the_signal_as_an_interpreter_would(zygote: Zygote) -> None:
    child, _ = started(zygote, "interrupted")
    assert child.wait(timeout=10) == -signal.SIGINT
    negative, _ = started(zygote, "-1")
    assert negative.wait(timeout=10) == 255  # sys.exit(-1): the low byte, not a signal


def test_a_request_it_cannot_serve_ends_only_that_request(zygote: Zygote) -> None:
    for bad in (b"not json\n", b'{"module": "tests.zygote_probe"}\n'):  # unparsable; no descriptor
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as asker:
            asker.connect(zygote.path)
            asker.sendall(bad)
            asker.settimeout(20)
            assert asker.recv(100) == b""  # closed, nothing forked
    child, said = started(zygote, "0")  # and the zygote serves the next one
    assert said["probe_env"] == "yes" and child.wait(timeout=10) == 0


def test_a_command_run_to_its_end_keeps_stdout_and_stderr_apart_and_a_timeout_kills_it(
    zygote: Zygote,
) -> None:
    """`run` is `subprocess.run(capture_output=True, text=True)` (tests/command_line.py)."""
    done = zygote.run("tests.zygote_probe", ["5"], {**os.environ, "ZYGOTE_PROBE": "run"}, timeout=30)
    assert done.returncode == 5 and done.stderr == "to stderr\n"
    said = json.loads(done.stdout)  # one line: stderr's is not in it
    assert said["probe_env"] == "run" and said["argv"] == ["5"]
    for still_running in ("wait", "silent"):  # its output open; closed, yet running on
        with pytest.raises(subprocess.TimeoutExpired):
            zygote.run("tests.zygote_probe", [still_running], dict(os.environ), timeout=1.0)
    # A preloaded module runs anew as __main__, as `python -m` runs it: nothing on stderr (runpy
    # warns when it runs a module already imported).
    usage = zygote.run("ptwl.cli", ["--help"], dict(os.environ), timeout=30)
    assert usage.returncode == 0 and usage.stdout.startswith("usage: ptwl") and usage.stderr == ""
