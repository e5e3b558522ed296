"""The attack of issue 9 as it happened, in a real browser: a page served from another origin
opens the console's socket and the robot's telemetry, and POSTs a no-cors STOP. None of it may
reach the robot; the same page served from an allowed origin shows the checks are what stop it."""

import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from ptwl.launcher import ServiceProcess, running_console, running_proxy, running_server
from server.client import RobotClient
from tests.console_page import until

ATTACK_PAGE = """<!doctype html><html><body><script>
window.results = {};
function probe(name, url) {
  try {
    const ws = new WebSocket(url);
    ws.onopen = () => { window.results[name] = "open"; };
    ws.onerror = () => { window.results[name] = "refused"; };
  } catch (e) { window.results[name] = "threw"; }
}
probe("console", "CONSOLE_WS");
probe("telemetry", "TELEMETRY_WS");
fetch("ROBOT/api/stop", {method: "POST", mode: "no-cors"})
  .then(() => { window.results.stop = "sent"; }, () => { window.results.stop = "failed"; });
</script></body></html>"""


class AttackSite:
    """A web server on its own origin (another port) serving the attack page."""

    def __init__(self) -> None:
        site = self

        class Page(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                body = site.html.encode()
                self.send_response(200)
                self.send_header("Content-Type", "text/html")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args: object) -> None:
                pass

        self.html = ""
        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Page)
        self.origin = f"http://127.0.0.1:{self.server.server_address[1]}"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


def attack(
    browser: object, site: AttackSite, robot: ServiceProcess, console: ServiceProcess
) -> tuple[dict[str, str], str]:
    """Open the attack page while a PTWL runs; what the page achieved, and the command's status."""
    site.html = (
        ATTACK_PAGE.replace("CONSOLE_WS", console.url.replace("http://", "ws://"))
        .replace("TELEMETRY_WS", robot.url.replace("http://", "ws://") + "/api/telemetry")
        .replace("ROBOT", robot.url)
    )
    with RobotClient(robot.url) as client:
        client.reset_scene("free_space")
        running = client.ptwl(translation=[0.0, 0.0, -0.02], duration=30.0).id
        page = browser.new_page()  # type: ignore[attr-defined]
        try:
            page.goto(site.origin + "/")
            until(
                page,
                "window.results.console && window.results.telemetry && window.results.stop",
            )
            results = page.evaluate("window.results")
            time.sleep(0.5)  # a STOP that got through would have ended the command by now
            status = client.get(running).status
            client.stop()
        finally:
            page.close()
    return results, status


@pytest.fixture
def site() -> Iterator[AttackSite]:
    attack_site = AttackSite()
    yield attack_site
    attack_site.close()


def test_a_page_on_another_origin_cannot_reach_console_or_robot(browser: object, site: AttackSite) -> None:
    with (
        running_server("--scene", "free_space") as robot,
        running_proxy(robot.url) as link,
        running_console(link.url) as console,
    ):
        results, status = attack(browser, site, robot, console)
    assert results["console"] == "refused" and results["telemetry"] == "refused"
    assert status == "running"  # the no-cors STOP was refused (403): the robot kept going


def test_the_same_page_from_an_allowed_origin_gets_through(browser: object, site: AttackSite) -> None:
    """Control: with the page's origin allowed, the same script opens both sockets and stops
    the robot, so the refusals above are the Origin checks, not a broken page."""
    with (
        running_server("--scene", "free_space", "--allow-origin", site.origin) as robot,
        running_proxy(robot.url) as link,
        running_console(link.url, "--allow-origin", site.origin) as console,
    ):
        results, status = attack(browser, site, robot, console)
    assert results["console"] == "open" and results["telemetry"] == "open"
    assert status == "done"
