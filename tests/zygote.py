"""A preloaded process that forks the suite's `ptwl` services instead of starting each one from a
fresh interpreter.

Why: a robot server spends ~2.1 CPU-s importing (numba's compiled tick, MuJoCo, FastAPI) before
it serves, a console ~3.3 CPU-s, and the suite starts a few dozen of them on a 2-core machine
where its time is its CPU. Forked from a process that imported them once, a service starts with
those imports done and runs the same `python -m MODULE ARGS` main as `ptwl.launcher` would have
run: its own argv, environment, working directory, process group and output pipe; a real
process serving through real uvicorn. Only the imports are shared, and they are the ones made
before any test ran.

What a child gets of its own is what `os.environ`, `sys.argv` and the descriptors hold; what an
interpreter reads once as it starts (PYTHON* variables, OPENBLAS_NUM_THREADS, NUMBA_*) is the
zygote's, which the suite starts with its own environment.

The protocol, over a Unix socket: a request is one JSON line (`module`, `args`, `env`, `cwd`) sent
with one file descriptor, the write end of the child's output pipe (or two: its stdout's and its
stderr's, for a command whose streams a test reads apart); the zygote answers with a
line `{"pid": N}`, then, when the child has exited, `{"returncode": C}` (negative: the signal that
ended it, as `subprocess` says) and closes the connection. A request it cannot serve closes its
connection and nothing else: the zygote lives on for the rest.

The zygote runs no Python thread of its own (a thread holding a lock at fork would leave the
child's copy of that lock held forever; OpenBLAS's threads see to their own forks), so it learns of
exits from SIGCHLD through `signal.set_wakeup_fd`. It has its own process group: a Ctrl-C in the
terminal reaches pytest, whose teardown stops each service, not the zygote under them.
"""

import atexit
import contextlib
import gc
import importlib
import json
import os
import runpy
import selectors
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback
from typing import Any

# What the services import: loaded once, here, before the zygote says it is ready.
PRELOAD = ("ptwl.cli", "ptwl.proxy_cli", "server.serve", "web.cli", "latency.serve")
MAX_REQUEST_BYTES = 1 << 20  # a request carries an environment: kilobytes, never a megabyte
REQUEST_TIMEOUT_S = 10.0  # the zygote serves one request at a time
REPLY_TIMEOUT_S = 60.0  # its pid, once the requests before this one were served


def serve(path: str) -> None:
    """Import PRELOAD, listen on `path`, fork a child per request until stdin closes."""
    gc.disable()  # no collection leaves holes in the pages the children share
    for module in PRELOAD:
        importlib.import_module(module)
    # The imports' objects into the permanent generation, which no child's collection walks: a
    # child's garbage collection then touches (and so copies) none of them, where a fresh
    # interpreter's walks all it imported (Python's `gc.freeze` advice for fork).
    gc.freeze()
    assert threading.active_count() == 1, f"a preload started a thread: {threading.enumerate()}"
    wake_r, wake_w = os.pipe()
    os.set_blocking(wake_w, False)
    signal.set_wakeup_fd(wake_w)
    signal.signal(signal.SIGCHLD, lambda *_: None)  # a handler, so the wakeup fd hears it
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(path)
    listener.listen(16)
    children: dict[int, socket.socket] = {}  # pid -> the connection that asked for it
    selector = selectors.DefaultSelector()
    selector.register(listener, selectors.EVENT_READ, "accept")
    selector.register(wake_r, selectors.EVENT_READ, "child")
    selector.register(sys.stdin, selectors.EVENT_READ, "parent")  # closed: the suite has ended
    own_fds = (wake_r, wake_w, selector.fileno())  # closed in every child
    print("ready", flush=True)
    while True:
        for key, _ in selector.select():
            if key.data == "parent":
                return
            if key.data == "accept":
                conn, _ = listener.accept()
                try:
                    pid = _fork_child(conn, [listener, *children.values()], own_fds)
                except Exception:  # one bad request (or a fork the system refused) ends only itself
                    traceback.print_exc()
                    conn.close()
                    continue
                children[pid] = conn
            else:
                os.read(wake_r, 4096)
                _reap(children)


def _fork_child(conn: socket.socket, others: list[socket.socket], fds_to_close: tuple[int, ...]) -> int:
    conn.settimeout(REQUEST_TIMEOUT_S)  # an asker that never finishes its request holds no one up
    message, fds, _, _ = socket.recv_fds(conn, MAX_REQUEST_BYTES, 2)
    try:
        while not message.endswith(b"\n"):  # a large environment comes in more than one read
            more = conn.recv(MAX_REQUEST_BYTES)
            if not more or len(message) > MAX_REQUEST_BYTES:
                raise ValueError(f"an unfinished request ({len(message)} B)")
            message += more
        if len(fds) not in (1, 2):
            raise ValueError(f"a request with {len(fds)} descriptors, not 1 or 2")
        request = json.loads(message)
        pid = os.fork()
        if pid == 0:  # never returns
            for sock in (*others, conn):
                sock.close()
            for fd in fds_to_close:  # the zygote's wakeup pipe and selector
                os.close(fd)
            _run_child(request, fds)
    finally:
        for fd in fds:  # the child's now (or nobody's: a request refused)
            os.close(fd)
    try:
        conn.sendall(json.dumps({"pid": pid}).encode() + b"\n")
    except OSError:
        os.kill(pid, signal.SIGKILL)  # the asker has gone: nobody would ever stop it
        raise
    return pid


def _name_process(name: str) -> None:
    """Name the child after its module and first argument in `ps -o comm` and /proc/PID/stat (15
    bytes at most: "ptwl.cli serve"), so a forked server, link or console can be told from the
    zygote it came from. Where there is no /proc, the child keeps the zygote's name."""
    with contextlib.suppress(OSError), open("/proc/self/comm", "wb") as comm:
        comm.write(name.encode()[:15])  # the kernel keeps 15 bytes


def _run_child(request: dict[str, Any], output_fds: list[int]) -> None:
    """(in the child) Become `python -m MODULE ARGS` as the launcher would have started it."""
    code: int = 1
    by_signal: int | None = None
    try:
        gc.enable()
        signal.set_wakeup_fd(-1)
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        os.setpgid(0, 0)  # its own process group, as the launcher's process_group=0
        devnull = os.open(os.devnull, os.O_RDONLY)
        os.dup2(devnull, 0)
        os.dup2(output_fds[0], 1)
        os.dup2(output_fds[-1], 2)  # with one descriptor, stderr joins stdout
        for fd in (devnull, *output_fds):
            os.close(fd)
        sys.stdin = open(0, closefd=False)  # noqa: SIM115 (fd 0 is the process's, for its life)
        sys.stdout.reconfigure(line_buffering=True)  # type: ignore[union-attr]
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        sys.argv = [request["module"], *request["args"]]
        _name_process(" ".join([request["module"], *request["args"][:1]]))
        # As `python -m` runs it: its code anew as __main__, not the preloaded copy (which runpy
        # would also warn about on stderr, where a fresh interpreter says nothing).
        sys.modules.pop(request["module"], None)
        runpy.run_module(request["module"], run_name="__main__", alter_sys=True)
        code = 0
    except SystemExit as stop:
        code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
        if stop.code is not None and not isinstance(stop.code, int):
            print(stop.code, file=sys.stderr)
    except KeyboardInterrupt:
        traceback.print_exc()
        by_signal = signal.SIGINT  # as an interpreter ends on an unhandled Ctrl-C: by the signal
    except BaseException:
        traceback.print_exc()
    finally:
        try:
            try:  # as an interpreter ends: its non-daemon threads joined, then its atexit handlers
                threading._shutdown()  # type: ignore[attr-defined]
                atexit._run_exitfuncs()
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                if by_signal is not None:
                    signal.signal(by_signal, signal.SIG_DFL)
                    os.kill(os.getpid(), by_signal)
        finally:
            os._exit(code & 0xFF)  # sys.exit(-1) is 255, as the kernel keeps a byte


def _reap(children: dict[int, socket.socket]) -> None:
    while children:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        conn = children.pop(pid, None)
        if conn is not None:
            with contextlib.suppress(OSError):  # the asker has gone: nobody to tell
                conn.sendall(json.dumps({"returncode": os.waitstatus_to_exitcode(status)}).encode() + b"\n")
            conn.close()


class ForkedProcess:
    """The parts of `subprocess.Popen` the launcher and the tests use, for a zygote's child."""

    def __init__(self, args: list[str], conn: socket.socket, stdout: Any) -> None:
        self.args = args
        self._conn = conn
        self._buffer = b""
        self.stdout = stdout
        self.returncode: int | None = None
        self.pid = int(self._message(REPLY_TIMEOUT_S)["pid"])

    def _message(self, timeout: float | None) -> dict[str, Any]:
        deadline = None if timeout is None else time.monotonic() + timeout
        while b"\n" not in self._buffer:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            self._conn.settimeout(left)
            try:
                chunk = self._conn.recv(4096)
            except (TimeoutError, BlockingIOError):  # (a timeout of 0 is a non-blocking read)
                raise subprocess.TimeoutExpired(self.args, timeout or 0.0) from None
            if not chunk:  # its child may live on, unwatched: say so rather than guess an exit
                raise RuntimeError(f"the zygote has gone (or refused {self.args})")
            self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        return dict(json.loads(line))

    def poll(self) -> int | None:
        try:
            return self.wait(0.0)
        except subprocess.TimeoutExpired:
            return None

    def wait(self, timeout: float | None = None) -> int:
        if self.returncode is None:
            self.returncode = int(self._message(timeout)["returncode"])
            self._conn.close()
        return self.returncode

    def send_signal(self, sig: int) -> None:
        # Not to a pid whose end was reported (it may be someone else's now); the zygote reaps its
        # children itself, so a signal sent in the instant between its reap and its report could
        # still go astray, where Popen's zombie would hold the pid: a window of microseconds.
        if self.poll() is None:
            os.kill(self.pid, sig)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


class Zygote:
    """A running zygote and the spawner that forks from it (`ptwl.launcher.SPAWN`)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tests.zygote", path],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            process_group=0,  # a terminal's Ctrl-C is pytest's to handle, not the zygote's
        )
        assert self.process.stdout is not None
        ready = self.process.stdout.readline()
        if ready.strip() != "ready":
            self.process.kill()
            raise RuntimeError(f"the zygote did not start: {ready!r}")

    def spawn(self, module: str, args: list[str], env: dict[str, str]) -> ForkedProcess:
        """`python -m MODULE ARGS` started, its stdout and stderr on one pipe (ptwl.launcher.SPAWN)."""
        out_r, out_w = os.pipe()
        conn = self._ask(module, args, env, [out_w], [out_r])
        stdout = open(out_r, encoding="utf-8", errors="replace")  # noqa: SIM115 (the process's)
        return ForkedProcess([sys.executable, "-m", module, *args], conn, stdout)

    def run(
        self, module: str, args: list[str], env: dict[str, str], timeout: float
    ) -> subprocess.CompletedProcess[str]:
        """`python -m MODULE ARGS` to its end, as `subprocess.run(..., capture_output=True,
        text=True, timeout=...)` runs it: stdout and stderr apart; killed on the timeout."""
        (out_r, out_w), (err_r, err_w) = os.pipe(), os.pipe()
        conn = self._ask(module, args, env, [out_w, err_w], [out_r, err_r])
        process = ForkedProcess([sys.executable, "-m", module, *args], conn, None)
        captured = {out_r: bytearray(), err_r: bytearray()}
        still_open = set(captured)
        deadline = time.monotonic() + timeout
        try:
            with selectors.DefaultSelector() as selector:
                for fd in still_open:
                    selector.register(fd, selectors.EVENT_READ)
                while selector.get_map():
                    ready = selector.select(max(0.0, deadline - time.monotonic()))
                    if not ready:
                        raise subprocess.TimeoutExpired(process.args, timeout)
                    for key, _ in ready:
                        chunk = os.read(key.fd, 65536)
                        captured[key.fd] += chunk
                        if not chunk:
                            selector.unregister(key.fd)
                            still_open.discard(key.fd)
                            os.close(key.fd)
            # Both streams closed, yet it may run on: waited for until the same deadline.
            code = process.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:  # as subprocess.run: killed, then the timeout raised
            process.kill()
            process.wait()
            raise
        finally:
            for fd in still_open:  # the read ends not yet at their end (a timeout, an error)
                os.close(fd)
        out, err = (bytes(captured[fd]).decode(errors="replace") for fd in (out_r, err_r))
        return subprocess.CompletedProcess(process.args, code, out, err)

    def _ask(
        self, module: str, args: list[str], env: dict[str, str], fds: list[int], read_ends: list[int]
    ) -> socket.socket:
        """Send the request with the write ends `fds` (closed here: the child holds them now);
        if it cannot be sent, the `read_ends` are closed too."""
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            conn.connect(self.path)
            request = {"module": module, "args": args, "env": env, "cwd": os.getcwd()}
            socket.send_fds(conn, [json.dumps(request).encode() + b"\n"], fds)
        except BaseException:
            conn.close()
            for fd in read_ends:
                os.close(fd)
            raise
        finally:
            for fd in fds:
                os.close(fd)
        return conn

    def close(self) -> None:
        """End the zygote (its children are each stopped by whoever started them)."""
        assert self.process.stdin is not None
        self.process.stdin.close()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:  # a process forked from the suite (a pool's worker)
            self.process.kill()  # holds the pipe open: the zygote never saw it close
            self.process.wait()


if __name__ == "__main__":
    serve(sys.argv[1])
