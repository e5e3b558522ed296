"""The Ray backend on a real two-node cluster (issue 30 point 4): a head and a second node, each
its own `ray start` on this machine, token-authenticated as Ray 2.60 documents (RAY_AUTH_MODE=
token, the same RAY_AUTH_TOKEN on every node and in the driver). Asked for 127.0.0.1, `ray start`
advertises the machine's own address instead (it turns a loopback address into one others can
reach). The rows are the process pool's, byte for byte, and the trials are shared between the
nodes; a driver with another token is refused."""

import contextlib
import importlib.util
import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from ptwl.launcher import free_port
from tests.test_sweep_outputs import SMALL, reference

__all__ = ["reference"]  # the process pool's rows, as test_sweep_outputs.py makes them

# The small grid of test_sweep_outputs.py, on the command line.
SMALL_ARGS = [
    "--task",
    SMALL["task"],
    "--rtt",
    ",".join(str(r) for r in SMALL["rtts_s"]),
    "--trials",
    str(SMALL["trials"]),
    "--operator",
    ",".join(SMALL["operators"]),
    "--think",
    "1.0",
]
NODE_START_S = 90.0  # two `ray start`s on a busy 2-core machine: ~10-30 s each measured


def ray_start(args: list[str], env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    """`ray start --block` in its own process group: stopping it stops that node's processes
    only (`ray stop` would stop every Ray node on the machine)."""
    ray_cli = Path(sys.executable).with_name("ray")
    common = [
        "--block",
        "--node-ip-address=127.0.0.1",
        "--num-cpus=1",
        "--disable-usage-stats",
        "--object-store-memory=100000000",
    ]
    with log.open("wb") as out:
        return subprocess.Popen(
            [str(ray_cli), "start", *args, *common],
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )


ALIVE_NODES = (
    "import ray, sys; ray.init(address=sys.argv[1], log_to_driver=False); "
    "print(sum(1 for n in ray.nodes() if n['Alive']))"
)


def ask_nodes(address: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    """Asked in a process of its own: Ray reads the token once a process has used it, and this
    one may have run a local Ray cluster (with its own token) in another test."""
    return subprocess.run(
        [sys.executable, "-c", ALIVE_NODES, address], env=env, capture_output=True, text=True, timeout=60
    )


def alive_nodes(address: str, env: dict[str, str]) -> int:
    done = ask_nodes(address, env)
    return int(done.stdout.strip().splitlines()[-1]) if done.returncode == 0 and done.stdout.strip() else 0


@pytest.fixture
def two_nodes(tmp_path: Path) -> Iterator[tuple[str, dict[str, str]]]:
    """The cluster's address, and the environment that holds its token (a driver needs it)."""
    if importlib.util.find_spec("ray") is None:
        pytest.skip("the ray extra is not installed")
    token = secrets.token_hex(32)
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token}
    env.pop("RAY_ADDRESS", None)
    port = free_port()
    address = f"127.0.0.1:{port}"
    # Its own temporary directory (short: Ray's Unix sockets live there), so that the address file
    # `ray start` writes is not the machine's: a later ray.init() would try to join this cluster.
    temp_dir = tempfile.mkdtemp(prefix="ray-", dir="/tmp")
    head = ["--head", f"--port={port}", "--include-dashboard=false", f"--temp-dir={temp_dir}"]
    nodes = [ray_start(head, env, tmp_path / "head.log")]
    try:
        nodes.append(ray_start([f"--address={address}"], env, tmp_path / "second.log"))
        deadline = time.monotonic() + NODE_START_S
        while alive_nodes(address, env) < 2:
            exited = [node.args for node in nodes if node.poll() is not None]
            assert not exited, f"a node exited: {exited}; {(tmp_path / 'head.log').read_text()[-2000:]}"
            assert time.monotonic() < deadline, (tmp_path / "head.log").read_text()[-2000:]
            time.sleep(1.0)
        yield address, env
    finally:
        for node in nodes:  # SIGINT: `ray start --block` stops its node's processes (SIGTERM did not)
            with contextlib.suppress(ProcessLookupError):
                os.killpg(node.pid, signal.SIGINT)
        for node in nodes:
            with contextlib.suppress(subprocess.TimeoutExpired):
                node.wait(timeout=30)
            with contextlib.suppress(ProcessLookupError):  # whatever of the node outlived its CLI
                os.killpg(node.pid, signal.SIGKILL)
            node.wait()
        shutil.rmtree(temp_dir, ignore_errors=True)


def test_two_nodes_run_the_same_trials_to_the_same_bytes(
    two_nodes: tuple[str, dict[str, str]], reference: Path, tmp_path: Path
) -> None:
    address, env = two_nodes
    out = tmp_path / "out"
    sweep = [sys.executable, "-m", "ptwl.cli", "sweep", *SMALL_ARGS, "--workers", "2", "--out", str(out)]
    done = subprocess.run(
        [*sweep, "--backend", "ray", "--ray-address", address],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert (out / "trials.csv").read_bytes() == (reference / "trials.csv").read_bytes()
    by_node = json.loads((out / "sweep.json").read_text())["trials_by_node_this_run"]
    assert len(by_node) == 2 and all(count >= 1 for count in by_node.values()), by_node
    assert sum(by_node.values()) == 8
    last = [line for line in done.stderr.splitlines() if line.startswith("sweep: ")][-1]
    assert last.startswith("sweep: 8/8 trials")
    assert all(f"node {name}: {count}" in last for name, count in by_node.items()), last
    wrong = {**env, "RAY_AUTH_TOKEN": secrets.token_hex(32)}  # a driver without the cluster's token
    refused = ask_nodes(address, wrong)
    assert refused.returncode != 0 and "InvalidAuthToken" in refused.stderr, refused.stderr[-2000:]
