"""Where trials run: a local process pool (default) or Ray tasks. Each trial is a pure function
of its settings (trial.run_trial), so both give the same rows; they come back as they end, each
with the name of the node that ran it (`local` for the process pool; a Ray node's id, short)."""

import ctypes
import ctypes.util
import importlib.util
import multiprocessing.util
import os
import signal
import sys
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from ptwl_config import PtwlError

from ptwl.experiments.sweep.parent_watch import ParentWatch
from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import run_trial
from robot_sim.warm import warm_up

PR_SET_PDEATHSIG = 1  # linux/prctl.h
LOCAL = "local"
NODE_ID_CHARS = 8  # a Ray node id (56 hex digits) as progress and sweep.json name it
Finished = tuple[dict[str, Any], str]  # a trial's row, and the node that ran it


def _worker_init(sweep_pid: int) -> None:
    """Each pool worker: Ctrl-C is left to the sweep (it stops handing out trials and keeps the
    rows), and the worker dies with the sweep. A sweep killed outright (kill -9, the OOM killer)
    runs no cleanup, and its workers, blocked reading a queue whose other ends they hold
    themselves, lived on under init, each a core busy on a trial nobody will read."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if not _kill_me_with_parent() or os.getppid() != sweep_pid:
        # No prctl (not Linux), or the parent is not the sweep (a forkserver's child), or the
        # sweep died before prctl took hold (the parent is already init): watch the sweep itself.
        # Stopped and joined as the worker exits (multiprocessing runs its finalizers then).
        watch = ParentWatch(sweep_pid).start()
        multiprocessing.util.Finalize(None, watch.stop, exitpriority=10)


def _kill_me_with_parent() -> bool:
    """Linux: SIGKILL from the kernel the moment the parent process dies; False elsewhere."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
        return bool(libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0)
    except (OSError, AttributeError):
        return False


def run_local(specs: list[TrialSpec], workers: int, record_dir: str | None = None) -> Iterator[Finished]:
    if not specs:
        return
    warm_up()  # compiled here once, into the cache every worker then loads (robot_sim/warm.py)
    with ProcessPoolExecutor(max_workers=workers, initializer=_worker_init, initargs=(os.getpid(),)) as pool:
        futures = [pool.submit(run_trial, spec, record_dir) for spec in specs]
        try:
            for future in as_completed(futures):
                yield future.result(), LOCAL
        finally:
            pool.shutdown(wait=True, cancel_futures=True)  # Ctrl-C: the running ones finish


def _trial_on_node(spec: TrialSpec, record_dir: str | None) -> Finished:
    """A Ray task: the trial, and the node it ran on."""
    import ray

    return run_trial(spec, record_dir), ray.get_runtime_context().get_node_id()[:NODE_ID_CHARS]


def run_ray(
    specs: list[TrialSpec], workers: int, address: str | None, record_dir: str | None = None
) -> Iterator[Finished]:
    """On the cluster at `address` (or RAY_ADDRESS), else a local one on loopback with `workers`
    CPUs. A remote cluster's nodes need this package installed (`pip install -e ".[ray]"`) and
    the cluster's token (RAY_AUTH_MODE=token and RAY_AUTH_TOKEN, the same on every node and
    here), and recordings land on the disk of the node that ran the trial."""
    import ray  # the optional extra: available() said so before the sweep began

    address = address or os.environ.get("RAY_ADDRESS") or None
    started = not ray.is_initialized()
    if started:
        if address is None:
            ray.init(  # "local": a cluster of its own, never one a `ray start` left its address of
                address="local",
                num_cpus=workers,
                include_dashboard=False,
                _node_ip_address="127.0.0.1",
                log_to_driver=False,
            )
        else:
            ray.init(address=address, log_to_driver=False)
    try:
        remote = ray.remote(num_cpus=1)(_trial_on_node)
        pending = [remote.remote(spec, record_dir) for spec in specs]
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            yield ray.get(ready[0])
    finally:
        if started:
            ray.shutdown()


class BackendMissing(PtwlError, RuntimeError):
    """A sweep backend whose library is not installed; the message says how to install it."""


def available(backend: str) -> None:
    """Refuse, before anything is written, a backend whose library is not installed."""
    if backend == "ray" and importlib.util.find_spec("ray") is None:
        raise BackendMissing('the ray backend needs Ray: pip install -e ".[ray]"')


def run(
    specs: list[TrialSpec], backend: str, workers: int, address: str | None, record_dir: str | None = None
) -> Iterator[Finished]:
    if backend == "ray":
        return run_ray(specs, workers, address, record_dir)
    return run_local(specs, workers, record_dir)
