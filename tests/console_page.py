"""Reading and driving the console in a real browser (Playwright pages on Debian's Chromium).

The 3D scene is WebGL, which the DOM cannot see, so the console mirrors what it draws in its
status lines (data-* attributes and text), updated in the same batch as the scene; these read them.
"""

import io
import re

import httpx
import numpy as np
from PIL import Image

from ptwl.launcher import ServiceProcess
from tests.frame_cap import FRAME_CAP_HZ

POLL_MS = 50
"""How often a waiting test reads the page. Playwright's default, every animation frame, makes the
page draw 60 frames a second for as long as a test waits: measured, 71% of a core in Chromium's
software GPU process against 9% when polled every 100 ms, for a page whose robot is still. 50 ms
is finer than any time a test asserts."""

PAGE_WAIT_MS = 60_000
"""How long a test waits for a page to show or do something (every page's default timeout, and
`until`'s): a bound, not a check. Loaded CI runs took over 3 s to draw a marker after its Send,
over 10 s to show a fresh page's Send, and once over 30 s (Playwright's default) to take a click
on a page that had just loaded a scene beside another. What the tests assert is what a page
shows, and the order of events: between two events both seen (the marker at least a second
before the robot's port moves), or by a window the test holds open long enough (a command queued
behind one that runs 8 s); never by a short wait."""

PORT_TEXT = re.compile(r"port \((-?[\d.]+), (-?[\d.]+), (-?[\d.]+)\) mm")


def until(page, predicate_js: str, timeout: float = PAGE_WAIT_MS):  # type: ignore[no-untyped-def]
    """Wait until `predicate_js` is true in `page`, read every POLL_MS, for up to `timeout`
    milliseconds (Playwright's own name and unit, which the callers pass on)."""
    return page.wait_for_function(predicate_js, timeout=timeout, polling=POLL_MS)


def open_console(  # type: ignore[no-untyped-def]
    browser: object,
    url: str,
    control: bool = True,
    viewport: tuple[int, int] = (1100, 720),
    frame_cap_hz: float = FRAME_CAP_HZ,
):
    """A page on the console; with `control`, it takes control (one commander at a time)."""
    return _ready(_load(browser, url, viewport, frame_cap_hz=frame_cap_hz), control)


def open_consoles(browser: object, url: str, *controls: bool) -> list:  # type: ignore[type-arg]
    """Several pages loading at once (each takes ~2.5 s of the browser's time, mostly its own
    renderer's); taken control of in the order given."""
    pages = [_load(browser, url, (1100, 720)) for _ in controls]
    return [_ready(page, control) for page, control in zip(pages, controls, strict=True)]


def _load(  # type: ignore[no-untyped-def]
    browser: object,
    url: str,
    viewport: tuple[int, int],
    csp: bool = False,
    frame_cap_hz: float = FRAME_CAP_HZ,
):
    """A page on `url`. The console's script policy forbids eval, which Playwright's string
    predicates (wait_for_function) use; so pages bypass it unless `csp` (tests of the policy
    itself, which wait by locators instead)."""
    size = {"width": viewport[0], "height": viewport[1]}
    page = browser.new_page(viewport=size, bypass_csp=not csp, frame_cap_hz=frame_cap_hz)  # type: ignore[attr-defined]
    page.goto(url, wait_until="commit")
    return page


def _ready(page, control: bool):  # type: ignore[no-untyped-def]
    page.get_by_role("button", name="Send cmd").wait_for()
    until(page, "document.querySelector('#ptwl-telemetry')?.dataset.seq > 0")
    if control:
        take_control(page)
    return page


def take_control(page) -> None:  # type: ignore[no-untyped-def]
    """Take control; from another page that holds it, through the confirmation it asks for."""
    page.get_by_role("button", name="Take control").click()
    # Control, or the question whether to take it from another operator: whichever comes first
    # (waiting a fixed second for a question that nobody asks cost every page a second).
    asked = (
        "[...document.querySelectorAll('button')]"
        f".some(b => b.offsetParent !== null && b.innerText.includes('{TAKE_FROM}'))"
    )
    until(page, f"{MINE} || {asked}")
    confirm = page.get_by_role("button", name=TAKE_FROM)
    if confirm.count():
        confirm.click()
    until(page, MINE)


MINE = "document.querySelector('#ptwl-control')?.dataset.mine === '1'"
TAKE_FROM = "Take control from them"


def inputs_for(page, label: str):  # type: ignore[no-untyped-def]
    return page.locator(f"xpath=//*[normalize-space(text())='{label}']/ancestor::*[.//input][1]//input")


def set_fields(page, label: str, *values: float) -> None:  # type: ignore[no-untyped-def]
    boxes = inputs_for(page, label)
    for i, value in enumerate(values):
        boxes.nth(i).fill(str(value))
        boxes.nth(i).press("Tab")


def command_status(page) -> str:  # type: ignore[no-untyped-def]
    return page.locator("#ptwl-command").get_attribute("data-status") or ""


def command_id(page) -> str:  # type: ignore[no-untyped-def]
    return page.locator("#ptwl-command").get_attribute("data-id") or ""


def wait_status(page, wanted: str, timeout_s: float = PAGE_WAIT_MS / 1000, after: str | None = None) -> None:  # type: ignore[no-untyped-def]
    """Wait until the command line shows `wanted` for a command other than `after` (the id shown
    before sending: the line is shared, so it may still show an earlier command's exit)."""
    newer = f" && el.dataset.id !== '{after}'" if after is not None else ""
    try:
        until(
            page,
            f"(() => {{ const el = document.querySelector('#ptwl-command');"
            f" return el && el.dataset.status === '{wanted}'{newer}; }})()",
            timeout=timeout_s * 1000,
        )
    except Exception as timed_out:  # say what the page showed instead
        shown = on_screen(page)
        raise AssertionError(f"no {wanted!r} after {after!r} in {timeout_s} s; {shown}") from timed_out


def on_screen(page) -> str:  # type: ignore[no-untyped-def]
    """The command line, the bar and any notifications, as text (for a failing wait's message)."""
    return page.evaluate(
        """() => ['#ptwl-command', '#ptwl-bar', '.mantine-Notification-root']
          .flatMap(s => [...document.querySelectorAll(s)])
          .map(el => (el.id ? el.id + ' ' + JSON.stringify({...el.dataset}) + ': ' : '') + el.innerText)
          .join(' | ')"""
    )


def send(page, button: str) -> str:  # type: ignore[no-untyped-def]
    """Click a send button; the id the command line showed before (for wait_status(after=...))."""
    before = command_id(page)
    page.get_by_role("button", name=button).click()
    return before


def port_mm(page) -> tuple[float, float, float]:  # type: ignore[no-untyped-def]
    match = PORT_TEXT.search(page.locator("#ptwl-telemetry").inner_text())
    assert match, page.locator("#ptwl-telemetry").inner_text()
    return float(match[1]), float(match[2]), float(match[3])


def reset(link: ServiceProcess) -> None:
    httpx.post(link.url + "/api/scene", json={"name": "free_space"}).raise_for_status()
    httpx.put(link.url + "/_link/profile", json={"uplink": 0.0, "downlink": 0.0}).raise_for_status()


def wait_text(page, text: str, timeout_s: float) -> None:  # type: ignore[no-untyped-def]
    until(
        page, f"document.querySelector('#ptwl-bar')?.innerText.includes({text!r})", timeout=timeout_s * 1000
    )


# The floating status window over the view: the rectangle of the first ancestor of the bar that
# is positioned on its own (the window itself, tab header included).
STATUS_WINDOW = """() => {
  let el = document.querySelector('#ptwl-bar');
  while (el && !['absolute', 'fixed'].includes(getComputedStyle(el).position)) el = el.parentElement;
  const r = (el || document.querySelector('#ptwl-bar')).getBoundingClientRect();
  return [r.left, r.top, r.right, r.bottom];
}"""


def view_hsv(page):  # type: ignore[no-untyped-def]
    """The 3D view's pixels as HSV (hue in degrees, saturation and value 0-1); viser's axes
    triad in the bottom-left corner and the status window (as tall as its text, over the view)
    are blanked, their colours being those of the markers."""
    canvas = page.locator("canvas").first
    png = canvas.screenshot()
    hsv = np.asarray(Image.open(io.BytesIO(png)).convert("RGB").convert("HSV"), dtype=float)
    hsv[..., 0] *= 360.0 / 255.0
    hsv[..., 1:] /= 255.0
    hsv[-100:, :100] = 0.0
    box = canvas.bounding_box()
    left, top, right, bottom = (round(v) for v in page.evaluate(STATUS_WINDOW))
    x0, y0 = round(box["x"]), round(box["y"])
    hsv[max(0, top - y0) : max(0, bottom - y0), max(0, left - x0) : max(0, right - x0)] = 0.0
    return hsv


def pixels_of_hue(hsv, low_deg: float, high_deg: float, min_saturation: float) -> int:  # type: ignore[no-untyped-def]
    """How many pixels have a hue in [low, high] and are coloured (not grey, not dark)."""
    hue, saturation, value = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    return int(((hue >= low_deg) & (hue <= high_deg) & (saturation > min_saturation) & (value > 0.2)).sum())
