"""What a sweep found: the paper's Tables 1-3 rows per (operator, RTT), task time against RTT
as a straight line per operator, and the delay beyond which onboard autonomy wins."""

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ptwl.experiments.sweep.spec import arm_of
from robot_sim.machines.spec import AUTONOMY_LEVELS
from robot_sim.policies.run import paper_rows

PTWL_EXITS = ("timeout", "goal_reached", "wrench_breach")


def as_trial_metrics(row: dict[str, Any]) -> dict[str, Any]:
    """A trials.csv row in trial_metrics' shape (what the paper's rows are computed from);
    the run time is the robot's task time."""
    return {**row, "run_time_s": row["task_time_s"], "ptwl": {e: row[f"ptwl_{e}"] for e in PTWL_EXITS}}


def arm(row: dict[str, Any]) -> str:
    """The row's operator, with the onboard machine's autonomy level when the sweep set one."""
    return arm_of(row["operator"], row.get("autonomy"))


def groups(rows: list[dict[str, Any]]) -> dict[tuple[str, float], list[dict[str, Any]]]:
    """Rows by (operator or onboard at a level, RTT), in the order they first appear (grid order)."""
    out: dict[tuple[str, float], list[dict[str, Any]]] = {}
    for row in rows:
        out.setdefault((arm(row), row["rtt_s"]), []).append(row)
    return out


def interval(values: list[float]) -> tuple[float, float, float]:
    """(median, 2.5th, 97.5th percentile): the middle 95 % of the trials."""
    p = np.percentile(values, [50.0, 2.5, 97.5])
    return float(p[0]), float(p[1]), float(p[2])


@dataclass(frozen=True)
class Fit:
    """y = intercept + slope x by least squares over every trial. `r2_means`: how well the line
    explains the mean at each x (is the trend linear?); `r2_trials`: how well it explains single
    trials (seeds that need more commands scatter around it). With the same number of trials at
    every x, the line is also the least-squares line through the means."""

    slope: float
    intercept: float
    r2_means: float
    r2_trials: float

    @classmethod
    def of(cls, x: list[float], y: list[float]) -> "Fit | None":
        if len(set(x)) < 2:
            return None
        slope, intercept = (float(v) for v in np.polyfit(x, y, 1))
        by_x: dict[float, list[float]] = {}
        for xi, yi in zip(x, y, strict=True):
            by_x.setdefault(xi, []).append(yi)
        xs = list(by_x)
        means = [float(np.mean(v)) for v in by_x.values()]
        return cls(slope, intercept, _r2(xs, means, slope, intercept), _r2(x, y, slope, intercept))


def _r2(x: list[float], y: list[float], slope: float, intercept: float) -> float:
    residual = np.asarray(y) - (intercept + slope * np.asarray(x))
    total = float(np.sum((np.asarray(y) - np.mean(y)) ** 2))
    return 1.0 - float(np.sum(residual**2)) / total if total > 0.0 else 1.0


def fits(rows: list[dict[str, Any]], y: str = "task_time_s") -> dict[str, Fit]:
    out = {}
    for operator in dict.fromkeys(arm(r) for r in rows):
        mine = [r for r in rows if arm(r) == operator]
        fit = Fit.of([r["rtt_s"] for r in mine], [r[y] for r in mine])
        if fit is not None:
            out[operator] = fit
    return out


def break_even_s(ground: Fit, onboard: Fit) -> float | None:
    """[s] RTT where the two lines cross (onboard faster beyond it if its slope is smaller);
    None if they are parallel."""
    if ground.slope == onboard.slope:
        return None
    return (onboard.intercept - ground.intercept) / (ground.slope - onboard.slope)


def summary_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (operator, RTT): the paper's figures (means) and the time distribution."""
    out = []
    for (operator, rtt), mine in groups(rows).items():
        task = interval([r["task_time_s"] for r in mine])
        paper = dict(paper_rows([as_trial_metrics(r) for r in mine], [r["success"] for r in mine]))
        out.append(
            {
                "operator": operator,
                "rtt_s": rtt,
                "trials": len(mine),
                "success_rate": sum(r["success"] for r in mine) / len(mine),
                "task_time_median_s": task[0],
                "task_time_p2_5_s": task[1],
                "task_time_p97_5_s": task[2],
                "operator_time_median_s": interval([r["operator_time_s"] for r in mine])[0],
                "commands_sent_mean": float(np.mean([r["commands_sent"] for r in mine])),
                "mean_force_n": float(np.mean([r["mean_force_n"] for r in mine])),
                "decisions_waited_mean": float(np.mean([r["decisions_waited"] for r in mine])),
                **{name: value for name, value in paper.items() if name != "Trials"},
            }
        )
    return out


@dataclass(frozen=True)
class LosSplit:
    """The trials of one arm and RTT with a loss of signal inside them (or without): how many,
    how many succeeded, and their median times (None: no such trial)."""

    arm: str
    rtt_s: float
    los_in_trial: bool
    trials: int
    success_rate: float | None
    task_time_median_s: float | None
    operator_time_median_s: float | None


def los_splits(rows: list[dict[str, Any]]) -> list[LosSplit]:
    """Per (arm, RTT), in grid order: the trials without a loss of signal, then those with."""
    out = []
    for (name, rtt), mine in groups(rows).items():
        for los in (False, True):
            part = [r for r in mine if r["los_in_trial"] == los]
            out.append(
                LosSplit(
                    name,
                    rtt,
                    los,
                    len(part),
                    sum(r["success"] for r in part) / len(part) if part else None,
                    interval([r["task_time_s"] for r in part])[0] if part else None,
                    interval([r["operator_time_s"] for r in part])[0] if part else None,
                )
            )
    return out


@dataclass(frozen=True)
class LevelAt:
    """One autonomy level at one RTT: success, the median task time, decisions waited."""

    level: str
    success_rate: float
    task_time_median_s: float
    decisions_waited_mean: float


@dataclass(frozen=True)
class SweetSpot:
    """Per RTT: every level measured and the sweet spot, the level with the best (least)
    median task time among those at least as successful as full autonomy (the most autonomous
    level measured, when `full` was not)."""

    rtt_s: float
    levels: list[LevelAt]
    reference: str  # the level whose success rate the others must match
    best: str | None  # None: no level matched it (cannot happen: the reference itself does)


def sweet_spots(rows: list[dict[str, Any]]) -> list[SweetSpot]:
    """The sweet spot at each RTT over the onboard rows with an autonomy level ([] if none)."""
    leveled = [r for r in rows if r["operator"] == "onboard" and r.get("autonomy")]
    out = []
    for rtt in sorted({r["rtt_s"] for r in leveled}):
        levels = []
        for level in AUTONOMY_LEVELS:
            mine = [r for r in leveled if r["rtt_s"] == rtt and r["autonomy"] == level]
            if mine:
                levels.append(
                    LevelAt(
                        level,
                        sum(r["success"] for r in mine) / len(mine),
                        interval([r["task_time_s"] for r in mine])[0],
                        float(np.mean([r["decisions_waited"] for r in mine])),
                    )
                )
        reference = levels[-1]  # the most autonomous measured: full, when it was
        fit = [x for x in levels if x.success_rate >= reference.success_rate]
        best = min(fit, key=lambda x: x.task_time_median_s).level if fit else None
        out.append(SweetSpot(rtt, levels, reference.level, best))
    return out


def write_summary(directory: Path, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """summary.csv (one line per operator and RTT) and summary.md (the paper's layout)."""
    table = summary_rows(rows)
    with (directory / "summary.csv").open("w", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=list(table[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(table)
    heads = [f"{t['operator']} {t['rtt_s']:g} s" for t in table]
    names = [k for k in table[0] if k not in ("operator", "rtt_s")]
    lines = [
        f"# {rows[0]['task']}: the paper's Tables 1-3 per operator and round trip",
        "",
        "Means over the trials unless named otherwise; times in seconds; the run time is the",
        "robot's task time (first behavior's start to last one's end).",
        "",
        "| | " + " | ".join(heads) + " |",
        "|---|" + "---|" * len(heads),
    ]
    for name in names:
        lines.append(f"| {name} | " + " | ".join(_text(t[name]) for t in table) + " |")
    (directory / "summary.md").write_text("\n".join(lines) + "\n")
    return table


def _text(value: object) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)
