"""Lifecycle: real-time pacing, clean shutdown that frees the port, faults that do not kill it."""

import signal
import socket
import time

import httpx
import pytest

from ptwl.launcher import ServiceProcess, running_server
from server.client import RobotClient


def test_the_server_paces_its_simulation_to_the_wall_clock(server: ServiceProcess) -> None:
    """Never ahead of the wall clock (unpaced, this contact scene runs several times faster),
    and on a machine busy enough to hold it back, still moving. The pacing rule itself is
    tested on a fake clock (test_cli_and_pacing.py); the real-time factor on a quiet machine,
    1.000 within 2 % over 10 s, is bench.server's `sim_rtf_while_serving`."""
    with RobotClient(server.url) as robot:
        robot.reset_scene("surface")
        robot.ptwl(translation=[0.0, 0.0, 0.0486], duration=2.0, force_threshold=100.0, watchdog=60.0)
        t0, sim0 = time.monotonic(), robot.health().sim_time
        time.sleep(2.0)
        t1, sim1 = time.monotonic(), robot.health().sim_time
        robot.stop()
    # Health reads the latest telemetry state: up to one 20 ms period behind at either end.
    assert 0.5 < (sim1 - sim0) / (t1 - t0) < 1.0 + 0.04 / (t1 - t0) + 0.01


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_clean_shutdown_frees_the_port(sig: int) -> None:
    with running_server("--scene", "free_space") as srv:
        port = srv.port
        assert srv.stop(sig) == 0
        assert "ptwl serve: stopped" in "".join(srv.output)
    probe = socket.socket()
    try:
        probe.bind(("127.0.0.1", port))  # free again
    finally:
        probe.close()
    with pytest.raises(httpx.TransportError):
        httpx.get(f"http://127.0.0.1:{port}/api/health", timeout=1.0)


def test_a_simulation_fault_ends_the_command_fault_and_the_server_keeps_serving(
    server: ServiceProcess,
) -> None:
    with RobotClient(server.url) as robot:
        robot.reset_scene("free_space")
        faults_before = robot.health().faults
        cmd = robot.ptwl(translation=[0.05, 0.0, 0.0], duration=5.0)
        time.sleep(0.3)
        httpx.post(server.url + "/api/_debug/fault").raise_for_status()
        status = robot.wait(cmd.id, timeout=5.0)
        assert status.exit == "fault"
        assert "unstable" in status.detail
        # Health and state read the latest telemetry state, at most a period behind the event
        # (the event leaves mid-step; a loaded machine can hold the thread off a while longer).
        deadline = time.monotonic() + 2.0
        while (health := robot.health()).faults == faults_before and time.monotonic() < deadline:
            time.sleep(0.01)
        assert health.faults == faults_before + 1 and health.last_fault and "BADQVEL" in health.last_fault
        state = robot.state()
        assert state.faults == faults_before + 1
        assert state.joint_positions == pytest.approx([0.0, 0.3, 0.2, 0.0, 1.0708, 0.0], abs=0.01)  # home
        assert (
            robot.run("ptwl", translation=[0.0, 0.0, -0.01], duration=0.3, timeout=10).exit == "goal_reached"
        )


def test_a_request_wakes_the_simulation_thread_instead_of_waiting_out_its_batch(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The sim thread sleeps between batches until the wall clock catches up; a request (a
    command, a STOP) and close() cut that sleep short. With a 4 s batch the difference is plain
    on any machine: answered in well under a second, not at the batch's end."""
    import server.runner as runner_module
    from server.commands import CommandBook

    monkeypatch.setattr(runner_module, "BATCH_S", 4.0)
    runner = runner_module.SimRunner("free_space", 0, 0.2, CommandBook(64, 100), lambda text: None)
    runner.start()
    try:
        time.sleep(0.3)  # inside the first sleep: the first 4 s of sim time ran at once
        for _ in range(3):
            asked = time.monotonic()
            sim_time = runner.call(lambda: runner.sim.time).result(timeout=10.0)
            assert time.monotonic() - asked < 1.0
            assert sim_time == pytest.approx(4.0, abs=1e-9)  # served between batches, none run early
    finally:
        asked = time.monotonic()
        runner.close()
        assert time.monotonic() - asked < 1.0 and not runner._thread.is_alive()
