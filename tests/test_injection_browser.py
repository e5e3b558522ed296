"""Issue 26's stored script injection, tried the ways it got in, in Chromium: markup in every string
an outsider can put on a console page (through the API, the link, a frame name, the link profile's
description, and a crafted recording played by `ptwl replay`) shows as text and runs nothing.
Framing: no page of ours can be put in another origin's frame; every server says so in its
headers."""

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from playwright.sync_api import TimeoutError as PlaywrightTimeout

from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import simulate
from ptwl.launcher import free_port, running
from server.models import SENDER_HEADER
from tests.console_page import _load
from tests.test_browser_attack import AttackSite
from tests.test_replay import robot_url

# Each would set window.__pwned if the page ran it as markup (the console's CSP allows inline
# handlers, which viser's page needs, so escaping is what must stop these).
PAYLOADS = (
    '<img src=x onerror="window.__pwned=(window.__pwned||0)+1">',
    '<svg onload="window.__pwned=1"></svg>',
    "</div><script>window.__pwned=1</script>",
    '"><img src=y onerror="window.__pwned=1">',
)
PAYLOAD = " ".join(PAYLOADS)  # 175 characters: inside the profile description's 500


@pytest.fixture
def site() -> Iterator[AttackSite]:
    s = AttackSite()
    yield s
    s.close()


def _no_injected_markup(page: Any) -> None:
    assert page.evaluate("window.__pwned") is None
    assert page.evaluate("document.querySelectorAll('img[src=x], img[src=y], svg[onload]').length") == 0


def test_markup_in_every_outside_string_shows_as_text(browser: object, stack: Any) -> None:
    robot, link, console = stack
    # The sender header refuses markup, directly and through the link (the link forwards the 422).
    for url in (robot.url, link.url):
        answer = httpx.post(url + "/api/commands", json={"type": "rwe"}, headers={SENDER_HEADER: PAYLOADS[0]})
        assert answer.status_code == 422 and SENDER_HEADER in answer.text
    # Frame names are identifiers: markup is refused naming the field.
    pose = {"position": [0.4, 0.0, 0.3], "quaternion": [1.0, 0.0, 0.0, 0.0]}
    answer = httpx.post(link.url + "/api/frames", json={"name": PAYLOADS[1], "pose": pose})
    assert answer.status_code == 422 and "name" in answer.text
    # The link profile's description is free text, shown on every console: as text.
    httpx.put(link.url + "/_link/profile", json={"description": PAYLOAD}).raise_for_status()
    page = _load(browser, console.url, (1100, 720), csp=True)  # the policy users get
    try:
        page.locator("#ptwl-link-profile", has_text="onerror").wait_for(state="attached")
        assert PAYLOAD in page.locator("#ptwl-link-profile").text_content()
        _no_injected_markup(page)
    finally:
        page.close()
        httpx.put(link.url + "/_link/profile", json={"description": ""}).raise_for_status()


MONITOR = {  # a force monitor's telemetry (robot_sim/task_monitor.py), its reason crafted
    "model": "friction",
    "mu": 0.3,
    "c": 0.0,
    "normal_force": 1.8,
    "tangential_force": 0.5,
    "predicted": 0.54,
    "residual": -0.04,
    "band": 1.0,
    "judging": False,
    "anomaly": False,
    "samples_learned": 40,
}
SPEC = TrialSpec("quick_connect", "onboard", 0.0, 0.0, 0.0, 0, think_s=0.0)


def _crafted(source: Path, out: Path) -> int:
    """`source` as an attacker would edit it: markup in every /commands message's sender, detail
    and steps, and in each state's task predicate and unit; how many command messages were
    edited."""
    edited = 0  # (and a force monitor on each state, markup in why it is not judging)
    with source.open("rb") as f_in, out.open("wb") as f_out:
        reader = make_reader(f_in)
        writer = Writer(f_out)
        writer.start(profile="ptwl")
        summary = reader.get_summary()
        assert summary is not None
        schema_ids = {
            sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in summary.schemas.items()
        }
        channel_ids = {
            cid: writer.register_channel(
                c.topic, c.message_encoding, schema_ids.get(c.schema_id, 0), c.metadata
            )
            for cid, c in summary.channels.items()
        }
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, record.metadata)
        for _, channel, message in reader.iter_messages(log_time_order=False):
            data = message.data
            if channel.topic == "/ptwl/telemetry" and json.loads(data).get("task"):
                state = json.loads(data)
                state["task"]["predicate"], state["task"]["unit"] = PAYLOADS[1], PAYLOADS[2]
                state["monitor"] = {**MONITOR, "not_judging": PAYLOADS[3]}
                data = json.dumps(state).encode()
            if channel.topic == "/commands":
                event = json.loads(data)
                event["sender"] = PAYLOADS[0]
                event["detail"] = PAYLOADS[2]
                for step in event.get("steps") or []:
                    step["why"], step["exit"] = PAYLOADS[1], PAYLOADS[3]
                data = json.dumps(event).encode()
                edited += 1
            writer.add_message(channel_ids[message.channel_id], message.log_time, data, message.publish_time)
        writer.finish()
    return edited


def test_markup_in_a_crafted_recording_shows_as_text_in_replay(browser: object, tmp_path: Path) -> None:
    source, crafted = tmp_path / "trial.mcap", tmp_path / "crafted.mcap"
    simulate(SPEC, record=source)
    assert _crafted(source, crafted) >= 3  # queued, running, completed
    port = free_port()
    with running(
        "replay", str(crafted), "--port", str(port), "--paused", health="/", startup_timeout=90.0
    ) as replay:
        page = _load(browser, replay.url, (1100, 900), csp=True)
        try:
            page.locator('#ptwl-replay[data-playing="0"]').wait_for(state="attached")
            # The first state drawn: the page is up (this page keeps its script policy, so it waits
            # by locators). Pressed before it, once with a core hogged, End never seeked.
            page.locator('#ptwl-telemetry:not([data-seq=""])').wait_for(state="attached")
            slider = page.get_by_role("slider")
            slider.focus()
            slider.press("End")  # every command event played past
            page.locator('#ptwl-command[data-status="completed"]').wait_for(state="attached")
            line = page.locator("#ptwl-command").inner_text()
            assert PAYLOADS[0] in line and PAYLOADS[2] in line, line
            assert PAYLOADS[0].split(" ")[0] in page.locator("#ptwl-history").inner_text()
            task = page.locator("#ptwl-task")
            assert task.get_attribute("title") == PAYLOADS[1] and PAYLOADS[2] in task.inner_text()
            assert PAYLOADS[3] in page.locator("#ptwl-monitor").inner_text()  # the monitor's reason
            time.sleep(0.5)  # an injected handler would have fired by now
            _no_injected_markup(page)
        finally:
            page.close()


def test_no_page_can_be_framed_by_another_origin(browser: object, stack: Any, site: AttackSite) -> None:
    robot, link, console = stack
    for url in (console.url + "/", robot.url + "/docs", robot.url + "/api/state", link.url + "/docs"):
        headers = httpx.get(url).headers
        assert "frame-ancestors 'none'" in headers["content-security-policy"], url
        assert headers["x-frame-options"] == "DENY", url
    assert "script-src 'self'" in httpx.get(console.url + "/").headers["content-security-policy"]
    refused = httpx.get(console.url + "/", headers={"Host": "rebinding.example"})  # the front door's own
    assert (
        refused.status_code == 400 and "frame-ancestors 'none'" in refused.headers["content-security-policy"]
    )
    # A page of another origin frames the console and clicks where Send would be.
    site.html = f'<!doctype html><iframe src="{console.url}/" width="1100" height="720"></iframe>'
    before = len(httpx.get(robot.url + "/api/commands", params={"limit": 1000}).json())
    page = browser.new_page(viewport={"width": 1300, "height": 900})  # type: ignore[attr-defined]
    try:
        page.goto(site.origin + "/")
        (framed,) = page.main_frame.child_frames
        # Unframed, the console shows Take control within ~3 s; framed, Chromium blocks it.
        with pytest.raises(PlaywrightTimeout):
            framed.get_by_role("button", name="Take control").wait_for(timeout=8_000)
        page.mouse.click(200, 300)
    finally:
        page.close()
    assert len(httpx.get(robot.url + "/api/commands", params={"limit": 1000}).json()) == before


def test_the_replay_and_its_stand_in_send_the_page_headers(tmp_path: Path) -> None:
    source = tmp_path / "trial.mcap"
    simulate(SPEC, record=source)
    port = free_port()
    with running(
        "replay", str(source), "--port", str(port), "--paused", health="/", startup_timeout=90.0
    ) as replay:
        stand_in = robot_url(replay.output)
        for url in (replay.url + "/", stand_in + "/docs", stand_in + "/api/state"):
            headers = httpx.get(url).headers
            assert "frame-ancestors 'none'" in headers["content-security-policy"], url
            assert headers["x-frame-options"] == "DENY", url
