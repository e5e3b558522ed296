"""The force/torque plots draw what the robot reports, in contact and in a replay (issue 27), in a
real browser; a replay's timeline marks its commands.

On main the force plot went blank in a 25 N jam while the readout said "|f| 25.01 N": showing or
hiding a command's threshold lines changed the chart's `series`, viser's client rebuilt the chart,
and its effect that keeps the x window relative to the data read the new chart's unset x scale as
0 and 1: from then on the plot showed a ~1 s window seconds before the data (web/plots.py). Here
the pixels of the trace colours on the plots' canvases are counted while the arm pushes into the
plate under a running PTWL's thresholds, and again after the command has ended.
"""

import io
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image

from ptwl.launcher import ServiceProcess, free_port, running, running_console, running_proxy, running_server
from ptwl.recording import topics
from ptwl.recording.reader import read
from ptwl.recording.replay.timeline import Timeline
from server.client import RobotClient
from tests.console_page import _load, inputs_for, open_console, pixels_of_hue, until

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

GAP_TO_PLATE_M = 0.0466 - 0.008  # [m] port above the plate at home, minus the tip radius (test_ptwl)
PAST_PLATE_M = 0.0125  # [m] the goal under the plate's surface: 2000 N/m x 12.5 mm = 25 N
FORCE_THRESHOLD_N = 100.0  # high: the jam (and its impact) holds, running, with its threshold lines shown
BLUE_DEG = (198.0, 218.0)  # z, #1971c2 (hue 208): the jam's axis
ORANGE_DEG = (28.0, 42.0)  # the threshold lines, #f08c00 (hue 35)
DRAWN_PX = 120  # a trace across the plot is >= ~240 px; a blank plot has 0


@pytest.fixture(scope="module")
def surface() -> Iterator[tuple[ServiceProcess, ServiceProcess, ServiceProcess]]:
    with (
        running_server("--scene", "surface") as robot,
        running_proxy(robot.url) as link,
        running_console(link.url) as console,
    ):
        yield robot, link, console


def plot(page, key: str) -> str:  # type: ignore[no-untyped-def]
    return page.locator("#ptwl-plot").get_attribute(f"data-{key}") or ""


def canvas_pixels(page, index: int, hue_deg: tuple[float, float]) -> int:  # type: ignore[no-untyped-def]
    """Pixels of a hue on plot `index`'s canvas (0: force, 1: torque), as the screen shows it."""
    png = page.locator(".uplot canvas").nth(index).screenshot()
    hsv = np.asarray(Image.open(io.BytesIO(png)).convert("RGB").convert("HSV"), dtype=float)
    hsv[..., 0] *= 360.0 / 255.0
    hsv[..., 1:] /= 255.0
    return pixels_of_hue(hsv, *hue_deg, min_saturation=0.3)


def test_the_force_plot_draws_a_25_n_jam_and_after_its_command_ends(browser, surface) -> None:  # type: ignore[no-untyped-def]
    _, link, console = surface
    page = open_console(browser, console.url, control=False, viewport=(1366, 768))
    assert page.locator(".uplot canvas").count() == 2
    until(page, "Number(document.querySelector('#ptwl-plot')?.dataset.t1) > 1")
    jam = {
        "type": "ptwl",
        "translation": [0.0, 0.0, GAP_TO_PLATE_M + PAST_PLATE_M],  # tool z points down
        "duration": 2.0,
        "watchdog": 30.0,  # the goal is out of reach: it pushes until the watchdog (or STOP, below)
        "force_threshold": FORCE_THRESHOLD_N,
        "torque_threshold": 10.0,
        "sent_at": time.time(),
    }
    httpx.post(link.url + "/api/commands", json=jam, timeout=10.0).raise_for_status()
    until(
        page,
        "(() => { const el = document.querySelector('#ptwl-plot');"
        f" return el?.dataset.threshold === '{FORCE_THRESHOLD_N}' && Number(el.dataset.force) > 20; }})()",
    )
    time.sleep(1.0)  # ten refreshes in contact, the first ones just after the threshold lines came
    force = float(plot(page, "force"))
    assert 20.0 < force < 30.0  # the jam, as the readout says
    in_contact = {
        "force z": canvas_pixels(page, 0, BLUE_DEG),
        "force limits": canvas_pixels(page, 0, ORANGE_DEG),
        "torque z": canvas_pixels(page, 1, BLUE_DEG),
    }
    assert float(plot(page, "t1")) - float(plot(page, "t0")) > 2.0  # seconds of samples held
    assert plot(page, "threshold") == f"{FORCE_THRESHOLD_N}"  # still running: its lines are due
    assert min(in_contact.values()) > DRAWN_PX, in_contact
    # The command ends (STOP): the lines go, the traces stay.
    httpx.post(link.url + "/api/stop", timeout=10.0).raise_for_status()
    until(page, "document.querySelector('#ptwl-plot')?.dataset.threshold === ''")
    time.sleep(1.0)
    after = {
        "force z": canvas_pixels(page, 0, BLUE_DEG),
        "force limits": canvas_pixels(page, 0, ORANGE_DEG),
        "torque z": canvas_pixels(page, 1, BLUE_DEG),
    }
    page.close()
    assert after["force z"] > DRAWN_PX and after["torque z"] > DRAWN_PX, after
    assert after["force limits"] == 0, after  # no threshold applies: no dashed lines


@pytest.fixture(scope="module")
def jam_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """~6 s: at rest, the jam (it times out after 3 s at ~25 N), a PTWL up (goal reached), rest."""
    path = tmp_path_factory.mktemp("jam") / "jam.mcap"
    with (
        running_server("--scene", "surface", "--record", str(path)) as robot,
        RobotClient(robot.url) as client,
    ):
        time.sleep(0.5)
        jam = client.ptwl(
            translation=[0.0, 0.0, GAP_TO_PLATE_M + PAST_PLATE_M],
            duration=1.0,
            watchdog=3.0,
            force_threshold=FORCE_THRESHOLD_N,
            torque_threshold=10.0,
        )
        assert client.wait(jam.id, timeout=20.0).exit == "timeout"
        up = client.ptwl(translation=[0.0, 0.0, -0.03], duration=1.0, force_threshold=40.0)
        assert client.wait(up.id, timeout=20.0).exit == "goal_reached"
        time.sleep(0.5)
    return path


def seek(page, position_s: float, sim_time_at) -> float:  # type: ignore[no-untyped-def]
    """Type a time into the slider's box (a browser's own move: a seek); wait until the plots end
    at the state there, filled from the recording. The time typed (to the slider's 0.01 s).

    The plots' jump count must grow too: between the seek and the fill, the stream's one state
    at the new time can already stand alone on the plots (t1 right, the window not yet filled)."""
    typed = round(position_s, 2)
    jumps = int(plot(page, "jumps") or 0)
    inputs_for(page, "Time [s]").last.fill(f"{typed:.2f}")
    until(
        page,
        f"Math.abs(Number(document.querySelector('#ptwl-plot')?.dataset.t1) - {sim_time_at(typed)}) < 0.001"
        f" && Number(document.querySelector('#ptwl-plot')?.dataset.jumps) > {jumps}",
    )
    return typed


def test_replay_marks_its_commands_and_plots_after_seeks_while_paused(browser, jam_recording) -> None:  # type: ignore[no-untyped-def]
    timeline = Timeline(jam_recording)
    start_s, duration_s = timeline.start_ns / 1e9, timeline.duration_s
    done = [m.value for m in read(jam_recording).on(topics.COMMANDS.name) if m.value["status"] == "done"]
    expected_starts = [(c["started_at"] - start_s) / duration_s for c in done]
    expected_ends = [(c["ended_at"] - start_s) / duration_s for c in done]
    jam_start_s = done[0]["started_at"] - start_s

    def sim_time_at(position_s: float) -> float:
        return float(timeline.state_at(timeline.start_ns + int(position_s * 1e9))["sim_time"])

    def recorded_until(position_s: float) -> int:
        """How many states the recording holds up to `position_s` into it."""
        at_ns = timeline.start_ns + int(position_s * 1e9)
        return int(np.searchsorted(timeline.telemetry.times_ns, at_ns, side="right"))

    port = free_port()
    with running(
        "replay", str(jam_recording), "--port", str(port), "--paused", health="/", startup_timeout=90.0
    ):
        page = _load(browser, f"http://127.0.0.1:{port}", (1366, 768))
        until(page, "document.querySelector('#ptwl-replay-marks')?.dataset.count === '2'")
        strip = page.locator("#ptwl-replay-marks")
        starts = [float(v) for v in (strip.get_attribute("data-starts") or "").split(",")]
        ends = [float(v) for v in (strip.get_attribute("data-ends") or "").split(",")]
        assert starts == pytest.approx(expected_starts, abs=0.002)
        assert ends == pytest.approx(expected_ends, abs=0.002)
        assert strip.get_attribute("data-exits") == "timeout,goal_reached"
        # On the slider itself: its two ends, each start (numbered) and each end.
        assert page.locator(".mantine-Slider-mark").count() == 6
        assert {"1", "2"} <= set(page.locator(".mantine-Slider-markLabel").all_inner_texts())

        # Paused, into the jam: the plots hold the recording up to there, thresholds and all.
        in_jam_s = seek(page, jam_start_s + 2.0, sim_time_at)
        # Every state the recording holds from its start: counted in the recording, not assumed at
        # 50 Hz (a server recording beside a busy test fell to 43 states/s once).
        assert int(plot(page, "samples")) == pytest.approx(recorded_until(in_jam_s), abs=1)
        assert 20.0 < float(plot(page, "force")) < 30.0
        assert plot(page, "threshold") == f"{FORCE_THRESHOLD_N}" and plot(page, "marks") == "1"
        time.sleep(1.0)  # paused: the same state comes again and again, and changes nothing
        assert int(plot(page, "samples")) == pytest.approx(recorded_until(in_jam_s), abs=1)
        drawn = {
            "force z": canvas_pixels(page, 0, BLUE_DEG),
            "force limits": canvas_pixels(page, 0, ORANGE_DEG),
        }
        assert min(drawn.values()) > DRAWN_PX, drawn

        # Played through both commands' ends (the thresholds change twice, then go) to the end: drawn.
        page.get_by_role("button", name="Play").click()
        until(page, "document.querySelector('#ptwl-plot')?.dataset.threshold === '40.0'")
        until(page, "document.querySelector('#ptwl-plot')?.dataset.threshold === ''")
        # The recording ends half a second later: there the replay stops by itself.
        until(page, "document.querySelector('#ptwl-replay')?.dataset.playing === '0'")
        time.sleep(0.3)  # the next refresh
        played = {
            "force z": canvas_pixels(page, 0, BLUE_DEG),
            "force limits": canvas_pixels(page, 0, ORANGE_DEG),
        }
        assert played["force z"] > DRAWN_PX and played["force limits"] == 0, played

        # Paused, back to the end of the jam: the window ends there, with its threshold.
        seek(page, done[0]["ended_at"] - start_s - 0.2, sim_time_at)
        assert plot(page, "threshold") == f"{FORCE_THRESHOLD_N}" and 20.0 < float(plot(page, "force")) < 30.0
        drawn = {
            "force z": canvas_pixels(page, 0, BLUE_DEG),
            "force limits": canvas_pixels(page, 0, ORANGE_DEG),
        }
        page.close()
    assert min(drawn.values()) > DRAWN_PX, drawn
