"""report.md and its plots (matplotlib, PNG): task time, success and peak force against RTT per
operator, the straight-line fits, and the findings as numbers."""

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only: no display on a server or a worker
import matplotlib.pyplot as plt

from ptwl.experiments.sweep.summary import (
    Fit,
    LevelAt,
    LosSplit,
    SweetSpot,
    arm,
    break_even_s,
    fits,
    groups,
    interval,
    los_splits,
    sweet_spots,
)

COLOURS = {"ground": "tab:orange", "onboard": "tab:blue"}


def _by_operator(rows: list[dict[str, Any]], key: str) -> dict[str, tuple[list[float], list[tuple]]]:
    """Per operator: RTTs and (median, 2.5th, 97.5th) of `key` at each."""
    out: dict[str, tuple[list[float], list[tuple]]] = {}
    for (operator, rtt), mine in groups(rows).items():
        rtts, stats = out.setdefault(operator, ([], []))
        rtts.append(rtt)
        stats.append(interval([float(r[key]) for r in mine]))
    return out


def _interval_plot(
    rows: list[dict[str, Any]], key: str, ylabel: str, path: Path, line: dict[str, Fit]
) -> None:
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
    for operator, (rtts, stats) in _by_operator(rows, key).items():
        med = [s[0] for s in stats]
        err = [
            [m - s[1] for m, s in zip(med, stats, strict=True)],
            [s[2] - m for m, s in zip(med, stats, strict=True)],
        ]
        colour = COLOURS.get(operator)
        ax.errorbar(rtts, med, yerr=err, fmt="o", capsize=4, color=colour, label=f"{operator}: median, 95 %")
        fit = line.get(operator)
        if fit is not None:
            xs = [min(rtts), max(rtts)]
            ax.plot(
                xs,
                [fit.intercept + fit.slope * x for x in xs],
                "--",
                color=colour,
                label=f"{operator} fit: {fit.slope:.2f} s/s, R$^2$ {fit.r2_means:.3f} (means)",
            )
    ax.set_xlabel("round trip [s]")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _success_plot(rows: list[dict[str, Any]], path: Path) -> None:
    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=110)
    per: dict[str, tuple[list[float], list[float]]] = {}
    for (operator, rtt), mine in groups(rows).items():
        rtts, rates = per.setdefault(operator, ([], []))
        rtts.append(rtt)
        rates.append(100.0 * sum(r["success"] for r in mine) / len(mine))
    for operator, (rtts, rates) in per.items():
        ax.plot(rtts, rates, "o-", color=COLOURS.get(operator), label=operator)
    ax.set_ylim(-5, 105)
    ax.set_xlabel("round trip [s]")
    ax.set_ylabel("success [%]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _sweet_spot_plot(spots: list[SweetSpot], path: Path) -> None:
    """Median task time and success against RTT per autonomy level; the sweet spot starred."""
    fig, (time_ax, success_ax) = plt.subplots(2, 1, figsize=(6.4, 6.0), dpi=110, sharex=True)
    names = dict.fromkeys(x.level for s in spots for x in s.levels)
    for name in names:
        at = [(s.rtt_s, x) for s in spots for x in s.levels if x.level == name]
        rtts = [rtt for rtt, _ in at]
        line = time_ax.plot(rtts, [x.task_time_median_s for _, x in at], "o-", label=f"autonomy {name}")
        success_ax.plot(rtts, [100.0 * x.success_rate for _, x in at], "o-", color=line[0].get_color())
    best = [(s.rtt_s, x) for s in spots for x in s.levels if x.level == s.best]
    time_ax.plot(
        [rtt for rtt, _ in best],
        [x.task_time_median_s for _, x in best],
        "*",
        markersize=16,
        color="gold",
        markeredgecolor="black",
        label="sweet spot",
    )
    time_ax.set_ylabel("task time, median [s]")
    success_ax.set_ylabel("success [%]")
    success_ax.set_ylim(-5, 105)
    success_ax.set_xlabel("round trip [s]")
    for ax in (time_ax, success_ax):
        ax.grid(alpha=0.3)
    time_ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _level_cell(at: LevelAt) -> str:
    return f"{100.0 * at.success_rate:.0f} %, {at.task_time_median_s:.1f}, {at.decisions_waited_mean:.1f}"


def sweet_spot_lines(spots: list[SweetSpot]) -> list[str]:
    """The sweet-spot table (markdown): per RTT, each level's success and median time, and the
    level with the best time at or above the reference level's success rate."""
    if not spots:
        return []
    names = list(dict.fromkeys(x.level for s in spots for x in s.levels))
    head = "| RTT [s] | " + " | ".join(f"{n}: success, time [s], waits" for n in names) + " | sweet spot |"
    lines = [head, "|---|" + "---|" * (len(names) + 1)]
    for s in spots:
        by = {x.level: x for x in s.levels}
        cells = [_level_cell(by[n]) if n in by else "-" for n in names]
        lines.append(f"| {s.rtt_s:g} | " + " | ".join(cells) + f" | **{s.best}** |")
    reference = spots[0].reference
    lines += [
        "",
        f"The sweet spot at each RTT: the level with the least median task time among those whose success "
        f"rate is at least autonomy `{reference}`'s (waits: decisions the machine waited for the operator "
        "on, mean per trial).",
    ]
    return lines


def _or_dash(value: float | None, text: str) -> str:
    return "-" if value is None else text.format(value)


def los_lines(splits: list[LosSplit]) -> list[str]:
    """The loss-of-signal table (markdown): per arm and RTT, the trials with a loss of signal
    inside them and those without, their success and median times."""
    lines = [
        "| operator | RTT [s] | LOS in trial | trials | success | task time median [s] "
        "| operator time median [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in splits:
        success = None if s.success_rate is None else 100.0 * s.success_rate
        lines.append(
            f"| {s.arm} | {s.rtt_s:g} | {'yes' if s.los_in_trial else 'no'} | {s.trials} | "
            f"{_or_dash(success, '{:.0f} %')} | {_or_dash(s.task_time_median_s, '{:.2f}')} | "
            f"{_or_dash(s.operator_time_median_s, '{:.2f}')} |"
        )
    return lines


def los_section(rows: list[dict[str, Any]]) -> list[str]:
    return [
        "## Loss of signal",
        "",
        "Each trial starts at a seeded point of the link's schedule (`plan_offset_s`: the same for a seed "
        "at every RTT and for every operator); a trial has a loss of signal in it if either direction was "
        "closed (a contact gap or a blackout) at any time before the operator knew the outcome "
        "(`los_s`, `los_in_trial`).",
        "",
        *los_lines(los_splits(rows)),
        "",
    ]


FLAT_S = 0.1  # [s] a task time that changes less than this over the RTTs measured is flat


def findings(rows: list[dict[str, Any]]) -> list[str]:
    """The sweep's conclusions as sentences with numbers."""
    lines = []
    task_fits, operator_fits = fits(rows), fits(rows, "operator_time_s")
    rtts = sorted({r["rtt_s"] for r in rows})
    for operator, fit in task_fits.items():
        change_s = abs(fit.slope) * (rtts[-1] - rtts[0])
        if change_s < FLAT_S:  # R^2 measures how well a trend explains the spread: with none, noise
            how = f"flat: {change_s:.3f} s from {rtts[0]:g} to {rtts[-1]:g} s of RTT, so no R^2"
        else:
            how = (
                f"R^2 = {fit.r2_means:.3f} against the mean at each RTT, {fit.r2_trials:.3f} over "
                "single trials"
            )
        lines.append(
            f"- **{operator}**: task time = {fit.intercept:.2f} s + {fit.slope:.3f} x RTT "
            f"({how}); the operator knew the outcome "
            f"{operator_fits[operator].slope:.3f} s later per second of RTT "
            f"(intercept {operator_fits[operator].intercept:.2f} s)."
        )
    ground, onboard = task_fits.get("ground"), task_fits.get("onboard")
    if ground is not None and onboard is not None:
        ratio = onboard.slope / ground.slope if ground.slope else float("nan")
        lines.append(
            f"- The onboard slope is {100.0 * ratio:.1f} % of the ground slope "
            f"({onboard.slope:.3f} against {ground.slope:.3f} s per s of RTT)."
        )
        crossing = break_even_s(ground, onboard)
        if crossing is None:
            lines.append("- The two lines are parallel: no break-even delay.")
        elif crossing <= rtts[0]:
            lines.append(
                f"- Break-even: the fits cross at {crossing:.2f} s, at or below the smallest RTT "
                f"measured ({rtts[0]:g} s): onboard is faster at every delay measured."
            )
        else:
            lines.append(
                f"- Break-even: onboard wins beyond an RTT of {crossing:.2f} s (where the fits cross)."
            )
    return lines


def write_report(
    directory: Path, rows: list[dict[str, Any]], table: list[dict[str, Any]], link_closes: bool = False
) -> None:
    """`link_closes`: the sweep's link has contact windows or blackouts (adds the loss-of-signal
    table)."""
    line = fits(rows)
    _interval_plot(
        rows, "task_time_s", "task time on the robot [s]", directory / "task_time_vs_rtt.png", line
    )
    _success_plot(rows, directory / "success_vs_rtt.png")
    _interval_plot(rows, "max_force_n", "peak force [N]", directory / "peak_force_vs_rtt.png", {})
    spots = sweet_spots(rows)
    if spots:
        _sweet_spot_plot(spots, directory / "autonomy_vs_rtt.png")
    autonomy = (
        [
            "## Autonomy levels: the sweet spot",
            "",
            "![task time and success per autonomy level vs RTT](autonomy_vs_rtt.png)",
            "",
            *sweet_spot_lines(spots),
            "",
        ]
        if spots
        else []
    )
    task = rows[0]["task"]
    rtts = ", ".join(f"{r:g}" for r in sorted({r["rtt_s"] for r in rows}))
    operators = ", ".join(dict.fromkeys(arm(r) for r in rows))
    text = [
        f"# Latency sweep: {task}",
        "",
        f"{len(rows)} trials; round trips {rtts} s; operators {operators}. The task time is measured on the "
        "robot, from the first behavior's start to the last one's end (the paper's run time); the operator "
        "time runs from the first send until the outcome came down the link.",
        "",
        "## Findings",
        "",
        *findings(rows),
        "",
        *autonomy,
        *(los_section(rows) if link_closes else []),
        "## Task time against round trip",
        "",
        "![task time vs RTT](task_time_vs_rtt.png)",
        "",
        "## Success rate",
        "",
        "![success vs RTT](success_vs_rtt.png)",
        "",
        "## Peak force",
        "",
        "![peak force vs RTT](peak_force_vs_rtt.png)",
        "",
        "## Per operator and round trip",
        "",
        "| operator | RTT [s] | trials | success | task time median [s] | 95 % interval [s] "
        "| peak force [N] |",
        "|---|---|---|---|---|---|---|",
        *[
            f"| {t['operator']} | {t['rtt_s']:g} | {t['trials']} | {100.0 * t['success_rate']:.0f} % | "
            f"{t['task_time_median_s']:.2f} | {t['task_time_p2_5_s']:.2f}-{t['task_time_p97_5_s']:.2f} | "
            f"{t['Max force [N]']} |"
            for t in table
        ],
        "",
        "The paper's Tables 1-3 rows for every grid point are in summary.md and summary.csv; every trial in "
        "trials.csv.",
    ]
    (directory / "report.md").write_text("\n".join(text) + "\n")
