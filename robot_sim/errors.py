"""The one root exception of robot_sim, and its kinds.

Routes (server/) turn these into HTTP errors; robot_sim itself never knows about HTTP. A bad
configuration file is the project's one ConfigError (ptwl_config), raised here too.
"""

from ptwl_config import ConfigError, PtwlError

__all__ = ["ConfigError", "RobotSimError", "SimulationFault", "UnknownNameError"]


class RobotSimError(PtwlError):
    """Root of every error robot_sim raises on purpose."""


class UnknownNameError(RobotSimError, KeyError):
    """A scene, preset or other registered name that does not exist; lists the valid ones."""

    def __init__(self, kind: str, name: str, valid: list[str]) -> None:
        self.kind = kind
        self.name = name
        self.valid = sorted(valid)
        super().__init__(f"unknown {kind} {name!r}; valid: {', '.join(self.valid)}")

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0])


class SimulationFault(RobotSimError):
    """The physics or the controller produced non-finite numbers."""
