"""The OpenAPI document is the truth: Schemathesis, every check, against the robot server and
against the link at zero delay (issue 9, hole 8). Configuration: schemathesis.toml."""

import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from server.launcher import ServerProcess, running_proxy, running_server

ROOT = Path(__file__).resolve().parent.parent
MAX_EXAMPLES = 25


@pytest.fixture(scope="module")
def stack() -> Iterator[tuple[ServerProcess, ServerProcess]]:
    with running_server("--scene", "free_space") as robot, running_proxy(robot.url) as link:
        yield robot, link


def schemathesis(url: str) -> subprocess.CompletedProcess[str]:
    st = shutil.which("st", path=str(Path(sys.executable).parent)) or "st"
    return subprocess.run(
        [
            st,
            "--config-file",
            str(ROOT / "schemathesis.toml"),
            "run",
            url + "/openapi.json",
            "--checks",
            "all",
            "--phases",
            "examples,coverage,fuzzing,stateful",
            "--max-examples",
            str(MAX_EXAMPLES),
            "--seed",
            "9",
            "--no-color",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )


@pytest.mark.parametrize("through", ["robot", "link"])
def test_schemathesis_finds_nothing(stack: tuple[ServerProcess, ServerProcess], through: str) -> None:
    robot, link = stack
    result = schemathesis(robot.url if through == "robot" else link.url)
    assert result.returncode == 0, result.stdout[-6000:] + result.stderr[-2000:]
    assert "passed" in result.stdout
