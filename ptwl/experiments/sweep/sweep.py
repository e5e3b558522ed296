"""A whole sweep into a directory: the grid, what is already there, the trials still to run (on
a backend), progress, and the outputs (trials.csv, summary.csv/.md, report.md with its PNGs,
sweep.json).

Re-running into the same directory runs only the trials missing from trials.csv; Ctrl-C keeps
every trial that finished (whole rows) and leaves sweep.json saying how many of the grid are
done. Settings that change what a trial is (task, jitter, loss, think time, seed, profile,
max age, machine, schedule file and its nodes) must match the directory's; RTTs, operators and
the trial count may grow.
"""

import importlib.metadata
import json
import platform
import sys
import time
from collections import Counter
from dataclasses import asdict
from pathlib import Path
from typing import Any, TextIO

import mujoco
import numpy as np
from ptwl_config import PtwlError
from tqdm import tqdm

from ptwl.experiments.sweep import backends
from ptwl.experiments.sweep.plots import write_report
from ptwl.experiments.sweep.spec import SweepSettings, TrialSpec, can_lose_signal
from ptwl.experiments.sweep.summary import write_summary
from ptwl.experiments.sweep.table import RowWriter, read_rows, row_key, write_sorted

# What a trial is: a directory's trials are only reusable under the same values.
RECORDINGS = "recordings"  # --record: one MCAP per trial, named by TrialSpec.file_stem()
TRIAL_SETTINGS = (
    "task",
    "jitter_s",
    "loss",
    "think_s",
    "seed",
    "profile",
    "max_age_s",
    "machine",
    "schedule",
    "ground_node",
    "robot_node",
)


class Progress:
    """A bar with trials done, rate and ETA on a terminal; plain lines otherwise (a log)."""

    def __init__(self, total: int, done: int, stream: TextIO = sys.stderr) -> None:
        self.total, self.done, self.stream = total, done, stream
        self._started, self._new = time.monotonic(), 0
        self.by_node: Counter[str] = Counter()  # this run's trials, by the node that ran them
        self._bar = (
            tqdm(total=total, initial=done, unit="trial", desc="sweep", file=stream)
            if stream.isatty()
            else None
        )
        self._every = max(1, total // 50)

    def update(self, node: str) -> None:
        self.done += 1
        self._new += 1
        self.by_node[node] += 1
        nodes = self._nodes()
        if self._bar is not None:
            if nodes:
                self._bar.set_postfix_str(nodes, refresh=False)
            self._bar.update()
            return
        if self._new % self._every == 0 or self.done == self.total:
            elapsed = time.monotonic() - self._started
            rate = self._new / elapsed if elapsed > 0 else 0.0
            eta = (self.total - self.done) / rate if rate > 0 else float("inf")
            print(
                f"sweep: {self.done}/{self.total} trials, {60.0 * rate:.1f} trials/min, ETA {eta:.0f} s"
                + (f" ({nodes})" if nodes else ""),
                file=self.stream,
                flush=True,
            )

    def _nodes(self) -> str:
        """Trials per node ("node 3f2a9c1e: 5, node 77b0d412: 4"), once a second node has run one."""
        if len(self.by_node) < 2:
            return ""
        return ", ".join(f"node {name}: {count}" for name, count in sorted(self.by_node.items()))

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def versions(backend: str) -> dict[str, str]:
    found = {
        "ptwl-console": importlib.metadata.version("ptwl-console"),
        "python": platform.python_version(),
        "mujoco": mujoco.__version__,
        "numpy": np.__version__,
    }
    if backend == "ray":
        found["ray"] = importlib.metadata.version("ray")
    return found


class OutDirectoryError(PtwlError, ValueError):
    """`--out` names a directory this sweep must not write into (`ptwl`: exit 2, one line)."""


def _check_directory(out: Path, settings: SweepSettings) -> None:
    """Write only into a new or empty directory, or a sweep's of the same grid (to resume it):
    a sweep overwrites report.md, summary.md, trials.csv and more, which in any other directory
    may be someone's own files. Trials of different settings never mix in one directory."""
    if not out.exists():
        return
    if not out.is_dir():
        raise OutDirectoryError(f"--out {out}: exists and is not a directory")
    path = out / "sweep.json"
    if not path.exists():
        found = sorted(p.name for p in out.iterdir())
        if found:
            shown = ", ".join(repr(n) for n in found[:3]) + (
                f" and {len(found) - 3} more" if len(found) > 3 else ""
            )
            raise OutDirectoryError(
                f"--out {out}: not empty and not a sweep's directory (no sweep.json; it holds {shown}); "
                "give a new or empty directory, or a sweep's to resume it"
            )
        return
    try:
        before = json.loads(path.read_text())["arguments"]
        if not isinstance(before, dict):
            raise TypeError("arguments is not an object")
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise OutDirectoryError(
            f"--out {out}: its sweep.json is not a sweep's ({type(err).__name__}: {err}); "
            "give a new or empty directory"
        ) from None
    for name in TRIAL_SETTINGS:
        if before.get(name) != getattr(settings, name):
            raise OutDirectoryError(
                f"--out {out}: holds a sweep with {name} = {before.get(name)!r}, not "
                f"{getattr(settings, name)!r}: use another --out, or the same settings to resume"
            )


def _write_json(
    out: Path,
    settings: SweepSettings,
    specs: list[TrialSpec],
    done: int,
    wall_s: float,
    by_node: dict[str, int] | None = None,
) -> None:
    record = {
        "arguments": asdict(settings),
        "versions": versions(settings.backend),
        "seeds": sorted({s.seed for s in specs}),
        "grid_trials": len(specs),
        "trials_done": done,
        "complete": done == len(specs),
        "wall_s_this_run": wall_s,
        "trials_by_node_this_run": by_node or {},
    }
    tmp = out / "sweep.json.tmp"
    tmp.write_text(json.dumps(record, indent=2) + "\n")
    tmp.replace(out / "sweep.json")


def run_sweep(settings: SweepSettings, stream: TextIO = sys.stderr) -> list[dict[str, Any]]:
    """Run what is missing and write every output; the rows of this grid, in grid order."""
    backends.available(settings.backend)
    out = Path(settings.out)
    _check_directory(out, settings)  # before anything is written
    out.mkdir(parents=True, exist_ok=True)
    specs = settings.specs()
    order = [s.key() for s in specs]
    csv_path = out / "trials.csv"
    have = {row_key(r) for r in write_sorted(csv_path, read_rows(csv_path), order)}
    todo = [s for s in specs if s.key() not in have]
    started = time.monotonic()
    _write_json(out, settings, specs, len(specs) - len(todo), 0.0)
    writer = RowWriter(csv_path)
    progress = Progress(len(specs), len(specs) - len(todo), stream)
    try:
        record_dir = None
        if settings.record:
            (out / RECORDINGS).mkdir(exist_ok=True)
            record_dir = str((out / RECORDINGS).resolve())
        for row, node in backends.run(
            todo, settings.backend, settings.workers, settings.ray_address, record_dir
        ):
            writer.append(row)
            progress.update(node)
    finally:
        writer.close()
        progress.close()
        _write_json(out, settings, specs, progress.done, time.monotonic() - started, dict(progress.by_node))
    wanted = set(order)
    mine = [r for r in write_sorted(csv_path, read_rows(csv_path), order) if row_key(r) in wanted]
    table = write_summary(out, mine)
    write_report(out, mine, table, can_lose_signal(specs[0].link_profile()))
    return mine
