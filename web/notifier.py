"""Notifications to every open browser (the toasts that stack top left), and the colour an exit
condition is told in."""

from typing import Literal

import viser

NotificationColor = Literal["gray", "red", "green", "orange", "yellow", "blue"]
EXIT_NOTIFICATION_COLORS: dict[str, NotificationColor] = {
    "goal_reached": "green",
    "completed": "green",
    "wrench_breach": "orange",
    "timeout": "yellow",
    "aborted": "gray",
    "expired": "blue",  # not a fault of the robot: the link held it too long
    "anomaly": "orange",  # the force task monitor stopped it: look before going on
}


class Notifier:
    def __init__(self, server: viser.ViserServer) -> None:
        self._server = server

    def notify(self, title: str, body: str, color: NotificationColor) -> None:
        for client in self._server.get_clients().values():
            client.add_notification(title, body, auto_close_seconds=6.0, color=color)


def exit_color(exit_condition: str | None) -> NotificationColor:
    return EXIT_NOTIFICATION_COLORS.get(exit_condition or "", "red")
