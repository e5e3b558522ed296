"""The force task monitor's line on the status bar (robot_sim/task_monitor.py): shown while the
running (or last) behavior asked for one. It never passes silently: learning, judging (with its
estimates), not judging and why ("normal force 1.8 N < 3.3 N"), or the anomaly it found."""

from typing import Any

from web.markup import Markup

STATE_COLORS = {"anomaly": "#e03131", "blind": "#f08c00", "judging": "#2f9e44", "learning": "#868e96"}


def monitor_state(monitor: dict[str, Any]) -> str:
    if monitor["anomaly"]:
        return "anomaly"
    if monitor.get("not_judging"):
        return "blind"
    return "judging" if monitor["judging"] else "learning"


def monitor_html(monitor: dict[str, Any] | None, running: bool) -> Markup:
    """`running`: a command is running now; if not, the monitor is the last behavior's, said so
    and greyed (the robot keeps it in telemetry after the behavior ends)."""
    if not monitor:
        return Markup("")
    state = monitor_state(monitor)
    estimates = Markup("mu {:.3f}, c {:.2f} N").format(monitor["mu"], monitor["c"])
    said = {
        "anomaly": Markup("<b>ANOMALY</b>: off its model ({})").format(estimates),
        "blind": Markup("<b>not judging</b> ({})").format(monitor.get("not_judging")),
        "judging": Markup("judging · {} · within ±{:.2f} N").format(estimates, monitor["band"]),
        "learning": Markup("learning ({} samples)").format(monitor["samples_learned"]),
    }[state]
    return Markup(
        '<div id="ptwl-monitor" data-state="{}" data-running="{}" style="color:{}">force monitor{}: {}</div>'
    ).format(
        state,
        int(running),
        STATE_COLORS[state] if running else "#868e96",
        "" if running else " (last command, ended)",
        said,
    )
