"""The suite's own scheduler (tests/scheduling.py): browser files go to a worker per core, the
other workers start on the long files, and every test runs once, its file's tests in order."""

import os
from collections import deque
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from tests import conftest
from tests.scheduling import (
    BROWSER_FILES,
    LONG_FILES,
    PagesCappedScheduling,
    file_order,
)

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


def collection() -> list[str]:
    tests_per_file = [3, 2, 4, 5, 1, 1, 2]
    files = PAGE_FILES + OTHER_FILES
    return [f"{path}::test_{i}" for path, n in zip(files, tests_per_file, strict=True) for i in range(n)]


def run(workers: int, page_workers: int) -> tuple[list[tuple[str, str]], list[FakeWorker], int]:
    """Deal `collection()` to fake workers that each finish one test in turn; what ran where, in
    order, and the most workers that held an unfinished browser file at once. A worker is given
    its next file only when two tests or fewer are left before it (xdist's low-water mark), or
    one would hoard the queue while the others idle."""
    config: Any = SimpleNamespace(
        getvalue=lambda name: [f"{workers}*popen"] if name == "tx" else None,
        option=SimpleNamespace(loadscopereorder=False),
    )
    scheduler = PagesCappedScheduling(config, page_workers=page_workers)
    nodes = [FakeWorker(f"gw{i}") for i in range(workers)]
    ids = collection()
    for node in nodes:
        scheduler.add_node(node)  # type: ignore[arg-type]
    for node in nodes:
        scheduler.add_node_collection(node, ids)  # type: ignore[arg-type]
    scheduler.schedule()
    ran: list[tuple[str, str]] = []
    most_on_pages = 0
    while any(node.queue for node in nodes):
        for node in nodes:
            on_pages = sum(
                1 for held in nodes if any(ids[i].split("::")[0] in PAGE_FILES for i in held.queue)
            )
            most_on_pages = max(most_on_pages, on_pages)
            files_held = [ids[i].split("::")[0] for i in node.queue]
            assert sum(1 for path in files_held if files_held and path != files_held[-1]) <= 2
            if node.queue:
                index = node.queue.popleft()
                ran.append((node.gateway.id, ids[index]))
                scheduler.mark_test_complete(node, index)  # type: ignore[arg-type]
    return ran, nodes, most_on_pages


def test_only_a_worker_per_core_takes_browser_files_and_every_test_runs_once_in_order() -> None:
    ran, nodes, most_on_pages = run(workers=3, page_workers=2)
    assert sorted(test for _, test in ran) == sorted(collection())
    assert most_on_pages == 2
    on_gw2 = [test for worker, test in ran if worker == "gw2"]
    assert on_gw2 and not any(test.split("::")[0] in PAGE_FILES for test in on_gw2)
    assert on_gw2[0].startswith(OTHER_FILES[0])  # the third worker starts on the long file
    for path in PAGE_FILES + OTHER_FILES:  # a file's tests on one worker, in order
        of_file = [(worker, test) for worker, test in ran if test.startswith(path + "::")]
        assert len({worker for worker, _ in of_file}) == 1
        assert [test for _, test in of_file] == [t for t in collection() if t.startswith(path + "::")]
    assert all(node.shutting_down for node in nodes)


def test_with_one_page_worker_the_browser_files_run_one_after_another() -> None:
    ran, _, most_on_pages = run(workers=3, page_workers=1)
    assert most_on_pages == 1
    page_workers = {worker for worker, test in ran if test.split("::")[0] in PAGE_FILES}
    assert page_workers == {"gw0"}


def test_browser_files_sort_first_then_the_long_files_in_their_order() -> None:
    names = ["test_a.py", LONG_FILES[1], BROWSER_FILES[2], LONG_FILES[0], "test_b.py"]
    ordered = sorted(names, key=lambda name: file_order(name, name in BROWSER_FILES))
    assert ordered == [BROWSER_FILES[2], LONG_FILES[0], LONG_FILES[1], "test_a.py", "test_b.py"]


def test_a_browser_test_from_a_file_not_in_browser_files_fails() -> None:
    def item(name: str) -> Any:
        return SimpleNamespace(path=Path(f"tests/{name}"), get_closest_marker=lambda mark: mark == "browser")

    conftest.pytest_runtest_setup(item(BROWSER_FILES[0]))
    with pytest.raises(
        pytest.fail.Exception, match=r"test_new_page\.py drives Chromium: add it to BROWSER_FILES"
    ):
        conftest.pytest_runtest_setup(item("test_new_page.py"))


def fake_config(dist: str = "loadfile", markexpr: str = "") -> Any:
    values = {"dist": dist, "tx": ["3*popen"]}
    return SimpleNamespace(
        getvalue=values.get,
        getoption=lambda name: markexpr if name == "markexpr" else None,
        option=SimpleNamespace(loadscopereorder=False),
    )


def test_the_readmes_command_gets_this_scheduler_and_a_worker_more_than_the_cores() -> None:
    cores = len(os.sched_getaffinity(0))
    scheduler = conftest.pytest_xdist_make_scheduler(fake_config(), log=None)
    assert isinstance(scheduler, PagesCappedScheduling) and scheduler.page_workers == cores
    assert conftest.pytest_xdist_make_scheduler(fake_config(dist="load"), log=None) is None
    assert conftest.pytest_xdist_auto_num_workers(fake_config()) == cores + 1
    assert conftest.pytest_xdist_auto_num_workers(fake_config(markexpr="not browser")) == cores + 2
