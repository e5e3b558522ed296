"""Where trials run: a local process pool (default) or Ray tasks. Each trial is a pure function
of its settings (trial.run_trial), so both give the same rows; they come back as they end."""

import importlib.util
import os
import signal
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from experiments.sweep.spec import TrialSpec
from experiments.sweep.trial import run_trial


def _ignore_sigint() -> None:
    """Workers leave Ctrl-C to the parent, which stops handing out trials and keeps the rows."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_local(
    specs: list[TrialSpec], workers: int, record_dir: str | None = None
) -> Iterator[dict[str, Any]]:
    if not specs:
        return
    with ProcessPoolExecutor(max_workers=workers, initializer=_ignore_sigint) as pool:
        futures = [pool.submit(run_trial, spec, record_dir) for spec in specs]
        try:
            for future in as_completed(futures):
                yield future.result()
        finally:
            pool.shutdown(wait=True, cancel_futures=True)  # Ctrl-C: the running ones finish


def run_ray(
    specs: list[TrialSpec], workers: int, address: str | None, record_dir: str | None = None
) -> Iterator[dict[str, Any]]:
    """On the cluster at `address` (or RAY_ADDRESS), else a local one on loopback with `workers`
    CPUs. A remote cluster's nodes need this package installed (`pip install -e ".[ray]"`), and
    recordings land on the disk of the node that ran the trial."""
    import ray  # the optional extra: available() said so before the sweep began

    address = address or os.environ.get("RAY_ADDRESS") or None
    started = not ray.is_initialized()
    if started:
        if address is None:
            ray.init(
                num_cpus=workers, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False
            )
        else:
            ray.init(address=address, log_to_driver=False)
    try:
        remote = ray.remote(num_cpus=1)(run_trial)
        pending = [remote.remote(spec, record_dir) for spec in specs]
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            yield ray.get(ready[0])
    finally:
        if started:
            ray.shutdown()


def available(backend: str) -> None:
    """Refuse, before anything is written, a backend whose library is not installed."""
    if backend == "ray" and importlib.util.find_spec("ray") is None:
        raise SystemExit('the ray backend needs Ray: pip install -e ".[ray]"')


def run(
    specs: list[TrialSpec], backend: str, workers: int, address: str | None, record_dir: str | None = None
) -> Iterator[dict[str, Any]]:
    if backend == "ray":
        return run_ray(specs, workers, address, record_dir)
    return run_local(specs, workers, record_dir)
