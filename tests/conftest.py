"""Shared fixtures: robot servers as real subprocesses."""

from collections.abc import Iterator

import pytest

from server.client import RobotClient
from server.launcher import ServerProcess, running_server


@pytest.fixture(scope="module")
def server() -> Iterator[ServerProcess]:
    with running_server("--scene", "free_space", "--fault-injection") as srv:
        yield srv


@pytest.fixture
def robot(server: ServerProcess) -> Iterator[RobotClient]:
    """A client on a server reset to free_space with nothing queued."""
    with RobotClient(server.url) as client:
        client.reset_scene("free_space")
        yield client
