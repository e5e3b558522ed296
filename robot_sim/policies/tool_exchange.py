"""Tool exchange (paper 2.3.2: "100 consecutive trials of both retrieval and stowage without a
single failure"), in one simulation with no reset: the retrieval and stowage machines as they
are, joined by moves that take the port back to where each of them starts.

    retrieve    the tool retrieval machine (down, close, relieve, turn the lock open, lift out)
    park        PTWL to the parking pose (120 mm aside, 60 mm up), turning the unlock's twist
                back on the way: each cycle starts the wrist where the first did
    carry back  PTWL to 40 mm over the first start's pose: the tool's legs above the bay's
                walls (a straight line from the parking pose would drag them into a wall)
    lower       PTWL down to the first start's pose: the tool 20 mm over its bay, as the stowage
                machine starts
    stow        the tool stowage machine (down, turn open, bottom out, turn shut, open, leave)
    return      PTWL to the first start's pose: the open gripper over the knob; the next cycle

The carry moves are aimed at poses remembered from the first start, in base axes, so nothing
accumulates from cycle to cycle: not the lock's turns, not what each contact left of the port.
"""

from pydantic import Field

from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose
from robot_sim.machines.engine import SpecPolicy, policy_class
from robot_sim.machines.library import builtin_machines
from robot_sim.params import PtwlParams
from robot_sim.policies.base import Decision, Finish, Policy, PolicySettings, Step
from robot_sim.scenes.tool_exchange import EXCHANGES_WANTED

PARK_OFFSET_M = (0.0, 0.12, 0.06)  # [m] base axes, from the start: aside and up, clear of the bay
OVER_M = 0.04  # [m] over the start, on the way back: the legs above the bay's 40 mm walls
CARRY_S = 3.0  # [s] each carry move
STEPS_PER_CYCLE = 15  # retrieval 5, park, carry back and lower 3, stowage 6, return 1


# The retrieval and stowage machines are the built-in files (robot_sim/machines/builtin).
RETRIEVAL = policy_class(builtin_machines()["tool_retrieval"])
STOWAGE = policy_class(builtin_machines()["tool_stowage"])


class ToolExchangeSettings(PolicySettings):
    cycles: int = Field(
        EXCHANGES_WANTED,
        ge=1,
        le=EXCHANGES_WANTED,
        description="exchanges to run: retrieve, park, stow (the task asks for 100 in a row)",
    )


class ToolExchange(Policy):
    task = "tool_exchange"
    summary = "retrieve the tool; park it and bring it back untwisted; stow it; again, `cycles` times"
    settings_model = ToolExchangeSettings
    settings: ToolExchangeSettings

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.home: Pose | None = None
        self.exchanges = 0  # whole cycles the machine believes done
        self.phase: SpecPolicy | None = None  # the machine running, if one is
        self.move = ""  # the carry move running, when no machine is

    def max_steps(self) -> int:
        return STEPS_PER_CYCLE * self.settings.cycles + super().max_steps()  # room for recoveries

    def first(self, port: Pose) -> Step:
        self.home = port
        return self._run(RETRIEVAL(), port)

    def next(self, report: BehaviorReport) -> Decision:
        if self.phase is not None:
            decision = self.phase.next(report)
            if isinstance(decision, Step):
                return self._in_cycle(decision)
            if not decision.completed:
                return Finish(False, f"cycle {self.cycle}, {self.phase.task}: {decision.why}")
            return self._after(self.phase, report)
        if report.exit is not ExitCondition.GOAL_REACHED:
            return Finish(
                False, f"cycle {self.cycle}, {self.move}: ended {report.exit} at {report.peak_force:.1f} N"
            )
        if self.move == "park":
            return self._carry("carry back", report.final_port, self._over(), "over the bay again, untwisted")
        if self.move == "carry back":
            return self._carry("lower", report.final_port, self._home(), "down to where the stowage starts")
        if self.move == "lower":
            return self._run(STOWAGE(), report.final_port)
        return self._run(RETRIEVAL(), report.final_port)  # back from a return

    def _after(self, finished: SpecPolicy, report: BehaviorReport) -> Decision:
        self.phase = None
        if finished.task == "tool_retrieval":
            park = self._offset(PARK_OFFSET_M)
            return self._carry(
                "park", report.final_port, park, "the tool out: to the parking pose, untwisting"
            )
        self.exchanges += 1
        if self.exchanges == self.settings.cycles:
            return Finish(True, f"{self.exchanges} exchanges: each tool retrieved, parked and stowed")
        return self._carry("return", report.final_port, self._home(), "stowed: back over the knob")

    def _run(self, machine: SpecPolicy, port: Pose) -> Step:
        self.phase, self.move = machine, ""
        return self._in_cycle(machine.first(port))

    def _in_cycle(self, step: Step) -> Step:
        assert self.phase is not None
        return Step(
            step.params,
            f"cycle {self.cycle}/{self.settings.cycles}, {self.phase.task}: {step.why}",
            step.state,
        )

    def _carry(self, move: str, port: Pose, goal: Pose, why: str) -> Step:
        """A free move from `port` to `goal` in base axes (the port's pose at its end is where
        the last behavior left it: onboard, the next starts at once)."""
        self.move = move
        translation, rotation = port.displacement_to(goal)
        params = PtwlParams(
            translation=translation,
            rotation=rotation,
            frame="base",
            duration=CARRY_S,
            force_threshold=15.0,
            preset="medium",
        )
        return Step(params, f"cycle {self.cycle}/{self.settings.cycles}, {move}: {why}")

    @property
    def cycle(self) -> int:
        """The cycle under way: the one after those done."""
        return self.exchanges + 1

    def _over(self) -> Pose:
        return self._offset((0.0, 0.0, OVER_M))

    def _offset(self, by_m: tuple[float, float, float]) -> Pose:
        """The first start's pose moved `by_m` in base axes, not turned."""
        (x, y, z), (dx, dy, dz) = self._home().position, by_m
        return Pose((x + dx, y + dy, z + dz), self._home().quaternion)

    def _home(self) -> Pose:
        assert self.home is not None, "next() before first()"
        return self.home

    def figures(self) -> dict[str, float]:
        return {"exchanges": float(self.exchanges)}
