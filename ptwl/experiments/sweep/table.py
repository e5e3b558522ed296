"""trials.csv: one row per trial, its columns and types, appended as trials end, read back.

A row is written whole (one write, then flush), so an interrupted sweep leaves complete rows
only; a final line without its newline (a kill mid-write) is ignored when read back. Before a
sweep appends, and when it ends, the file is rewritten in grid order (to a temporary file, then
renamed): the header and whole rows only, so the same arguments give the same bytes whatever
the number of workers or backend.
"""

import csv
import io
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from ptwl.experiments.sweep.spec import KEY_FIELDS, cell


def _optional_str(text: str) -> str | None:
    return text or None


def _optional_float(text: str) -> float | None:
    return float(text) if text else None


def _bool(text: str) -> bool:
    return text == "1"


# name, parser, meaning (docs/sweeps.md points here for the columns)
COLUMNS: list[tuple[str, Callable[[str], Any], str]] = [
    ("task", str, "the task (its scene and state machine)"),
    ("operator", str, "ground (move-and-wait, one behavior per round trip) or onboard (one state machine)"),
    ("autonomy", _optional_str, "onboard: the machine's autonomy level (off, low, high, full; empty: full)"),
    (
        "rtt_s",
        float,
        "[s] round trip, half each way; when the schedule has delay points they set the delay, and this is "
        "twice their mean one-way delay over their span",
    ),
    ("jitter_s", float, "[s] uniform +- on each message's delay"),
    ("loss", float, "chance an event (WebSocket message) is lost"),
    ("seed", int, "the scene's misalignments and every draw of the trial"),
    ("think_s", float, "[s] the operator's mean think time between commands"),
    (
        "profile",
        _optional_str,
        "named link profile whose blackouts, schedule, rates, jitter and loss applied (not its delays)",
    ),
    ("max_age_s", _optional_float, "[s] every command's max_age (empty: commands never expire)"),
    ("machine", _optional_str, "the machine file run instead of the task's built-in one (empty: built-in)"),
    ("schedule", _optional_str, "the schedule file (TOML or ION plan) replacing the profile's (empty: none)"),
    (
        "plan_offset_s",
        float,
        "[s] how far into its schedule and blackouts the link was at the trial's start: seeded, uniform "
        "over the period (else up to the last contact's end), whole ms; 0 with neither",
    ),
    ("success", _bool, "the scene's predicate when the operator learned the outcome"),
    ("progress", float, "the predicate's progress value then (depth, angle, error: its unit)"),
    ("end", str, "how the machine ended: completed, failed, aborted, fault, timed_out; expired: gave up"),
    ("why", str, "the machine's reason"),
    ("task_time_s", float, "[s] on the robot, first behavior's start to last one's end"),
    ("operator_time_s", float, "[s] from the first send until the operator knew the outcome"),
    ("commands_sent", int, "POSTs, resends included"),
    ("wait_cycles", int, "commands the operator waited for (move-and-wait cycles)"),
    ("requeries", int, "status questions after a report was overdue (onboard: every 10 s)"),
    ("unstarted", int, "commands that ended without running (expired), each sent again"),
    (
        "decisions_waited",
        int,
        "decisions the onboard machine waited for the operator on (its autonomy level)",
    ),
    ("decision_wait_s", float, "[s] on the robot, waiting for those decisions in total"),
    ("think_total_s", float, "[s] thought in total"),
    ("max_force_n", float, "[N] peak |f| on the port"),
    ("mean_force_n", float, "[N] mean |f| over the task time"),
    ("max_torque_nm", float, "[N m] peak |tau|"),
    ("mean_torque_nm", float, "[N m] mean |tau| over the task time"),
    ("behaviors", int, "behaviors run (the gripper apart)"),
    ("rwe", int, "RWEs"),
    ("dither", int, "Dithers"),
    ("gripper", int, "gripper closes and opens"),
    ("ptwl_timeout", int, "PTWLs that ended timeout"),
    ("ptwl_goal_reached", int, "PTWLs that ended goal_reached"),
    ("ptwl_wrench_breach", int, "PTWLs that ended wrench_breach"),
    ("lost_messages", int, "messages the link lost (loss, drop blackouts)"),
    ("blackout_s", float, "[s] of the trial inside blackout windows"),
    ("los_s", float, "[s] of the trial with either direction closed (a contact gap or a blackout)"),
    ("los_in_trial", _bool, "a loss of signal fell inside the trial (los_s > 0)"),
]
NAMES = [name for name, _, _ in COLUMNS]


def row_key(row: dict[str, Any]) -> tuple[str, ...]:
    return tuple(cell(row[name]) for name in KEY_FIELDS)


def _line(row: dict[str, Any]) -> str:
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerow([cell(row[name]) for name in NAMES])
    return out.getvalue()


def read_rows(path: Path) -> list[dict[str, Any]]:
    """The complete rows of an existing trials.csv (typed), or [] if there is none."""
    if not path.exists():
        return []
    text = path.read_text()
    if not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # a line cut short by a kill
    reader = csv.reader(io.StringIO(text))
    header = next(reader, None)
    if header is None:
        return []
    if header != NAMES:
        raise ValueError(f"{path}: not this version's trials.csv (columns {header[:4]}...)")
    parsers = [parse for _, parse, _ in COLUMNS]
    return [{n: p(v) for n, p, v in zip(NAMES, parsers, values, strict=True)} for values in reader]


class RowWriter:
    """Appends rows to trials.csv as trials end (the file is whole: see `write_sorted`)."""

    def __init__(self, path: Path) -> None:
        self._file = path.open("a")

    def append(self, row: dict[str, Any]) -> None:
        self._file.write(_line(row))
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def write_sorted(
    path: Path, rows: Iterable[dict[str, Any]], order: list[tuple[str, ...]]
) -> list[dict[str, Any]]:
    """Rewrite the file (header and whole rows only) with `rows` in `order` (keys; others
    after), atomically; the rows as written."""
    rank = {key: i for i, key in enumerate(order)}
    ordered = sorted(rows, key=lambda r: rank.get(row_key(r), len(rank)))
    tmp = path.with_suffix(".csv.tmp")
    with tmp.open("w") as out:
        out.write(",".join(NAMES) + "\n")
        out.writelines(_line(r) for r in ordered)
        out.flush()
        os.fsync(out.fileno())
    os.replace(tmp, path)
    return ordered
