"""What every browser shares: the latest command's line, the force/torque plots, the command
history with the paper's counts, and the scene and link controls."""

from typing import Any

import viser

from web.markup import Markup, add_html, show
from web.panel_html import gains_html
from web.plots import WrenchPlots

BOARD_ORDER = 100.0  # below each browser's own form
PLOT_EVERY = 5  # telemetry messages per plot refresh (10 Hz at 50 Hz telemetry)


class Board:
    def __init__(self, gui: viser.GuiApi, scenes: list[str], scene: str, plot_window_s: float) -> None:
        self._states = 0
        self.command_status = add_html(gui, _command_html(None), order=BOARD_ORDER)
        self.commanded = add_html(gui, _commanded_html(None), order=BOARD_ORDER + 0.5)
        self.gains = add_html(gui, Markup('<div id="ptwl-gains"></div>'), order=BOARD_ORDER + 0.6)
        # Which state the 3D scene last moved to, sent in the same atomic batch as the scene
        # (tests and bench/console.py read it; the status bar shows the age on its own clock).
        self.scene_state = add_html(gui, _scene_state_html(None, None), order=BOARD_ORDER + 0.7)
        with gui.add_folder("Force / torque", expand_by_default=True, order=BOARD_ORDER + 1):
            self.plots = WrenchPlots(gui, plot_window_s)
        with gui.add_folder("Commands", expand_by_default=True, order=BOARD_ORDER + 2):
            self.history = add_html(gui, Markup("No commands yet."))
        with gui.add_folder("Scene and link", expand_by_default=False, order=BOARD_ORDER + 3):
            self.scene = gui.add_dropdown("Scene", scenes, initial_value=scene)
            self.seed = gui.add_number("Seed (0: nominal)", 0, min=0, step=1)
            self.reset_scene = gui.add_button("Reset scene")
            self.link = add_html(gui, Markup('<div id="ptwl-link-profile">link: unknown</div>'))

    def plot_state(self, sim_time: float, wrench: list[float]) -> None:
        """A state's wrench into the plots, drawn every PLOT_EVERY states."""
        self.plots.add(sim_time, wrench)
        self._states += 1
        if self._states % PLOT_EVERY == 0:
            self.plots.refresh()

    def show_scene(self, scene: str) -> None:
        """The scene the robot has loaded, as the reset dropdown's choice."""
        handle: Any = self.scene
        handle.value = scene

    def show_command(self, view: Any) -> None:
        show(self.command_status, _command_html(view))

    def show_scene_state(self, seq: int, arrived: float) -> None:
        show(self.scene_state, _scene_state_html(seq, arrived))

    def show_gains(self, gains: dict[str, Any] | None) -> None:
        """The stiffness and damping in force on the robot now (as its telemetry reports them)."""
        if gains is None:
            return
        shown = gains_html(gains["stiffness"], gains["damping"], "ptwl-gains", f"{gains['frame']} axes")
        caption = Markup("<div style='font-size:0.8em'>gains on the robot now ({} axes):</div>")
        show(self.gains, caption.format(gains["frame"]) + shown)

    def show_link_profile(self, text: str) -> None:
        show(self.link, Markup('<div id="ptwl-link-profile">{}</div>').format(text))

    def show_history(self, counts: dict[str, Any], views: list[Any], scene: str = "") -> None:
        """The paper's counts for `scene` (PTWL by exit condition, RWE, Dither, peaks) and the
        latest commands, newest first."""
        show(self.history, _history_html(counts, views, scene))

    def show_commanded(self, view: Any, distance_mm: float | None = None) -> None:
        """The commanded target the 3D marker shows (the last PTWL sent from this console), and
        how far it is from the port."""
        show(self.commanded, _commanded_html(view, distance_mm))


def _command_html(view: Any) -> Markup:
    if view is None:
        return Markup('<div id="ptwl-command" data-status="" style="padding:4px 0">No command yet.</div>')
    extra = Markup(" — {}").format(view.detail) if view.detail else ""
    by = Markup(' <span style="font-weight:400">by {}</span>').format(view.sender) if view.sender else ""
    line = Markup(
        '<div id="ptwl-command" data-status="{status}" data-id="{id}" '
        'style="padding:4px 8px;border-left:6px solid {color};font-weight:600">'
        "{behavior} {label}: {status}{extra}{by}</div>"
    ).format(
        status=view.status,
        id=view.id or "",
        color=view.color,
        behavior=view.behavior.upper(),
        label=view.label,
        extra=extra,
        by=by,
    )
    return line + _steps_html(view.steps)


STEPS_SHOWN = 30  # a state machine's latest steps listed; a tool exchange runs 1,500


def _steps_html(steps: list[dict[str, Any]]) -> Markup:
    """A state machine's steps so far (the latest STEPS_SHOWN): behavior, exit and why the
    machine chose it; numbered as the machine counts them."""
    if not steps:
        return Markup("")
    row = Markup(
        '<li data-behavior="{behavior}" data-exit="{exit}">{shown} → {exit} '
        "<span style='color:#868e96'>{why}</span></li>"
    )
    shown = steps[-STEPS_SHOWN:]
    rows = Markup("").join(
        row.format(behavior=s["behavior"], exit=s["exit"], shown=s["behavior"].upper(), why=s["why"])
        for s in shown
    )
    earlier = len(steps) - len(shown)
    note = Markup("<div style='font-size:0.85em;color:#868e96'>{} earlier steps not listed</div>").format(
        earlier
    )
    listed = Markup(
        '<ol id="ptwl-steps" data-count="{}" start="{}" style="margin:2px 0 4px 20px;font-size:0.85em">'
        "{}</ol>"
    ).format(len(steps), earlier + 1, rows)
    return (note if earlier else Markup("")) + listed


def _commanded_html(view: Any, distance_mm: float | None = None) -> Markup:
    """Where the red marker is and how sure: predicted from the delayed port (a relative command
    resolves against the port where it starts), or resolved by the robot."""
    if view is None or view.target is None or view.phase == "done":
        return Markup('<div id="ptwl-no-commanded"></div>')
    x, y, z = (1000.0 * float(v) for v in view.target[0])
    how = "resolved by the robot" if view.resolved else "relative to the port at start, predicted"
    far = "" if distance_mm is None else f"; {distance_mm:.1f} mm from the port"
    return Markup(
        '<div id="ptwl-commanded" data-resolved="{}" data-local="{}" data-distance="{}" '
        'style="padding:0 8px;color:#e03131">commanded target of PTWL {}: '
        "({:.1f}, {:.1f}, {:.1f}) mm, {}{}</div>"
    ).format(
        int(view.resolved),
        view.local,
        "" if distance_mm is None else f"{distance_mm:.1f}",
        view.label,
        x,
        y,
        z,
        how,
        far,
    )


def _percent(n: int, total: int) -> str:
    return f"{100.0 * n / total:.0f}%" if total else "—"


def _history_html(counts: dict[str, Any], views: list[Any], scene: str = "") -> Markup:
    """The paper's behavior breakdown (Tables 1-3: RWE and PTWL with their share, PTWL by exit,
    the total; state machine steps counted as the behaviors they ran) for this scene, and the
    latest commands, newest first."""
    total, by_exit = counts["behaviors"], counts["ptwl"]
    known = ("timeout", "goal_reached", "wrench_breach")
    others = ", ".join(f"{k} {v}" for k, v in sorted(by_exit.items()) if k not in known)
    line = Markup("<tr><td>{}</td><td style='text-align:right'>{}</td></tr>")
    rows = [
        ("RWE", f"{counts['rwe']} ({_percent(counts['rwe'], total)})"),
        ("PTWL", f"{counts['ptwl_total']} ({_percent(counts['ptwl_total'], total)})"),
        ("PTWL timeout", by_exit.get("timeout", 0)),
        ("PTWL goal reached", by_exit.get("goal_reached", 0)),
        ("PTWL wrench breach", by_exit.get("wrench_breach", 0)),
        *([("PTWL other", others)] if others else []),
        ("Dither", counts["dither"]),
        ("Behaviors in all", total),
        ("Max force [N]", f"{counts['peak_force']:.1f}"),
        ("Max torque [N m]", f"{counts['peak_torque']:.2f}"),
    ]
    breakdown = Markup(
        '<table id="ptwl-counts" data-behaviors="{}" data-ptwl="{}" data-rwe="{}" data-scene="{}" '
        'style="font-size:0.8em">'
        "<caption style='text-align:left'>scene {} (steps of state machines included)</caption>{}</table>"
    ).format(
        total,
        counts["ptwl_total"],
        counts["rwe"],
        scene,
        scene or "—",
        Markup("").join(line.format(name, value) for name, value in rows),
    )
    row = Markup(
        '<tr><td title="{}">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>'
    )
    recent = Markup("").join(
        row.format(
            v.label,
            v.short_label,
            v.behavior,
            v.status,
            (v.sender or "script").split(" at console")[0],
            "" if v.peak_force is None else f"{v.peak_force:.1f}",
            "" if v.peak_torque is None else f"{v.peak_torque:.2f}",
            "" if v.duration is None else f"{v.duration:.2f}",
        )
        for v in views
    )
    head = Markup(
        "<tr><th>cmd</th><th>behavior</th><th>status</th><th>by</th><th>F [N]</th>"
        "<th>τ [N m]</th><th>t [s]</th></tr>"
    )
    table = Markup('<table id="ptwl-history" style="font-size:0.8em;text-align:left">{}{}</table>')
    return breakdown + table.format(head, recent)


def _scene_state_html(seq: int | None, arrived: float | None) -> Markup:
    return Markup('<i id="ptwl-scene" data-seq="{}" data-arrived="{}"></i>').format(seq or "", arrived or "")
