"""What a link's per-message record says of the schedule's effect: per direction, how many
messages it released and dropped (and why), how long they waited for each reason (delay, a
contact gap, the rate's queue and serialisation, a blackout, order), and how late the proxy let
them go against their scheduled release. Streamed: sums and maxima, whatever the file's size."""

from collections import Counter, defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from ptwl.recording import topics
from ptwl.recording.reader import Recorded


@dataclass
class Wait:
    messages: int = 0
    total_s: float = 0.0
    max_s: float = 0.0

    def add(self, seconds: float) -> None:
        self.messages += 1
        self.total_s += seconds
        self.max_s = max(self.max_s, seconds)


@dataclass
class DirectionSummary:
    released: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    waits: dict[str, Wait] = field(default_factory=lambda: defaultdict(Wait))
    late: Wait = field(default_factory=Wait)  # release - scheduled release

    def add(self, record: dict[str, Any]) -> None:
        if record.get("release") is None:
            self.dropped[str(record.get("drop_reason"))] += 1
            return
        self.released += 1
        for reason, seconds in (record.get("why") or {}).items():
            self.waits[reason].add(float(seconds))
        if record.get("scheduled_release") is not None:
            self.late.add(max(0.0, float(record["release"]) - float(record["scheduled_release"])))


class LinkSummary:
    def __init__(self) -> None:
        self.directions: dict[str, DirectionSummary] = defaultdict(DirectionSummary)

    def tally(self, messages: Iterable[Recorded]) -> Iterator[Recorded]:
        """Pass every message on, counting the link's as they go by."""
        for message in messages:
            if message.topic == topics.LINK.name and isinstance(message.value, dict):
                self.directions[str(message.value.get("direction"))].add(message.value)
            yield message

    def lines(self) -> list[str]:
        out = []
        for name, d in sorted(self.directions.items()):
            dropped = ", ".join(f"{r} {n}" for r, n in sorted(d.dropped.items())) or "none"
            out.append(f"  {name}: {d.released} released, dropped: {dropped}")
            for reason, w in d.waits.items():  # in the order first seen
                if w.messages:
                    out.append(
                        f"    waited for {reason}: {w.messages} messages, "
                        f"mean {w.total_s / w.messages:.3f} s, "
                        f"max {w.max_s:.3f} s"
                    )
            if d.late.messages:
                mean_ms = 1000.0 * d.late.total_s / d.late.messages
                out.append(f"    released late by mean {mean_ms:.2f} ms, max {1000.0 * d.late.max_s:.2f} ms")
        return ["", "link (its per-message record):", *out] if out else []
