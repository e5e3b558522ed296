"""The suite's services are forked from a preloaded process (tests/zygote.py): each child must
start as `python -m MODULE ARGS` from the launcher would, and end as it would be seen to."""

import json
import os
import signal
import socket
import subprocess

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
