"""The paper's Tables 1-3 (tool retrieval, tool stowage, sleeve on peg), to set ours beside.

The paper gives ten teleoperated trials per column, without and with the delayed link: mean
peaks and run time per trial, and totals of behaviors over the ten. Here the totals are divided
by the trials, so every figure is a per-trial mean in the layout of `paper_rows` (run.py).
`ptwl report` and `ptwl task bench` print these beside our own; docs/robot.md has the table.
"""

from dataclasses import dataclass


@dataclass(frozen=True)
class PaperColumn:
    """One column of one of the paper's tables, as printed there."""

    heading: str
    trials: int
    max_force_n: float  # "Mean Max Force"
    max_torque_nm: float  # "Mean Max Torque"
    run_time_s: float  # "Mean Run time"
    behaviors: float  # "Mean Num Behaviors"
    rwe: int  # "Total Number RWE", over the trials
    ptwl_timeout: int  # "PTWL Timeout", over the trials
    ptwl_goal_reached: int
    ptwl_wrench_breach: int

    def rows(self) -> dict[str, str]:
        """Per-trial means under `paper_rows`' labels; what the paper does not give is absent."""
        n = self.trials
        return {
            "Trials": f"{n}",
            "Max force [N]": f"{self.max_force_n:.1f}",
            "Max torque [N m]": f"{self.max_torque_nm:.2f}",
            "Run time [s]": f"{self.run_time_s:.1f}",
            "Number of behaviors": f"{self.behaviors:.2f}",
            "RWE": f"{self.rwe / n:.2f}",
            "PTWL (timeout)": f"{self.ptwl_timeout / n:.2f}",
            "PTWL (goal reached)": f"{self.ptwl_goal_reached / n:.2f}",
            "PTWL (wrench breach)": f"{self.ptwl_wrench_breach / n:.2f}",
        }


@dataclass(frozen=True)
class PaperTable:
    """A task's table: its number, both columns, and why ours differ in shape (a line each)."""

    number: int
    direct: PaperColumn
    delayed: PaperColumn
    differences: tuple[str, ...]


_RUN_TIME = (
    "run time: the paper's include an operator deciding each step (delayed, the link too); "
    "ours are the robot's own"
)
_TIMEOUTS = (
    "PTWL exits: the paper's operator aimed PTWLs past contact and let them time out; our machine "
    "aims its free moves at reachable goals and finds contact by a breach"
)
_TORQUES = (
    "torques 3-8x smaller: not explained (our bayonet's spring and friction are modelled, not measured)"
)

PAPER_TABLES: dict[str, PaperTable] = {
    "tool_retrieval": PaperTable(
        1,
        PaperColumn("paper", 10, 51.829, 5.296, 99.761, 6.2, 10, 42, 0, 10),
        PaperColumn("paper, delayed", 10, 20.751, 2.549, 93.144, 3.6, 6, 29, 0, 1),
        (
            _RUN_TIME,
            _TIMEOUTS,
            "max force: the paper's 51.8 N is its pneumatic gripper's closing impact; ours closes in "
            "10 ms (~20 N); `gripper_close_s` 0.0055 runs the pneumatic case (~52 N)",
            _TORQUES,
        ),
    ),
    "tool_stowage": PaperTable(
        2,
        PaperColumn("paper", 10, 27.28, 1.947, 108.762, 6.1, 0, 50, 1, 10),
        PaperColumn("paper, delayed", 10, 30.03, 1.422, 102.112, 5.3, 8, 35, 0, 10),
        (_RUN_TIME, _TIMEOUTS, _TORQUES),
    ),
    "sleeve_on_peg": PaperTable(
        3,
        PaperColumn("paper", 10, 18.763, 1.354, 18.2, 1.2, 0, 12, 0, 0),
        PaperColumn("paper, delayed", 10, 19.562, 1.619, 14.554, 1.0, 0, 10, 0, 0),
        (_RUN_TIME, "the same shape: one PTWL ending `timeout` pressing the bottom at ~19 N"),
    ),
}


def beside_paper(task: str, ours: list[tuple[str, str]], heading: str) -> list[str]:
    """Text lines: our `paper_rows` beside the paper's two columns for `task`, then a line per
    difference in shape; nothing for a task the paper has no table of."""
    table = PAPER_TABLES.get(task)
    if table is None:
        return []
    columns = [table.direct.rows(), table.delayed.rows(), dict(ours)]
    headers = [table.direct.heading, table.delayed.heading, heading]
    title = f"{task} beside the paper's Table {table.number} (per-trial means; '-': the paper does not say)"
    lines = [title, *text_table([label for label, _ in ours], headers, columns)]
    return lines + [f"  - {why}" for why in table.differences]


def text_table(labels: list[str], headers: list[str], columns: list[dict[str, str]]) -> list[str]:
    """A plain-text table: a row per label, a column per header ('-' where a column lacks it)."""
    width = max(len(label) for label in labels)
    widths = [max(len(h), 10) for h in headers]
    lines = [
        " " * width + " | " + " | ".join(h.rjust(w) for h, w in zip(headers, widths, strict=True)),
        "-" * width + "-|-" + "-|-".join("-" * w for w in widths),
    ]
    for label in labels:
        cells = [column.get(label, "-") for column in columns]
        lines.append(
            label.ljust(width) + " | " + " | ".join(c.rjust(w) for c, w in zip(cells, widths, strict=True))
        )
    return lines
