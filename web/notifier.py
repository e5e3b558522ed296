"""Notifications to every open browser (the toasts that stack top left), and the colour an exit
condition is told in."""

from typing import Literal

import viser

from robot_sim.exit_severity import Severity, severity

NotificationColor = Literal["gray", "red", "green", "orange", "yellow", "blue"]
NOTIFICATION_COLORS: dict[Severity, NotificationColor] = {
    Severity.SUCCESS: "green",
    Severity.NOTICE: "blue",  # it did not run to its end (STOP, the link held it too long)
    Severity.WARNING: "orange",
    Severity.ERROR: "red",
}


class Notifier:
    def __init__(self, server: viser.ViserServer) -> None:
        self._server = server

    def notify(self, title: str, body: str, color: NotificationColor) -> None:
        for client in self._server.get_clients().values():
            client.add_notification(title, body, auto_close_seconds=6.0, color=color)


def exit_color(exit_condition: str | None) -> NotificationColor:
    return NOTIFICATION_COLORS[severity(exit_condition)]
