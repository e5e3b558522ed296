"""The OpenAPI document is the truth: Schemathesis, every check, against the robot server and
against the link at zero delay (issue 9, hole 8). Configuration: schemathesis.toml."""

import shutil
import subprocess
import sys
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import pytest

from ptwl.launcher import ServiceProcess, running_proxy, running_server
from robot_sim.scenes import SCENES

ROOT = Path(__file__).resolve().parent.parent
MAX_EXAMPLES = 12


@pytest.fixture(scope="module")
def stack() -> Iterator[tuple[ServiceProcess, ServiceProcess]]:
    with running_server("--scene", "free_space") as robot, running_proxy(robot.url) as link:
        yield robot, link


@pytest.fixture(scope="module")
def fuzzed(
    stack: tuple[ServiceProcess, ServiceProcess],
) -> Iterator[dict[str, subprocess.CompletedProcess[str]]]:
    """Both runs at once, each against its own robot (the link's is `stack`'s; the direct one a
    second server), so neither sees the other's commands: ~13 s instead of ~23 s one after the
    other."""
    with running_server("--scene", "free_space") as direct, ThreadPoolExecutor(max_workers=2) as pool:
        runs = {
            "robot": pool.submit(schemathesis, direct.url),
            "link": pool.submit(schemathesis, stack[1].url),
        }
        yield {through: run.result() for through, run in runs.items()}


def schemathesis(
    url: str,
    phases: str = "examples,coverage,fuzzing,stateful",
    max_examples: int = MAX_EXAMPLES,
    operations: tuple[str, ...] = (),
) -> subprocess.CompletedProcess[str]:
    st = shutil.which("st", path=str(Path(sys.executable).parent)) or "st"
    only = [arg for name in operations for arg in ("--include-name", name)]
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
            phases,
            "--max-examples",
            str(max_examples),
            "--seed",
            "9",
            "--no-color",
            *only,
        ],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )


@pytest.mark.parametrize("through", ["robot", "link"])
def test_schemathesis_finds_nothing(
    fuzzed: dict[str, subprocess.CompletedProcess[str]], through: str
) -> None:
    result = fuzzed[through]
    assert result.returncode == 0, result.stdout[-6000:] + result.stderr[-2000:]
    assert "passed" in result.stdout


# The OpenAPI links (server/models.py) that lead from a new task frame to a PTWL with its gains
# in it, then to the command's status and the state. A fresh robot, and only these operations:
# in the full run the queue is full of long fuzzed commands, so the PTWL never started and the
# stateful phase never saw its gains (with ActiveGainsModel.frame back to base/tool, 4 seeds of
# 4 found the 500 here, none in the full run).
GAINS_FRAME_PATH = (
    "POST /api/frames",
    "POST /api/commands",
    "GET /api/commands/{command_id}",
    "GET /api/state",
)


def test_stateful_state_after_gains_in_a_task_frame() -> None:
    """Issue 26: GET /api/state answered 500 once a PTWL with `gains_frame` naming a task frame
    had started: two requests, so the one-request phases could not find it."""
    with running_server("--scene", "free_space") as robot:
        result = schemathesis(robot.url, "stateful", 20, GAINS_FRAME_PATH)
        assert result.returncode == 0, result.stdout[-6000:] + result.stderr[-2000:]
        commands = httpx.get(robot.url + "/api/commands", params={"limit": 1000}).json()
    in_frames = [
        c
        for c in commands
        if c["params"].get("gains_frame") not in (None, "base", "tool") and c["started_at"] is not None
    ]
    assert in_frames, "the stateful phase never ran a PTWL with gains in a task frame"


def test_the_document_says_what_main_left_out(stack: tuple[ServiceProcess, ServiceProcess]) -> None:
    """Main documented 422 as an array, made `type` optional, had no scene enum, left 400, 401,
    403, 404, 413, 429 and 503 out and sent 429 with no Retry-After."""
    document = httpx.get(stack[0].url + "/openapi.json").json()
    schemas = document["components"]["schemas"]
    assert schemas["ValidationErrorModel"]["properties"]["detail"]["type"] == "string"
    for behavior in ("PtwlParams", "RweParams", "DitherParams", "StateMachineParams"):
        assert "type" in schemas[behavior]["required"], behavior
    assert schemas["SceneRequest"]["properties"]["name"]["enum"] == list(SCENES)
    seed = schemas["SceneRequest"]["properties"]["seed"]["anyOf"][0]  # JSON Schema's words, not pydantic's
    assert seed["minimum"] == 0 and seed["maximum"] == 2**32 - 1 and "ge" not in seed
    assert schemas["PtwlParams"]["properties"]["force_threshold"]["maximum"] == 500.0
    post = document["paths"]["/api/commands"]["post"]["responses"]
    assert {"202", "400", "401", "403", "413", "422", "429"} <= set(post)
    assert "Retry-After" in post["429"]["headers"]
    assert "404" in document["paths"]["/api/commands/{command_id}"]["get"]["responses"]
    assert "503" in document["paths"]["/api/stop"]["post"]["responses"]
