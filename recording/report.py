"""`ptwl report FILE.mcap`: the paper's per-trial figures (Tables 1-3) from a recording.

A trial is what ran on one scene load: from a geometry record (start, reset, a fault's reload)
to the next. Its figures come from the behaviors it ran (`/steps`, each with its sim-time start,
end and peaks) by the same rule the tasks and sweeps use (robot_sim.policies.run), and its
success from the scene's predicate in the last telemetry before the next load.
"""

from dataclasses import dataclass, field
from typing import Any

from recording import topics
from recording.reader import Recording
from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose
from robot_sim.policies.run import paper_rows, report_metrics


@dataclass
class RecordedTrial:
    scene: str
    start_ns: int
    steps: list[dict[str, Any]] = field(default_factory=list)
    task: dict[str, Any] | None = None  # the last /task message

    @property
    def success(self) -> bool:
        return bool(self.task and self.task.get("success"))

    def metrics(self) -> dict[str, Any]:
        return report_metrics([_report(step) for step in self.steps])


def trials(recording: Recording) -> list[RecordedTrial]:
    """Every scene load that ran at least one behavior, in order."""
    found: list[RecordedTrial] = []
    for message in recording.messages:
        if message.topic == topics.GEOMETRY.name:
            found.append(RecordedTrial(message.value["scene"], message.log_time_ns))
        elif message.topic == topics.STEPS.name and found:
            found[-1].steps.append(message.value)
        elif message.topic == topics.TASK.name and found:
            found[-1].task = message.value
    return [t for t in found if t.steps]


def report_text(recording: Recording) -> str:
    found = trials(recording)
    source = recording.metadata.get("ptwl", {}).get("source", "unknown source")
    lines = [f"{recording.path}: {source}, {len(recording.messages)} messages"]
    if not recording.complete:
        lines.append(f"  cut short ({recording.problem or 'no end record'}): read up to the last whole chunk")
    if not found:
        lines.append("  no behavior ran: nothing to report")
        return "\n".join(lines) + "\n"
    columns = [dict(paper_rows([t.metrics()], [t.success])) for t in found]
    headers = [f"trial {i + 1} ({t.scene})" for i, t in enumerate(found)]
    labels = [label for label, _ in paper_rows([found[0].metrics()], [True]) if label != "Trials"]
    width = max(len(label) for label in labels)
    widths = [max(len(h), 10) for h in headers]
    lines.append("")
    lines.append(" " * width + " | " + " | ".join(h.rjust(w) for h, w in zip(headers, widths, strict=True)))
    lines.append("-" * width + "-|-" + "-|-".join("-" * w for w in widths))
    for label in labels:
        cells = [
            ("yes" if t.success else "no") if label == "Success" else c[label]
            for t, c in zip(found, columns, strict=True)
        ]
        lines.append(
            label.ljust(width) + " | " + " | ".join(v.rjust(w) for v, w in zip(cells, widths, strict=True))
        )
    return "\n".join(lines) + "\n"


def report_json(recording: Recording) -> list[dict[str, Any]]:
    return [
        {"scene": t.scene, "success": t.success, "task": t.task, **t.metrics()} for t in trials(recording)
    ]


def _report(step: dict[str, Any]) -> BehaviorReport:
    """A recorded step (StepRecord.as_dict()) as the report it was made from."""
    port = step.get("final_port") or {"position": [0.0] * 3, "quaternion": [1.0, 0.0, 0.0, 0.0]}
    return BehaviorReport(
        behavior=step["behavior"],
        exit=ExitCondition(step["exit"]),
        started_at=step["started_at"],
        ended_at=step["ended_at"],
        peak_force=_number(step.get("peak_force")),
        peak_torque=_number(step.get("peak_torque")),
        final_wrench=tuple(step.get("final_wrench") or [0.0] * 6),
        final_port=Pose(tuple(port["position"]), tuple(port["quaternion"])),
        detail=step.get("detail", ""),
    )


def _number(value: float | None) -> float:
    return float("nan") if value is None else float(value)
