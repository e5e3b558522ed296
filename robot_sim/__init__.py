"""The robot: MuJoCo physics, the admittance controller, the behaviors and the tasks' state
machines; no network, no clock of its own.

Importing it registers the presets and the tasks' state machines with robot_sim.params, which
resolves the names a request uses through them (params.NAMED) without importing them.
"""

import robot_sim.policies
import robot_sim.presets  # noqa: F401
