"""The telemetry feed: one background thread reading the robot's WebSocket through the link,
reconnecting by itself when the link or the robot goes away.

It keeps the console's copy of the task frames: the whole list the robot sends first, then the
changes (robot_sim.telemetry.FramesMirror). A change lost on the link (it may drop WebSocket
messages) shows as a gap in `rev`, or a state's `frames_rev` ahead of the copy: the whole list is
fetched then (GET /api/frames, on a thread of its own so states keep flowing meanwhile)."""

import threading
import time
from collections.abc import Callable
from typing import Any

from websockets.exceptions import ConnectionClosed, InvalidStatus

from robot_sim.telemetry import FramesMirror
from server.client import RobotClient
from web.errands import Errands
from web.worker import Worker

RECONNECT_S = 1.0
RECEIVE_TIMEOUT_S = 0.5  # how often a quiet feed checks whether it should stop
# [s] a closing feed waits this long for the far end to answer its WebSocket close. websockets'
# default (10 s) outlives the thread's join when the far end does not answer (shown with a peer
# that never does: tests/test_threads_owned.py); the likely cause, not confirmed, of the thread
# once found running after close() with a core hogged.
CLOSE_TIMEOUT_S = 1.0
# [s] slack on top of those waits, for a thread that is ready but not yet scheduled on a loaded
# machine. (Not covered: a close() during a reconnect's opening handshake, up to its 5 s
# open_timeout against a link that accepts and never answers; the thread is a daemon.)
SCHEDULING_SLACK_S = 1.5


class TelemetryFeed(Worker):
    def __init__(
        self,
        client: RobotClient,
        on_state: Callable[[dict[str, Any], float], None],
        on_command: Callable[[dict[str, Any]], None],
        on_link: Callable[[str], None],
        on_frames: Callable[[list[dict[str, Any]]], None],
    ) -> None:
        self._client = client
        self._on_frames = on_frames
        self._on_state = on_state
        self._on_command = on_command
        self._on_link = on_link
        # close() returns within one receive timeout and one close handshake (a reconnect's wait
        # ends at once: it waits on the closing event).
        super().__init__(
            "ptwl-telemetry", join_timeout_s=RECEIVE_TIMEOUT_S + CLOSE_TIMEOUT_S + SCHEDULING_SLACK_S
        )
        self.connected = False
        self.reconnects = 0
        self._frames = FramesMirror()
        self._frames_lock = threading.RLock()  # the reading thread and a refetch both update it
        self._refetching = False
        self.frames_refetches = 0  # whole lists fetched because a change was lost
        self.errands = Errands()

    def _run(self) -> None:
        while not self._closed.is_set():
            try:
                for message in self._client.telemetry(
                    open_timeout=5.0, idle_s=RECEIVE_TIMEOUT_S, close_timeout=CLOSE_TIMEOUT_S
                ):
                    arrived = time.time()
                    if self._closed.is_set():
                        return
                    if message["type"] == "idle":
                        continue
                    if not self.connected:
                        self.connected = True
                        self._on_link("connected")
                    if message.get("type") == "state":
                        self._on_state(message, arrived)
                        if "frames_rev" in message:  # (a file recorded before it: none)
                            self._check_frames_rev(message["frames_rev"])
                    elif message.get("type") == "command":
                        self._on_command(message)
                    elif message.get("type") == "frames":
                        self._frames_message(message)
                reason = "the robot closed the telemetry stream"
            except Exception as err:  # any failure of the link: say so in plain words, then retry
                reason = plain_reason(err)
            if self.connected:
                self.reconnects += 1
            self.connected = False
            self._on_link(f"no telemetry: {reason}; reconnecting")
            self._closed.wait(RECONNECT_S)

    # ------------------------------------------------------------ task frames
    def _frames_message(self, message: dict[str, Any]) -> None:
        # The console hears each list under the lock, so a refetch's answer and a newer change
        # cannot reach it in the wrong order.
        with self._frames_lock:
            news = self._frames.apply(message)
            if news == "changed":
                self._on_frames(self._frames.frames())
        if news == "gap":
            self._refetch_frames(message["rev"])

    def _check_frames_rev(self, rev: int) -> None:
        """A state says which frames message came last before it: behind it, one was lost."""
        with self._frames_lock:
            behind = self._frames.rev != rev
        if behind:
            self._refetch_frames(rev)

    def close(self) -> None:
        super().close()
        self.errands.close()

    def _refetch_frames(self, rev: int) -> None:
        """Fetch the whole list (GET /api/frames), one fetch at a time; a later state asks again
        if the link lost more meanwhile."""
        with self._frames_lock:
            if self._refetching:
                return
            self._refetching = True
            self.frames_refetches += 1
        if not self.errands.run("ptwl-frames-refetch", self._refetch, rev):
            with self._frames_lock:
                self._refetching = False

    def _refetch(self, rev: int) -> None:
        try:
            listed, listed_rev = self._client.frames_at_rev()
        except Exception:  # the link failed: the next state that finds the copy behind asks again
            with self._frames_lock:
                self._refetching = False
            return
        with self._frames_lock:
            # The list's own rev, so the changes after it still apply and no later state asks
            # again; a replay does not say: the list is at least as new as `rev` (asked after it).
            self._frames.replace([f.model_dump() for f in listed], rev if listed_rev is None else listed_rev)
            self._refetching = False
            if not self._closed.is_set():
                self._on_frames(self._frames.frames())


def plain_reason(err: BaseException) -> str:
    """Why the telemetry stream failed, for an operator (not a Python exception name)."""
    if isinstance(err, InvalidStatus):
        code = err.response.status_code
        if code in (401, 403):
            return f"the link or robot refused the connection ({code}): check the access token"
        return f"the link or robot answered {code} instead of opening the stream"
    if isinstance(err, ConnectionClosed):
        closed = err.rcvd.code if err.rcvd is not None else None
        if closed == 1012:
            return "the link or robot restarted"
        if closed == 1001:
            return "the link or robot is shutting down"
        return "the connection to the link dropped"
    if isinstance(err, ConnectionRefusedError):
        return "nothing is listening at the link's address (is the link running?)"
    if isinstance(err, TimeoutError):
        return "the link did not answer in time"
    if isinstance(err, OSError):
        return f"the network failed ({err.strerror or 'no detail'})"
    return f"unexpected error ({type(err).__name__})"
