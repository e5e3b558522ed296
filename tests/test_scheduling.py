"""The suite's own scheduler (tests/scheduling.py): no more workers than cores hold browser files at
once, the other workers start on the long files, and every test runs once, its file's tests in
order on one worker, a crashed worker's file included."""

import os
import re
from collections import deque
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from tests import conftest
from tests.scheduling import BROWSER_FILES, LONG_FILES, PagesCappedScheduling, file_of, file_order

TESTS_DIR = Path(__file__).resolve().parent
PAGE_FILES = [f"tests/{name}" for name in BROWSER_FILES[:3]]
OTHER_FILES = [f"tests/{LONG_FILES[0]}", "tests/test_a.py", "tests/test_b.py", "tests/test_c.py"]


class FakeWorker:
    """What the scheduler uses of xdist's WorkerController."""

    def __init__(self, name: str) -> None:
        self.gateway = SimpleNamespace(id=name)
        self.shutting_down = False
        self.queue: deque[int] = deque()

    def send_runtest_some(self, indices: list[int]) -> None:
        self.queue.extend(indices)

    def shutdown(self) -> None:
        self.shutting_down = True


def collection(tests_per_file: tuple[int, ...] = (3, 2, 6, 5, 1, 1, 2)) -> list[str]:
    files = (PAGE_FILES + OTHER_FILES)[: len(tests_per_file)]
    return [f"{path}::test_{i}" for path, n in zip(files, tests_per_file, strict=True) for i in range(n)]


def fake_config(dist: str = "loadfile", markexpr: str = "", workers: int = 3) -> Any:
    """What the scheduler and the suite's xdist hooks read of pytest's config."""
    values = {"dist": dist, "tx": [f"{workers}*popen"]}
    return SimpleNamespace(
        getvalue=values.get,
        getoption=lambda name: markexpr if name == "markexpr" else None,
        option=SimpleNamespace(loadscopereorder=False),
    )


class Run:
    """`collection` dealt to fake workers that each finish one test in turn, as xdist's DSession
    drives a scheduler: what ran where in order, and the most workers holding browser tests at
    once. A worker is given its next file only when two tests or fewer are left before it
    (xdist's low-water mark), or one would hoard the queue while the others idle."""

    def __init__(self, ids: list[str], workers: int, page_workers: int) -> None:
        self.ids = ids
        self.scheduler = PagesCappedScheduling(fake_config(workers=workers), page_workers=page_workers)
        self.nodes: list[FakeWorker] = []
        self.ran: list[tuple[str, str]] = []
        self.most_on_pages = 0
        for i in range(workers):
            self.join(FakeWorker(f"gw{i}"), schedule=False)
        self.scheduler.schedule()

    def join(self, node: FakeWorker, schedule: bool = True) -> None:
        self.nodes.append(node)
        self.scheduler.add_node(node)  # type: ignore[arg-type]
        self.scheduler.add_node_collection(node, self.ids)  # type: ignore[arg-type]
        if schedule:  # DSession, once a worker that joins late has collected
            self.scheduler.schedule()

    def crash(self, node: FakeWorker) -> None:
        """The worker dies in the test it runs; xdist removes it and starts another."""
        crashed = self.scheduler.remove_node(node)  # type: ignore[arg-type]
        assert crashed == self.ids[node.queue[0]]
        self.nodes.remove(node)
        self.join(FakeWorker(f"gw{len(self.nodes) + 1}-after-{node.gateway.id}"))

    def step(self) -> bool:
        """Each worker finishes its next test; whether any worker had one."""
        busy = False
        for node in list(self.nodes):
            on_pages = sum(
                1 for held in self.nodes if any(file_of(self.ids[i]) in PAGE_FILES for i in held.queue)
            )
            self.most_on_pages = max(self.most_on_pages, on_pages)
            files_held = [file_of(self.ids[i]) for i in node.queue]
            assert sum(1 for path in files_held if path != files_held[-1]) <= 2
            if node.queue:
                busy = True
                index = node.queue.popleft()
                self.ran.append((node.gateway.id, self.ids[index]))
                self.scheduler.mark_test_complete(node, index)  # type: ignore[arg-type]
        return busy

    def finish(self) -> None:
        while self.step():
            pass
        assert self.scheduler.tests_finished  # then xdist's DSession shuts every worker down

    def assert_each_test_once_and_each_file_in_order_on_one_worker(self) -> None:
        assert sorted(test for _, test in self.ran) == sorted(self.ids)
        for path in dict.fromkeys(file_of(test) for test in self.ids):
            of_file = [(worker, test) for worker, test in self.ran if file_of(test) == path]
            assert [test for _, test in of_file] == [t for t in self.ids if file_of(t) == path]
            assert len({worker for worker, _ in of_file}) == 1, of_file


def test_no_more_workers_than_cores_hold_browser_files_and_every_test_runs_once_in_order() -> None:
    run = Run(collection(), workers=3, page_workers=2)
    run.finish()
    run.assert_each_test_once_and_each_file_in_order_on_one_worker()
    assert run.most_on_pages == 2
    on_gw2 = [test for worker, test in run.ran if worker == "gw2"]
    assert on_gw2[0].startswith(OTHER_FILES[0] + "::")  # the extra worker starts on the long file


def test_with_one_page_worker_the_browser_files_run_one_after_another() -> None:
    run = Run(collection(), workers=3, page_workers=1)
    run.finish()
    run.assert_each_test_once_and_each_file_in_order_on_one_worker()
    assert run.most_on_pages == 1
    assert {worker for worker, test in run.ran if file_of(test) in PAGE_FILES} == {"gw0"}


def test_a_crashed_workers_browser_file_is_finished_by_the_worker_started_in_its_place() -> None:
    """With the queue empty the others are shutting down and take nothing more: only the worker
    started in the crashed one's place can finish its browser file (the rest of it, once; the
    files the crashed worker had finished, which xdist puts back too, not again)."""
    run = Run(collection(), workers=3, page_workers=1)
    page_worker = run.nodes[0]
    while run.scheduler.workqueue or len(page_worker.queue) < 3:
        assert run.step()
    assert (
        all(node.shutting_down for node in run.nodes[1:])
        and file_of(run.ids[page_worker.queue[0]]) in PAGE_FILES
    )
    run.crash(page_worker)
    run.finish()
    assert sorted(test for _, test in run.ran) == sorted(run.ids)  # the crashed test too, run again
    assert run.most_on_pages == 1
    assert [worker for worker, _ in run.ran[-3:]] == ["gw3-after-gw0"] * 3


def test_a_worker_that_finished_its_browser_file_no_longer_counts_against_the_cap() -> None:
    """Files dealt in the order given: the page worker moves on to a file without a browser while
    its browser file finishes; once it has, the other worker may take the next browser file."""
    first, second, plain = PAGE_FILES[0], PAGE_FILES[1], OTHER_FILES[1:3]
    ids = [f"{path}::test_{i}" for path in (first, plain[0], plain[1], second) for i in range(3)]
    run = Run(ids, workers=2, page_workers=1)
    run.finish()
    run.assert_each_test_once_and_each_file_in_order_on_one_worker()
    assert run.most_on_pages == 1
    assert {worker for worker, test in run.ran if file_of(test) == first} == {"gw0"}
    assert {worker for worker, test in run.ran if file_of(test) == second} == {"gw1"}


def test_with_only_browser_files_the_workers_past_the_cap_take_nothing() -> None:
    run = Run(collection((3, 2, 2)), workers=3, page_workers=2)
    run.finish()
    run.assert_each_test_once_and_each_file_in_order_on_one_worker()
    assert run.most_on_pages == 2 and not any(worker == "gw2" for worker, _ in run.ran)


def test_browser_files_sort_first_then_the_long_files_in_their_order() -> None:
    files = [f"tests/{name}" for name in ("test_a.py", LONG_FILES[1], BROWSER_FILES[2], LONG_FILES[0])]
    assert sorted(files, key=file_order) == [files[2], files[3], files[1], files[0]]


def test_every_listed_browser_file_drives_chromium() -> None:
    """A file left in BROWSER_FILES after its browser tests went would hold a page worker for
    nothing: each listed file has a test that takes the `browser` fixture."""
    for name in BROWSER_FILES:
        text = (TESTS_DIR / name).read_text()
        assert re.search(r"def test_\w+\([^)]*\bbrowser\b", text), name


def test_a_browser_test_from_a_file_not_in_browser_files_errors() -> None:
    def item(path: str) -> Any:
        return SimpleNamespace(nodeid=f"{path}::test_x", get_closest_marker=lambda mark: mark == "browser")

    conftest.pytest_runtest_setup(item(PAGE_FILES[0]))
    with pytest.raises(pytest.fail.Exception, match=r"tests/test_new_page\.py drives Chromium: add it"):
        conftest.pytest_runtest_setup(item("tests/test_new_page.py"))
    with pytest.raises(pytest.fail.Exception):  # the same name elsewhere is another file
        conftest.pytest_runtest_setup(item(f"tests/sub/{BROWSER_FILES[0]}"))


def test_the_readmes_command_gets_this_scheduler_and_a_worker_more_than_the_cores(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("PYTEST_XDIST_AUTO_NUM_WORKERS", raising=False)
    cores = len(os.sched_getaffinity(0))
    scheduler = conftest.pytest_xdist_make_scheduler(fake_config(), log=None)  # type: ignore[arg-type]
    assert isinstance(scheduler, PagesCappedScheduling) and scheduler.page_workers == cores
    assert conftest.pytest_xdist_make_scheduler(fake_config(dist="load"), log=None) is None  # type: ignore[arg-type]
    assert conftest.pytest_xdist_auto_num_workers(fake_config()) == cores + 1
    assert conftest.pytest_xdist_auto_num_workers(fake_config(markexpr="not browser")) == cores + 2
    monkeypatch.setenv("PYTEST_XDIST_AUTO_NUM_WORKERS", "5")
    assert conftest.pytest_xdist_auto_num_workers(fake_config()) == 5
