"""Every route that reads the simulation does so on its thread (issue 28): POST /api/commands
checked the scene, the task frames and the gains on the event loop while the simulation thread
changed them."""

import threading
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

import server.routes.commands as command_routes
from server.app import create_app
from server.config import ServerConfig
from tests.helpers import threads_started_since


def test_a_command_is_checked_and_queued_on_the_simulation_thread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    app = create_app(ServerConfig(scene="surface", data_dir=tmp_path, allow_hosts=("testserver",)))
    seen: list[str] = []
    warn = command_routes.ptwl_warnings

    def ptwl_warnings(*args: Any) -> list[str]:
        seen.append("warnings on " + threading.current_thread().name)
        return warn(*args)

    monkeypatch.setattr(command_routes, "ptwl_warnings", ptwl_warnings)
    with TestClient(app) as client:
        frames = app.state.runner.sim.frames
        unknown = frames.unknown_errors

        def unknown_errors(params: Any) -> list[Any]:
            seen.append("frames on " + threading.current_thread().name)
            return unknown(params)

        monkeypatch.setattr(frames, "unknown_errors", unknown_errors)
        answer = client.post("/api/commands", json={"type": "ptwl", "translation": [0, 0, 0.001]})
        assert answer.status_code == 202, answer.text
        refused = client.post("/api/commands", json={"type": "ptwl", "frame": "nowhere"})
        assert refused.status_code == 422 and "nowhere" in refused.text
        assert seen == ["frames on ptwl-sim", "warnings on ptwl-sim", "frames on ptwl-sim"]
        assert app.state.book.queued_count() <= 1  # the refused one was never queued


def test_the_server_in_process_leaves_no_thread_behind(tmp_path: Path) -> None:
    """Its simulation thread (and the recording's, when recording) stop and join with the app."""
    before = set(threading.enumerate())
    record = tmp_path / "session.mcap"
    app = create_app(
        ServerConfig(scene="surface", data_dir=tmp_path, allow_hosts=("testserver",), record=record)
    )
    with TestClient(app) as client:
        assert client.post("/api/commands", json={"type": "rwe", "duration": 0.1}).status_code == 202
        names = {thread.name for thread in threading.enumerate()}
        assert {"ptwl-sim", "ptwl-record"} <= names
    assert threads_started_since(before) == []
