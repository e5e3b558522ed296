"""What every browser shares: the latest command's line, the force/torque plots, the command
history with the paper's counts, and the scene and link controls."""

import html
from typing import Any

import viser

from web.panel import gains_html
from web.plots import WrenchPlots

BOARD_ORDER = 100.0  # below each browser's own form


class Board:
    def __init__(self, gui: viser.GuiApi, scenes: list[str], scene: str, plot_window_s: float) -> None:
        self.command_status = gui.add_html(_command_html(None), order=BOARD_ORDER)
        self.commanded = gui.add_html(_commanded_html(None), order=BOARD_ORDER + 0.5)
        self.gains = gui.add_html('<div id="ptwl-gains"></div>', order=BOARD_ORDER + 0.6)
        # Which state the 3D scene shows, sent in the same atomic batch as the scene (tests and
        # bench/console.py read it; the status bar shows the age on its own clock).
        self.scene_state = gui.add_html(_scene_state_html(None, None), order=BOARD_ORDER + 0.7)
        with gui.add_folder("Force / torque", expand_by_default=True, order=BOARD_ORDER + 1):
            self.plots = WrenchPlots(gui, plot_window_s)
        with gui.add_folder("Commands", expand_by_default=True, order=BOARD_ORDER + 2):
            self.history = gui.add_markdown("No commands yet.")
        with gui.add_folder("Scene and link", expand_by_default=False, order=BOARD_ORDER + 3):
            self.scene = gui.add_dropdown("Scene", scenes, initial_value=scene)
            self.seed = gui.add_number("Seed (0: nominal)", 0, min=0, step=1)
            self.reset_scene = gui.add_button("Reset scene")
            self.link = gui.add_markdown("link: unknown")

    def show_scene(self, scene: str) -> None:
        """The scene the robot has loaded, as the reset dropdown's choice."""
        handle: Any = self.scene
        handle.value = scene

    def show_command(self, view: Any) -> None:
        self.command_status.content = _command_html(view)

    def show_scene_state(self, seq: int, arrived: float) -> None:
        self.scene_state.content = _scene_state_html(seq, arrived)

    def show_gains(self, gains: dict[str, Any] | None) -> None:
        """The stiffness and damping in force on the robot now (as its telemetry reports them)."""
        if gains is None:
            return
        shown = gains_html(gains["stiffness"], gains["damping"], "ptwl-gains", f"{gains['frame']} axes")
        self.gains.content = (
            f"<div style='font-size:0.8em'>gains on the robot now ({gains['frame']} axes):</div>{shown}"
        )

    def show_commanded(self, view: Any, distance_mm: float | None = None) -> None:
        """The commanded target the 3D marker shows (the last PTWL sent from this console), and
        how far it is from the port."""
        self.commanded.content = _commanded_html(view, distance_mm)


def _command_html(view: Any) -> str:
    if view is None:
        return '<div id="ptwl-command" data-status="" style="padding:4px 0">No command yet.</div>'
    extra = f" — {view.detail}" if view.detail else ""
    by = f' <span style="font-weight:400">by {view.sender}</span>' if view.sender else ""
    return (
        f'<div id="ptwl-command" data-status="{view.status}" data-id="{view.id or ""}" '
        f'style="padding:4px 8px;border-left:6px solid {view.color};font-weight:600">'
        f"{view.behavior.upper()} {view.label}: {view.status}{extra}{by}</div>" + _steps_html(view.steps)
    )


def _steps_html(steps: list[dict[str, Any]]) -> str:
    """A state machine's steps so far: behavior, exit and why the machine chose it."""
    if not steps:
        return ""
    rows = "".join(
        f'<li data-behavior="{s["behavior"]}" data-exit="{s["exit"]}">{s["behavior"].upper()} → '
        f"{s['exit']} <span style='color:#868e96'>{html.escape(s['why'])}</span></li>"
        for s in steps
    )
    style = "margin:2px 0 4px 20px;font-size:0.85em"
    return f'<ol id="ptwl-steps" data-count="{len(steps)}" style="{style}">{rows}</ol>'


def _commanded_html(view: Any, distance_mm: float | None = None) -> str:
    """Where the red marker is and how sure: predicted from the delayed port (a relative command
    resolves against the port where it starts), or resolved by the robot."""
    if view is None or view.target is None or view.phase == "done":
        return '<div id="ptwl-no-commanded"></div>'
    x, y, z = (1000.0 * float(v) for v in view.target[0])
    how = "resolved by the robot" if view.resolved else "relative to the port at start, predicted"
    far = "" if distance_mm is None else f"; {distance_mm:.1f} mm from the port"
    return (
        f'<div id="ptwl-commanded" data-resolved="{int(view.resolved)}" data-local="{view.local}" '
        f'data-distance="{"" if distance_mm is None else f"{distance_mm:.1f}"}" '
        f'style="padding:0 8px;color:#e03131">commanded target of PTWL {view.label}: '
        f"({x:.1f}, {y:.1f}, {z:.1f}) mm, {how}{far}</div>"
    )


def _scene_state_html(seq: int | None, arrived: float | None) -> str:
    return f'<i id="ptwl-scene" data-seq="{seq or ""}" data-arrived="{arrived or ""}"></i>'
