"""Shared fixtures: robot servers as real subprocesses."""

import gc
import os
from collections.abc import Iterator

import pytest
from xdist.remote import Producer

import ptwl.launcher
from ptwl.launcher import ServiceProcess, running_console, running_proxy, running_server
from robot_sim.warm import warm_up
from server.client import RobotClient
from tests.console_page import PAGE_WAIT_MS
from tests.frame_cap import CappedBrowser
from tests.scheduling import PagesCappedScheduling, file_of, file_order, is_browser_file
from tests.zygote import Zygote
from web.browser import chromium_available, launch


@pytest.fixture(scope="session", autouse=True)
def own_state_home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Servers the tests start keep their command-id record in a directory of the run's own, not
    in the user's ~/.local/state/ptwl (children inherit the environment)."""
    before = os.environ.get("XDG_STATE_HOME")
    os.environ["XDG_STATE_HOME"] = str(tmp_path_factory.mktemp("state_home"))
    yield
    if before is None:
        os.environ.pop("XDG_STATE_HOME", None)
    else:
        os.environ["XDG_STATE_HOME"] = before


@pytest.fixture(scope="session", autouse=True)
def forked_services(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Zygote | None]:
    """The services `ptwl.launcher` starts are forked from a preloaded process (tests/zygote.py):
    each start then skips ~2-3 CPU-s of imports. PTWL_TEST_FORK=0 starts fresh interpreters."""
    if os.environ.get("PTWL_TEST_FORK") == "0":
        yield None
        return
    zygote = Zygote(str(tmp_path_factory.mktemp("zygote") / "socket"))
    ptwl.launcher.SPAWN = zygote.spawn
    try:
        yield zygote
    finally:
        ptwl.launcher.SPAWN = ptwl.launcher.popen
        zygote.close()


@pytest.fixture(scope="module")
def server() -> Iterator[ServiceProcess]:
    with running_server("--scene", "free_space", "--fault-injection") as srv:
        yield srv


@pytest.fixture
def robot(server: ServiceProcess) -> Iterator[RobotClient]:
    """A client on a server reset to free_space with nothing queued."""
    with RobotClient(server.url) as client:
        client.reset_scene("free_space")
        yield client


@pytest.fixture
def no_gc_pauses() -> Iterator[None]:
    """For tests that time messages in this process: a few hundred tests in, one full garbage
    collection here takes ~90 ms (150 000 objects after the imports alone), which is what made
    end-to-end latencies 50-65 ms late in full runs while the link's own record was on time.
    Frozen and off for the test; back on after."""
    gc.collect()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
        gc.unfreeze()


@pytest.fixture(scope="module")
def stack() -> Iterator[tuple[ServiceProcess, ServiceProcess, ServiceProcess]]:
    """Robot (free_space), link and console, for one module's browser tests."""
    with (
        running_server("--scene", "free_space") as robot,
        running_proxy(robot.url) as link,
        running_console(link.url) as console,
    ):
        yield robot, link, console


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    """Debian's Chromium under Playwright (never `playwright install`), its pages' drawing capped
    (tests/frame_cap.py). Outside CI the browser tests skip without it; under CI=true its absence
    fails."""
    if not chromium_available():
        if os.environ.get("CI") == "true":
            pytest.fail("CI=true but /usr/bin/chromium is missing: .ci/run must apt-get install chromium")
        pytest.skip("Debian's chromium is not installed (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        chromium = launch(playwright)
        yield CappedBrowser(chromium, timeout_ms=PAGE_WAIT_MS)
        chromium.close()


@pytest.fixture(autouse=True)
def pages_closed(request: pytest.FixtureRequest) -> Iterator[None]:
    """Every page a test opened is closed when it ends, passed or failed (a failed test skips its
    own `page.close()`): pages left open would load the tests after it."""
    capped = request.getfixturevalue("browser") if "browser" in request.fixturenames else None
    yield
    if isinstance(capped, CappedBrowser):
        capped.close_pages()


def pytest_sessionstart(session: pytest.Session) -> None:
    """The compiled tick into numba's cache before any test (a fresh clone compiles it once,
    ~17 s): the robot servers the tests start then load it in a fraction of a second, well
    inside their start-up timeout, instead of each compiling it."""
    warm_up()


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """`-n auto`: a worker per core and one more; two more for the inner loop (`-m "not browser"`).
    No more workers than cores hold browser files at once (tests/scheduling.py), so no more pages
    draw at once than with a worker per core, while the extra workers run the files that mostly
    wait on real time. PYTEST_XDIST_AUTO_NUM_WORKERS, as in xdist's own `-n auto`, says how many instead."""
    if told := os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return int(told)
    cores = len(os.sched_getaffinity(0))
    inner_loop = (config.getoption("markexpr") or "").split() == ["not", "browser"]
    return cores + 2 if inner_loop else cores + 1


@pytest.hookimpl(tryfirst=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Producer) -> PagesCappedScheduling | None:
    """`--dist loadfile` as tests/scheduling.py deals it: browser files on a worker per core at most."""
    if config.getvalue("dist") != "loadfile":
        return None
    return PagesCappedScheduling(config, log, page_workers=len(os.sched_getaffinity(0)))


def pytest_configure(config: pytest.Config) -> None:
    """Keep the order below across workers: by default pytest-xdist's `loadfile` hands out the
    files with the most tests first (`--loadscope-reorder`), which put the browser files (2-17
    tests each, a minute to four) last, where one worker finished one alone while the other
    idled (measured: 56-63 s apart at the end)."""
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every test that drives Chromium is marked `browser`, so `-m "not browser"` leaves them out.

    Files with browser tests run first, then tests/scheduling.py's LONG_FILES, then the rest (each
    file's tests together and in order): the long files start while there is still work to fill in
    behind them."""
    for item in items:
        if "browser" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.browser)
    items.sort(key=lambda item: file_order(file_of(item.nodeid)))


def pytest_runtest_setup(item: pytest.Item) -> None:
    """A test that drives Chromium from a file missing in BROWSER_FILES errors: the scheduler, which
    sees node ids only, would let every worker take its file."""
    if item.get_closest_marker("browser") and not is_browser_file(path := file_of(item.nodeid)):
        pytest.fail(f"{path} drives Chromium: add it to BROWSER_FILES in tests/scheduling.py")
