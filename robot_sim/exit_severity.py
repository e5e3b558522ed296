"""How bad each exit condition is: the one table the console's colours and toasts, the MCAP log
levels and docs/robot.md's list are drawn from (tests/test_exit_severity.py holds docs/robot.md to it).

- success: the behavior did what it was sent for;
- notice: it did not run to its end, by someone's choice (STOP, the link's age limit);
- warning: the world pushed back (a breach, a timeout, an anomaly the task monitor saw, a state
  machine that gave up): look before going on;
- error: the simulation faulted.
"""

from enum import StrEnum

from robot_sim.behaviors.base import ExitCondition


class Severity(StrEnum):
    SUCCESS = "success"
    NOTICE = "notice"
    WARNING = "warning"
    ERROR = "error"


EXIT_SEVERITY: dict[ExitCondition, Severity] = {
    ExitCondition.GOAL_REACHED: Severity.SUCCESS,
    ExitCondition.COMPLETED: Severity.SUCCESS,
    ExitCondition.ABORTED: Severity.NOTICE,
    ExitCondition.EXPIRED: Severity.NOTICE,
    ExitCondition.WRENCH_BREACH: Severity.WARNING,
    ExitCondition.TIMEOUT: Severity.WARNING,
    ExitCondition.ANOMALY: Severity.WARNING,
    ExitCondition.FAILED: Severity.WARNING,
    ExitCondition.FAULT: Severity.ERROR,
}


def severity(exit_condition: str | None) -> Severity:
    """An exit's severity; anything else (a console's own "refused" or "lost", a newer robot's
    exit this one does not know) is an error: it is not known to be well."""
    try:
        return EXIT_SEVERITY[ExitCondition(exit_condition or "")]
    except ValueError:
        return Severity.ERROR
