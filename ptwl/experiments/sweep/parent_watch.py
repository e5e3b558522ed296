"""A sweep worker's watch on its sweep: the worker ends the moment the sweep's process does.

Where the kernel cannot do it (no prctl, a forkserver's child, or a sweep killed before prctl
held), a thread waits on the sweep's pidfd (or polls it). The thread is owned: `stop()` wakes
and joins it, and a worker registers that for its own exit."""

import os
import select
import threading

PARENT_POLL_S = 0.5  # the portable watch's period: how long a worker may outlive its sweep
JOIN_S = 2.0  # stop() waits this long for the thread (it wakes at once on the pipe)


class ParentWatch:
    def __init__(self, pid: int) -> None:
        self.pid = pid
        self._wake_r, self._wake_w = os.pipe()  # written by stop(): the thread returns
        self._thread = threading.Thread(target=self.wait, name="sweep-watch", daemon=True)
        self._stopped = False

    def start(self) -> "ParentWatch":
        self._thread.start()
        return self

    def stop(self) -> None:
        """Wake the thread and join it; the watch is over (this process lives on). Once."""
        if self._stopped:
            return
        self._stopped = True
        os.write(self._wake_w, b"x")
        if self._thread.is_alive():
            self._thread.join(JOIN_S)
        for fd in (self._wake_r, self._wake_w):
            os.close(fd)

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def wait(self) -> None:
        """Block until process `pid` has ended, then end this process (no cleanup: nobody reads
        it), or until stop() is called, then return."""
        pidfd = self._pidfd()
        if pidfd is not None:
            try:
                readable, _, _ = select.select([pidfd, self._wake_r], [], [])
                if pidfd in readable:
                    os._exit(1)
                return
            finally:
                os.close(pidfd)
        while not self._gone():
            readable, _, _ = select.select([self._wake_r], [], [], PARENT_POLL_S)
            if readable:
                return
        os._exit(1)

    def _pidfd(self) -> int | None:
        """A descriptor readable once `pid` ends (immune to pid reuse), or None: poll instead."""
        if not hasattr(os, "pidfd_open"):
            return None
        try:
            return os.pidfd_open(self.pid)
        except ProcessLookupError:
            os._exit(1)
        except OSError:
            return None  # an old kernel

    def _gone(self) -> bool:
        try:
            os.kill(self.pid, 0)
        except ProcessLookupError:
            return True
        except PermissionError:
            pass  # it exists (a pid reused by another user's process is not told apart here)
        return False
