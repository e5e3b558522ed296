"""What every browser shares: the latest command's line, the force/torque plots, the command
history with the paper's counts, and the scene and link controls."""

from typing import Any

import numpy as np
import viser

BOARD_ORDER = 100.0  # below each browser's own form


class Board:
    def __init__(self, gui: viser.GuiApi, scenes: list[str], scene: str) -> None:
        self.command_status = gui.add_html(_command_html(None), order=BOARD_ORDER)
        self.commanded = gui.add_html(_commanded_html(None), order=BOARD_ORDER + 0.5)
        with gui.add_folder("Force / torque", expand_by_default=True, order=BOARD_ORDER + 1):
            self.force_plot = _xyz_plot(gui, "f", "N")
            self.torque_plot = _xyz_plot(gui, "t", "N m")
        with gui.add_folder("Commands", expand_by_default=True, order=BOARD_ORDER + 2):
            self.history = gui.add_markdown("No commands yet.")
        with gui.add_folder("Scene and link", expand_by_default=False, order=BOARD_ORDER + 3):
            self.scene = gui.add_dropdown("Scene", scenes, initial_value=scene)
            self.seed = gui.add_number("Seed (0: nominal)", 0, min=0, step=1)
            self.reset_scene = gui.add_button("Reset scene")
            self.link = gui.add_markdown("link: unknown")

    def show_command(self, view: Any) -> None:
        self.command_status.content = _command_html(view)

    def show_commanded(self, view: Any) -> None:
        """The commanded target the 3D marker shows (the last PTWL sent from this console)."""
        self.commanded.content = _commanded_html(view)


def _xyz_plot(gui: Any, symbol: str, unit: str) -> Any:
    """A time plot of x, y, z components (red, green, blue), empty until telemetry arrives."""
    empty = np.zeros(1)
    series = [{"label": "t [s]"}] + [
        {"label": f"{symbol}{axis} [{unit}]", "stroke": color}
        for axis, color in zip("xyz", ("#e03131", "#2f9e44", "#1971c2"), strict=True)
    ]
    return gui.add_uplot((empty,) * 4, tuple(series), scales={"x": {"time": False}}, aspect=2.5)


def _command_html(view: Any) -> str:
    if view is None:
        return '<div id="ptwl-command" data-status="" style="padding:4px 0">No command yet.</div>'
    extra = f" — {view.detail}" if view.detail else ""
    by = f' <span style="font-weight:400">by {view.sender}</span>' if view.sender else ""
    return (
        f'<div id="ptwl-command" data-status="{view.status}" data-id="{view.id or ""}" '
        f'style="padding:4px 8px;border-left:6px solid {view.color};font-weight:600">'
        f"{view.behavior.upper()} {view.label}: {view.status}{extra}{by}</div>"
    )


def _commanded_html(view: Any) -> str:
    """Where the red marker is and how sure: predicted from the delayed port (a relative command
    resolves against the port where it starts), or resolved by the robot."""
    if view is None or view.target is None or view.phase == "done":
        return '<div id="ptwl-no-commanded"></div>'
    x, y, z = (1000.0 * float(v) for v in view.target[0])
    how = "resolved by the robot" if view.resolved else "relative to the port at start, predicted"
    return (
        f'<div id="ptwl-commanded" data-resolved="{int(view.resolved)}" data-local="{view.local}" '
        f'style="padding:0 8px;color:#e03131">commanded target of PTWL {view.label}: '
        f"({x:.1f}, {y:.1f}, {z:.1f}) mm, {how}</div>"
    )
