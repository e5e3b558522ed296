"""How the suite's files are dealt to pytest-xdist's workers (`-n auto --dist loadfile`).

Two kinds of file share the cores. A file that drives Chromium keeps most of a core busy while
its tests wait (a page draws, its robot, link and console run), and its real-time checks go late
when pages outnumber the cores. Most other files wait on real time with their core idle (a robot
that moves in real time, a link's delays): serially the files without a browser took 284 CPU-s
in 8:40 of wall time, about half a core. So the workers outnumber the cores, but no more of them
than there are cores hold browser files at once (`PagesCappedScheduling`): the others start on
the longest files without one, and every worker takes what is left.
"""

import pytest
from xdist.remote import Producer
from xdist.scheduler import LoadFileScheduling
from xdist.workermanage import WorkerController

# Every file in tests/ with a test that uses the `browser` fixture: the scheduler sees node ids
# only, not markers (tests/conftest.py errors a browser test from a file missing here, and
# tests/test_scheduling.py checks that every file here has one).
BROWSER_FILES = (
    "test_console_trust.py",  # 17 tests, 172 CPU-s serially: the longest file by far
    "test_console_browser.py",
    "test_plots_browser.py",
    "test_injection_browser.py",
    "test_console_desk_browser.py",
    "test_console_stop_browser.py",
    "test_replay.py",
    "test_console_fields_browser.py",
    "test_browser_attack.py",
)

# The longest files without a browser, measured (idle, 2 cores): 15-50 s each against a few
# seconds for most. They go out first among the files without a browser, so that short files fill
# in behind them instead of one worker finishing a long file alone at the end.
LONG_FILES = (
    "test_sweep_ray_cluster.py",  # two `ray start` nodes
    "test_sweep_outputs.py",  # sweeps, one on a local Ray
    "test_link_proxy.py",
    "test_server_commands.py",
    "test_link_schedule_proxy.py",
    "test_server_bad_input.py",
    "test_console_logic.py",
    "test_openapi_fuzz.py",  # Schemathesis, twice at once
    "test_state_machines.py",
)


BROWSER_PATHS = frozenset(f"tests/{name}" for name in BROWSER_FILES)  # as node ids name them


def file_of(nodeid: str) -> str:
    """A test's file, by its path from the repository's root: the scope xdist's loadfile deals."""
    return nodeid.split("::", 1)[0]


def is_browser_file(path_from_root: str) -> bool:
    """Whether a test file (its path from the repository's root, as in a node id) drives Chromium."""
    return path_from_root in BROWSER_PATHS


def file_order(path_from_root: str) -> tuple[bool, int]:
    """Sort key of a test file: browser files first, then LONG_FILES in their order, then the rest
    (each file's tests stay together and in order)."""
    name = path_from_root.removeprefix("tests/")
    long_rank = LONG_FILES.index(name) if name in LONG_FILES else len(LONG_FILES)
    return (not is_browser_file(path_from_root), long_rank)


class PagesCappedScheduling(LoadFileScheduling):
    """xdist's `loadfile` (a file's tests on one worker, in order, files in collection order), but
    no more than `page_workers` workers hold unfinished tests of browser files at once, however
    many workers there are. The cap is a count, not a place in the list of workers: a worker
    started in place of a crashed one can take the rest of the crashed one's browser file. A
    worker that may take nothing now waits, as xdist's own do for the queue's end: a crashed
    worker's files put back are offered to it, and the DSession shuts every worker down once
    every test has run."""

    def __init__(self, config: pytest.Config, log: Producer | None = None, *, page_workers: int) -> None:
        super().__init__(config, log)
        self.page_workers = page_workers

    def _holds_pages(self, node: WorkerController) -> bool:
        return any(
            is_browser_file(scope) and not all(unit.values())
            for scope, unit in self.assigned_work[node].items()
        )

    def _may_take(self, node: WorkerController, scope: str) -> bool:
        if not is_browser_file(scope) or self._holds_pages(node):
            return True
        return sum(1 for other in self.nodes if self._holds_pages(other)) < self.page_workers

    def _next_scope(self, node: WorkerController) -> str | None:
        return next((scope for scope in self.workqueue if self._may_take(node, scope)), None)

    def _assign_work_unit(self, node: WorkerController) -> None:
        """The next file this worker may take, skipping files already finished: xdist puts back
        every file a crashed worker held, finished ones too, and a worker sent an empty file
        would never report a test, so it would never be given another."""
        while (scope := self._next_scope(node)) is not None:
            work_unit = self.workqueue.pop(scope)
            self.assigned_work.setdefault(node, {})[scope] = work_unit
            collection = self.registered_collections[node]
            left = [collection.index(nodeid) for nodeid, done in work_unit.items() if not done]
            if left:
                node.send_runtest_some(left)
                return
