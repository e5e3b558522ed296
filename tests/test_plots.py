"""The force/torque plots' data as the console sends it, a replay's seek, and the recording read
for it (no browser: tests/test_plots_browser.py looks at the canvases).

Issue 27: a change of a uPlot's `series` after it is made blanks the plot in viser's client (its x
window is lost when the chart is rebuilt), so the series are set once and the threshold lines are
moved off the plot instead of hidden; and after a replay's seek the plots hold the recording up to
the new time, not one state."""

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import simulate
from ptwl.recording import topics
from ptwl.recording.reader import read
from ptwl.recording.replay.timeline import Timeline
from web import plots as plots_module
from web.plots import WrenchPlots
from web.replay_marks import marks_html, slider_marks
from web.replay_record import CommandSpan, ReplayRecord

HZ = 50.0


class FakeHandle:
    """A viser handle that keeps what was set on it, and how often."""

    def __init__(self, **props: Any) -> None:
        self.__dict__["sets"] = {}
        self.__dict__.update(props)

    def __setattr__(self, name: str, value: Any) -> None:
        self.sets[name] = self.sets.get(name, 0) + 1
        self.__dict__[name] = value


class FakeGui:
    def add_uplot(self, data: Any, series: Any, **props: Any) -> FakeHandle:
        return FakeHandle(data=data, series=series, **props)

    def add_html(self, content: str, order: float | None = None) -> FakeHandle:
        return FakeHandle(content=content)


def attribute(plots: WrenchPlots, name: str) -> str:
    content = str(plots.summary.content)
    return content.split(f'data-{name}="', 1)[1].split('"', 1)[0]


def contact(plots: WrenchPlots, t0: float, t1: float, force_n: float) -> None:
    for t in np.arange(t0, t1, 1.0 / HZ):
        plots.add(float(t), [0.2, -0.1, force_n, 0.01, 0.02, 0.0])


def test_thresholds_come_and_go_without_a_change_of_series_and_never_as_nan() -> None:
    plots = WrenchPlots(FakeGui(), 10.0)  # type: ignore[arg-type]
    series = plots.force.handle.series
    contact(plots, 0.0, 2.0, 0.0)
    plots.refresh()
    plots.set_thresholds((60.0, 10.0))  # a PTWL starts: its lines appear
    contact(plots, 2.0, 4.0, 25.0)
    plots.refresh()
    data = plots.force.handle.data
    assert float(data[3][-1]) == 25.0  # z, as sent
    assert np.all(data[4] == 60.0) and np.all(data[5] == -60.0)  # the lines at +-threshold
    lo, hi = plots.force.y_range
    assert lo <= -60.0 and hi >= 60.0  # and in the range (the invisible range series hold it)
    assert np.all(data[7] == lo) and np.all(data[8] == hi)
    plots.set_thresholds(None)  # it ends: the lines go off the plot, far above and below it
    plots.refresh()
    data = plots.force.handle.data
    lo, hi = plots.force.y_range
    assert np.all(data[4] > hi + 5 * (hi - lo)) and np.all(data[5] < lo - 5 * (hi - lo))
    for handle in (plots.force.handle, plots.torque.handle):
        assert "series" not in handle.sets  # never sent again: viser would rebuild the chart
        assert all(np.all(np.isfinite(column)) for column in handle.data)
    assert plots.force.handle.series is series
    limit_series = [s for s in series if s["label"] in ("limit", "-limit")]
    assert len(limit_series) == 2 and all(s["auto"] is False and "show" not in s for s in limit_series)


def test_a_seek_holds_the_recording_up_to_the_new_time_until_the_stream_is_there(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    clock = [100.0]
    monkeypatch.setattr(plots_module.time, "monotonic", lambda: clock[0])
    plots = WrenchPlots(FakeGui(), 10.0)  # type: ignore[arg-type]
    contact(plots, 0.0, 20.0, 1.0)  # played up to 20 s
    samples = [(t, [0.0, 0.0, 25.0, 0.0, 0.0, 0.0]) for t in np.arange(0.0, 5.0001, 1.0 / HZ)]
    plots.jump([(float(t), w) for t, w in samples], [1.0, 3.0])  # a seek back to 5 s, paused
    assert attribute(plots, "samples") == str(len(samples)) == "251"
    assert attribute(plots, "t1") == "5.000" and attribute(plots, "marks") == "2"
    assert attribute(plots, "force") == "25.00" and attribute(plots, "jumps") == "1"
    plots.add(20.02, [0.0] * 6)  # from before the seek, still on its way: not plotted
    plots.add(19.0, [0.0] * 6)  # nor does an earlier one clear the plots
    plots.refresh()
    assert attribute(plots, "samples") == "251" and attribute(plots, "t1") == "5.000"
    plots.add(5.0, [0.0, 0.0, 25.0, 0.0, 0.0, 0.0])  # the stream at the new time (a repeat)
    plots.add(5.02, [0.0, 0.0, 25.0, 0.0, 0.0, 0.0])  # and on, playing
    plots.refresh()
    assert attribute(plots, "samples") == "252" and attribute(plots, "t1") == "5.020"
    # A jump the stream never reaches stops waiting after AWAIT_S.
    plots.jump([(1.0, [0.0] * 6), (2.0, [0.0] * 6)], [])
    plots.add(30.0, [0.0] * 6)
    clock[0] += plots_module.AWAIT_S + 0.1
    plots.add(30.02, [0.0] * 6)
    plots.refresh()
    assert attribute(plots, "t1") == "30.020"


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("plots") / "trial.mcap"
    simulate(TrialSpec("quick_connect", "onboard", 0.0, 0.0, 0.0, 0, think_s=0.0), record=path)
    return path


def test_the_recording_read_for_a_seek_and_for_the_timeline(recording: Path) -> None:
    record = ReplayRecord(recording)
    timeline = Timeline(recording)
    start_s = timeline.start_ns / 1e9
    done = [m.value for m in read(recording).on(topics.COMMANDS.name) if m.value["status"] == "done"]
    assert [(c.start_s, c.end_s, c.exit) for c in record.commands] == [
        pytest.approx((d["started_at"] - start_s, d["ended_at"] - start_s, d["exit"])) for d in done
    ]
    assert record.duration_s == timeline.duration_s
    position_s = record.duration_s / 2
    window = record.window(position_s, 10.0)
    at = timeline.state_at(timeline.start_ns + int(position_s * 1e9))
    sim_times = [t for t, _ in window.samples]
    assert sim_times[-1] == at["sim_time"] and window.samples[-1][1] == at["wrench"]
    assert np.all(np.diff(sim_times) > 0)
    assert len(sim_times) == pytest.approx(HZ * sim_times[-1], abs=2)  # all of it (under 10 s)
    assert window.marks_s == [pytest.approx(sim_times[0], abs=0.021)]  # the machine's start
    assert window.thresholds is None  # a state machine's own params have none
    short = record.window(position_s, 1.0)  # only the last second and a half of log time
    assert len(short.samples) == pytest.approx(1.5 * HZ, abs=2) and short.marks_s == []


def test_the_marks_sit_where_the_commands_ran_as_fractions_of_the_recording() -> None:
    commands = [
        CommandSpan(1, "PTWL #…0001", 1.0, 3.0, "timeout"),
        CommandSpan(2, "<b>x</b>", 6.0, None, None),  # still running when the recording ends
    ]
    html = str(marks_html(commands, 10.0, 2.5, ""))
    assert 'data-count="2"' in html and 'data-starts="0.1000,0.6000"' in html
    assert 'data-ends="0.3000,1.0000"' in html and 'data-position="0.2500"' in html
    assert 'data-exits="timeout,running"' in html and "<b>x</b>" not in html  # labels escaped
    assert slider_marks(commands, 10.0) == ((0.0, "0"), (10.0, "10.0 s"), (1.0, "1"), 3.0, (6.0, "2"))
    assert 'data-count=""' in str(marks_html(None, 10.0, 0.0, "reading the recording"))
