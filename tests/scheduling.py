"""How the suite's files are dealt to pytest-xdist's workers (`-n auto --dist loadfile`).

Two kinds of file share the cores. A file that drives Chromium keeps most of a core busy while
its tests wait (a page draws, its robot, link and console run), and its real-time checks go late
when pages outnumber the cores. Most other files wait on real time with their core idle (a robot
that moves in real time, a link's delays): serially the files without a browser took 284 CPU-s
in 8:40 of wall time, a third of a core. So the workers outnumber the cores, but only as many of
them as there are cores take browser files (`PagesCappedScheduling`): the others start on the
longest files without one, and every worker takes what is left once the browser files are dealt.
"""

from pathlib import PurePosixPath

import pytest
from xdist.remote import Producer
from xdist.scheduler import LoadFileScheduling
from xdist.workermanage import WorkerController

# Every file with a test that uses the `browser` fixture (tests/conftest.py fails a browser test
# from a file missing here: the scheduler sees node ids only, not markers).
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


def file_order(path_name: str, is_browser_file: bool) -> tuple[bool, int]:
    """Sort key of a test file: browser files first, then LONG_FILES in their order, then the rest
    (each file's tests stay together and in order)."""
    long_rank = LONG_FILES.index(path_name) if path_name in LONG_FILES else len(LONG_FILES)
    return (not is_browser_file, long_rank)


class PagesCappedScheduling(LoadFileScheduling):
    """xdist's `loadfile` (a file's tests on one worker, in order, files in collection order), but
    only the first `page_workers` of the live workers take files in BROWSER_FILES: at most that
    many pages draw at once, however many workers there are."""

    def __init__(self, config: pytest.Config, log: Producer | None = None, *, page_workers: int) -> None:
        super().__init__(config, log)
        self.page_workers = page_workers

    def _may_take(self, node: WorkerController, scope: str) -> bool:
        if PurePosixPath(scope).name not in BROWSER_FILES:
            return True
        return self.nodes.index(node) < self.page_workers

    def _next_scope(self, node: WorkerController) -> str | None:
        return next((scope for scope in self.workqueue if self._may_take(node, scope)), None)

    def _assign_work_unit(self, node: WorkerController) -> None:
        scope = self._next_scope(node)
        if scope is None:
            return
        work_unit = self.workqueue.pop(scope)
        self.assigned_work.setdefault(node, {})[scope] = work_unit
        collection = self.registered_collections[node]
        node.send_runtest_some([collection.index(nodeid) for nodeid, done in work_unit.items() if not done])

    def _reschedule(self, node: WorkerController) -> None:
        if node.shutting_down:
            return
        if self._next_scope(node) is None:
            node.shutdown()  # it finishes what it holds; nothing left is for it
            return
        if self._pending_of(self.assigned_work[node]) > 2:  # xdist's own low-water mark
            return
        self._assign_work_unit(node)
