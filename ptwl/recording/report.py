"""`ptwl report FILE.mcap`: the paper's per-trial figures (Tables 1-3) from a recording.

A trial is what ran on one scene load: from a geometry record (start, reset, a fault's reload)
to the next. Its figures come from the behaviors it ran (`/steps`, each with its sim-time start,
end and peaks) by the same rule the tasks and sweeps use (robot_sim.policies.run), and its
success from the scene's predicate in the last telemetry before the next load.

The file is streamed: only its scene loads, steps and task records are decoded, and a trial's
steps are let go once its figures are made, so memory holds one trial's steps at a time.
"""

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ptwl.recording import topics
from ptwl.recording.link_summary import LinkSummary
from ptwl.recording.reader import Recorded, Recording, RecordingError, Scan
from robot_sim.behaviors import BehaviorReport
from robot_sim.finite import report_from_json
from robot_sim.policies.paper_tables import beside_paper, text_table
from robot_sim.policies.run import paper_rows, report_metrics

REPORTED = (topics.GEOMETRY.name, topics.STEPS.name, topics.TASK.name, topics.LINK.name)  # all it decodes
# A trial's steps are held until it ends; our state machines take tens, a ground operator a few
# hundred. A file with more is refused rather than held (each decoded step is ~2 KB).
MAX_TRIAL_STEPS = 10_000


@dataclass
class RecordedTrial:
    scene: str
    start_ns: int
    steps: list[dict[str, Any]] = field(default_factory=list)
    task: dict[str, Any] | None = None  # the last /task message
    figures: dict[str, Any] | None = None  # its metrics, made when the trial ended

    @property
    def success(self) -> bool:
        return bool(isinstance(self.task, dict) and self.task.get("success"))

    def metrics(self) -> dict[str, Any]:
        if self.figures is None:
            try:
                self.figures = report_metrics([_report(step) for step in self.steps])
            except (KeyError, TypeError, ValueError, AttributeError, IndexError) as err:
                raise RecordingError(
                    f"a /steps message of the {self.scene} trial at {self.start_ns} ns is no ptwl.Step "
                    f"({type(err).__name__}: {err})"
                ) from None
        return self.figures


@dataclass
class Summary:
    """What a report says of a file: where it came from, how much it holds, its trials."""

    path: Path
    metadata: dict[str, dict[str, str]]
    complete: bool
    problem: str
    count: int  # messages in the file, every topic
    trials: list[RecordedTrial]
    link: LinkSummary = field(default_factory=LinkSummary)  # a link's record in it, if any


def summarize(source: Path | Recording) -> Summary:
    """A file, streamed; or a recording already read (tests)."""
    link = LinkSummary()
    if isinstance(source, Recording):
        found = _named(source.path, lambda: trials(link.tally(source.messages)))
        return Summary(
            source.path, source.metadata, source.complete, source.problem, source.count, found, link
        )
    scan = Scan(source, REPORTED)
    found = _named(source, lambda: trials(link.tally(scan)))
    return Summary(source, scan.metadata, scan.complete, scan.problem, scan.count, found, link)


def trials(messages: Iterable[Recorded] | Recording) -> list[RecordedTrial]:
    """Every scene load that ran at least one behavior, in order, its figures made."""
    if isinstance(messages, Recording):
        messages = messages.messages
    found: list[RecordedTrial] = []

    def end_trial() -> None:  # its figures made and its steps let go; a load that ran nothing dropped
        if found and found[-1].figures is None:
            if found[-1].steps:
                found[-1].metrics()
                found[-1].steps = []
            else:
                found.pop()

    for message in messages:
        value = message.value
        if message.topic == topics.GEOMETRY.name:
            if not isinstance(value, dict) or not isinstance(value.get("scene"), str):
                raise RecordingError(
                    f"the {message.topic} message at {message.log_time_ns} ns names no scene"
                )
            end_trial()
            found.append(RecordedTrial(value["scene"], message.log_time_ns))
        elif message.topic == topics.STEPS.name and found:
            if len(found[-1].steps) >= MAX_TRIAL_STEPS:
                raise RecordingError(
                    f"the {found[-1].scene} trial at {found[-1].start_ns} ns has over {MAX_TRIAL_STEPS} steps"
                )
            found[-1].steps.append(value)
        elif message.topic == topics.TASK.name and found:
            found[-1].task = value
    end_trial()
    return found


def report_text(source: Path | Recording) -> str:
    summary = summarize(source)
    found = summary.trials
    source_name = summary.metadata.get("ptwl", {}).get("source", "unknown source")
    lines = [f"{summary.path}: {source_name}, {summary.count} messages"]
    if not summary.complete:
        lines.append(f"  cut short ({summary.problem or 'no end record'}): read up to the last whole chunk")
    lines += summary.link.lines()
    if not found:
        lines.append("  no behavior ran: no trials to report")
        return "\n".join(lines) + "\n"
    columns = [
        dict(paper_rows([t.metrics()], [t.success]), Success="yes" if t.success else "no") for t in found
    ]
    headers = [f"trial {i + 1} ({t.scene})" for i, t in enumerate(found)]
    labels = [label for label, _ in paper_rows([found[0].metrics()], [True]) if label != "Trials"]
    lines += ["", *text_table(labels, headers, columns)]
    for scene in dict.fromkeys(t.scene for t in found):  # each scene once, in order
        same = [t for t in found if t.scene == scene]
        ours = paper_rows([t.metrics() for t in same], [t.success for t in same])
        beside = beside_paper(scene, ours, f"this file ({len(same)})")
        lines += ["", *beside] if beside else []
    return "\n".join(lines) + "\n"


def report_json(source: Path | Recording) -> list[dict[str, Any]]:
    return [
        {"scene": t.scene, "success": t.success, "task": t.task, **t.metrics()}
        for t in summarize(source).trials
    ]


def _named(path: Path, make: Callable[[], list[RecordedTrial]]) -> list[RecordedTrial]:
    """The trials, or an error that names the file (the reader's errors already do)."""
    try:
        found = make()
    except RecordingError as err:
        if str(err).startswith(f"{path}:"):
            raise
        raise RecordingError(f"{path}: {err}") from None
    return found


def _report(step: dict[str, Any]) -> BehaviorReport:
    """A recorded step (StepRecord.as_dict()) as the report it was made from."""
    return report_from_json(step, step["started_at"], step["ended_at"])
