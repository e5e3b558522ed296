"""Optional per-message record, one JSON object a line.

Line-buffered: each record reaches the file as it is written, so a crash (kill -9) loses at most
the line being written. At 2 x 50 Hz telemetry that is ~100 write calls a second, nothing next
to the proxy's own work.
"""

import json
from pathlib import Path
from typing import IO

from latency.delay_line import Dropped, Entry


class Recorder:
    def __init__(self, path: Path) -> None:
        self._file: IO[str] = path.open("a", buffering=1)

    def released(self, entry: Entry, now: float) -> None:
        self._write(
            {
                "seq": entry.seq,
                "direction": entry.direction,
                "kind": entry.kind,
                "size": entry.size,
                "arrival": entry.arrival,
                "release": now,
                "configured_delay": entry.configured_delay,
                "realized_delay": now - entry.arrival,
                "profile_version": entry.version,
                "drop_reason": None,
            }
        )

    def dropped(self, drop: Dropped) -> None:
        self._write(
            {
                "seq": drop.seq,
                "direction": drop.direction,
                "kind": drop.kind,
                "size": drop.size,
                "arrival": drop.arrival,
                "release": None,
                "configured_delay": None,
                "realized_delay": None,
                "profile_version": drop.version,
                "drop_reason": drop.reason,
            }
        )

    def _write(self, record: dict[str, object]) -> None:
        self._file.write(json.dumps(record) + "\n")

    def close(self) -> None:
        self._file.close()
