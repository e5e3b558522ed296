"""One simulated robot: MuJoCo physics, the admittance controller and the behavior runner.

Pacing is not here: `step()` advances one control period as fast as the CPU allows; the
server paces it to real time, sweeps do not.

Per control period (control_dt = n_substeps * physics_dt), compiled (tick.py):
    measure                  compensated wrench from the sensor
    _move_attractor          the behavior moves the attractor, may end with an exit condition
    command                  eq. 5 + DLS -> joint-velocity servo commands
    mj_step x n_substeps     physics with those commands held

`advance` runs many periods in one call and comes back to Python only where Python decides:
a behavior's end, a task-monitor window, a fault, or a scene's mechanism after every tick.

Kinematics and sensors in MjData are those mj_step computed at the start of its last step,
so the controller sees the robot 1 ms late, as it would a real sensor and servo bus.
"""

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from robot_sim import tick
from robot_sim.arm import ArmLayout
from robot_sim.behaviors.base import Behavior, BehaviorReport, ExitCondition, Pose
from robot_sim.behaviors.gripper import Gripper
from robot_sim.controller import FT_CUTOFF_HZ, AdmittanceController
from robot_sim.errors import RobotSimError
from robot_sim.gains import Gains
from robot_sim.held_back import held_back_detail
from robot_sim.model import PHYSICS_TIMESTEP_S, build_model
from robot_sim.payload import Payload
from robot_sim.presets import default_presets
from robot_sim.scenes import Scene, TaskProgress, apply_seed, get_scene
from robot_sim.scenes.grasp import actuate, check_close_time, close_time, set_close_time, takes_close_time
from robot_sim.task_frames import TaskFrame, TaskFrames, scene_frames, unit_quaternion
from robot_sim.task_monitor import FrictionMonitor

# `advance`'s bound when the run ends on a sim time or a behavior's end instead
UNBOUNDED_TICKS = 2**62
SETTLE_S = 0.3  # [s] physics in position hold at every (re)load, before compliance starts


def default_gains() -> Gains:
    """The config's default stiffness/damping preset."""
    presets = default_presets()
    return presets.stiffness_preset(presets.default_stiffness).to_gains()


@dataclass(frozen=True)
class RobotState:
    """What telemetry reports: the API contract's state fields, SI units, base frame."""

    sim_time: float
    port: Pose
    attractor: Pose
    wrench: tuple[float, ...]  # (6,) environment on port [N, N m]
    joint_positions: tuple[float, ...]  # (6,) [rad]
    manipulability: float
    scene: str
    behavior: str | None
    limited: str | None  # what holds the motion back now (singularity, joint_limit, speed)


def _warnings(data: mujoco.MjData) -> str:
    names = [
        name.removeprefix("mjWARN_")
        for name, value in mujoco.mjtWarning.__members__.items()
        if name != "mjNWARNING" and data.warning[int(value)].number > 0
    ]
    return ", ".join(names) or "no warning recorded"


def _pose(position: np.ndarray, quaternion: np.ndarray) -> Pose:
    p = (float(position[0]), float(position[1]), float(position[2]))
    q = (float(quaternion[0]), float(quaternion[1]), float(quaternion[2]), float(quaternion[3]))
    return Pose(p, q)


class Simulation:
    """A scene with the arm under admittance control, running one behavior at a time."""

    def __init__(
        self,
        scene: str = "free_space",
        seed: int | None = None,
        *,
        gains: Gains | None = None,
        control_hz: float = 1000.0,
        qpos: "tuple[float, ...] | None" = None,
        ft_cutoff_hz: float | None = FT_CUTOFF_HZ,
        gripper_close_s: float | None = None,
    ) -> None:
        """Args:
        scene: a name from robot_sim.scenes.SCENES.
        seed: jitters the scene's fixture (None: nominal layout).
        gripper_close_s: the gripper's closing time constant [s] (None: the scene's own; see
            robot_sim/scenes/grasp.py), on a scene whose tool has a gripper.
        gains: initial stiffness/damping (default: the config's default preset).
        control_hz: control rate [Hz], >= 500 and a divisor of the 1 kHz physics rate.
        qpos: initial joint positions [rad] (default: the scene's home).
        ft_cutoff_hz: low-pass cutoff on the F/T signal the controller uses [Hz]; None: raw.
        """
        substeps = 1.0 / (control_hz * PHYSICS_TIMESTEP_S)
        if control_hz < 500.0 or abs(substeps - round(substeps)) > 1e-9:
            raise RobotSimError(
                f"control_hz must be >= 500 and divide the {1 / PHYSICS_TIMESTEP_S:.0f} Hz physics rate, "
                f"got {control_hz}"
            )
        self.n_substeps = round(substeps)
        self.control_dt = self.n_substeps * PHYSICS_TIMESTEP_S
        self.ft_cutoff_hz = ft_cutoff_hz
        self.fault_count = 0
        self.last_fault: str | None = None
        self.controller: AdmittanceController
        self.last_report: BehaviorReport | None = None  # kept across resets: how the last one ended
        self.reset(
            scene,
            seed,
            gains=gains if gains is not None else default_gains(),
            qpos=qpos,
            gripper_close_s=gripper_close_s,
        )

    # ------------------------------------------------------------------------- scenes
    def reset(
        self,
        scene: str,
        seed: int | None = None,
        *,
        gains: Gains | None = None,
        qpos: "tuple[float, ...] | None" = None,
        gripper_close_s: float | None = None,
    ) -> None:
        """Load `scene` fresh, arm at home (or `qpos` [rad]), compliance on, attractor on the port.
        `gripper_close_s` [s]: the gripper's closing time constant (None: the scene's own)."""
        spec: Scene = get_scene(scene)
        check_close_time(spec.name, spec.gripper, gripper_close_s)  # before anything is lost
        model = build_model(spec.scene_file, spec.tool_file)
        apply_seed(spec, model, seed)
        if gripper_close_s is not None and spec.gripper is not None:  # checked above: it takes one
            set_close_time(model, spec.gripper, gripper_close_s)
        data = mujoco.MjData(model)
        layout = ArmLayout.from_model(model)
        start = spec.home_qpos if qpos is None else qpos
        data.qpos[layout.qpos_adr] = start
        data.act[layout.act_adr] = start
        # Let the servos take up the tool's weight in position hold before compliance starts:
        # otherwise the arm sags ~0.1 mm and creeps for a second after every reset, and a
        # command sent right away starts from a port that is still moving.
        mujoco.mj_step(model, data, round(SETTLE_S / PHYSICS_TIMESTEP_S))
        data.time = 0.0
        mujoco.mj_forward(model, data)
        self.scene = spec
        self.seed = seed
        self.gripper_close_s = gripper_close_s
        self.model = model
        self.data = data
        self.layout = layout
        # the scene's own logic, run every tick (a latch, a lock's spring, what the bay has seen)
        self.mechanism = spec.mechanism(model) if spec.mechanism is not None else None
        self.payload = Payload.from_model(model, layout)
        # The scene's own frames where the seed put its fixtures; an operator's are added here.
        self.frames: TaskFrames = scene_frames(spec.name, model, data)
        keep: Gains = gains if gains is not None else self.controller.gains
        if keep.frame not in self.frames.names():  # the last scene's frame, gone with it
            keep = keep.in_frame("base")
        self.controller = AdmittanceController(
            model,
            data,
            layout,
            self.payload,
            self.frames.resolve_gains(keep),
            self.control_dt,
            self.ft_cutoff_hz,
        )
        self.controller.enable()
        self.behavior: Behavior | None = None
        self._behavior_started_at = 0.0
        self._behavior_detail = ""  # what the running behavior's report will say (a grasp)
        self.monitor: FrictionMonitor | None = None  # the last behavior's task monitor, if it had one

    @property
    def time(self) -> float:
        return float(self.data.time)

    def sync_to(
        self,
        sim_time_s: float,
        joint_positions: "tuple[float, ...] | list[float]",
        attractor: Pose,
        gains: Gains,
    ) -> None:
        """Put this simulation where another's telemetry says it was: a ground twin's start
        (web/twin.py). Telemetry has no joint velocities, so the arm starts at rest; in free
        space the difference dies out with the admittance's time constant. Any behavior ends
        (nothing is reported: the twin re-issues what should run)."""
        self.behavior = None
        self.controller.i[tick.RUNNING] = 0
        data, layout, ctl = self.data, self.layout, self.controller
        data.qpos[layout.qpos_adr] = joint_positions
        data.qvel[:] = 0.0
        data.act[layout.act_adr] = joint_positions
        data.time = sim_time_s
        mujoco.mj_forward(self.model, data)
        ctl.set_gains(self.frames.resolve_gains(gains))
        ctl.enable()
        ctl.p_world_attractor[:] = attractor.position
        ctl.q_world_attractor[:] = attractor.quaternion
        ctl.measure_stretch()

    # -------------------------------------------------------------------------- steps
    def step(self) -> BehaviorReport | None:
        """Advance one control period; returns the report if a behavior ended in it."""
        return self.advance(1)[0]

    def advance(self, max_ticks: int, until_s: float = math.inf) -> tuple[BehaviorReport | None, int]:
        """Run up to `max_ticks` control periods (at least one), stopping after one in which a
        behavior ended (or a fault reloaded the scene) or that ended at or past sim time `until_s`
        [s]; (that report or None, the periods run)."""
        ctl = self.controller
        mj, f, i, n_substeps = ctl.mj, ctl.f, ctl.i, self.n_substeps
        max_ticks, until_s = int(max_ticks), float(until_s)  # the types the loop is compiled for
        per_call = max_ticks if self.mechanism is None else 1  # a mechanism acts after every tick
        done = 0
        while done < max_ticks:
            ran = tick.run_ticks(mj, f, i, min(per_call, max_ticks - done), n_substeps, until_s)
            report = None
            stop = int(i[tick.STOP])
            if i[tick.MID_TICK]:
                report = self._decide(stop)
                stop = tick.finish_tick(mj, f, i, n_substeps)
                ran += 1
            done += ran
            if self.mechanism is not None and stop != tick.Stop.NON_FINITE:
                self.mechanism(self.data)
            if stop == tick.Stop.NON_FINITE:
                return self._recover_from_fault("non-finite wrench, stretch or joint position"), done
            if stop == tick.Stop.UNSTABLE:
                message = f"MuJoCo found the simulation unstable: {_warnings(self.data)}"
                return self._recover_from_fault(message), done
            if report is not None or self.data.time >= until_s:
                return report, done
        return None, done

    def _decide(self, stop: int) -> BehaviorReport | None:
        """Python's part of a tick the loop stopped in before the servos: a behavior's end, or a
        task-monitor window to judge."""
        behavior = self.behavior
        assert behavior is not None
        monitor = self.monitor
        if stop == tick.Stop.MONITOR_WINDOW:
            assert monitor is not None
            anomaly = monitor.update(self.controller)
            return self._finish(ExitCondition.ANOMALY, monitor.detail()) if anomaly else None
        return self._finish(behavior.exit_for(self.controller, stop))

    def run(self, seconds: float) -> list[BehaviorReport]:
        """Step for `seconds` of sim time; the reports of behaviors that ended meanwhile."""
        reports = []
        left = round(seconds / self.control_dt)
        while left > 0:
            report, ran = self.advance(left)
            left -= ran
            if report is not None:
                reports.append(report)
        return reports

    # ---------------------------------------------------------------------- behaviors
    def start(self, behavior: Behavior) -> BehaviorReport | None:
        """Start `behavior` now, preempting any running one.

        The behavior starts from the attractor where it is (or, bringing other stiffness, where
        the new spring pulls as the old one did), so nothing jumps: a held force carries into
        the new command.

        Returns:
            The preempted behavior's report (exit `aborted`, detail "preempted"), or None.
        """
        preempted = self.abort("preempted") if self.behavior is not None else None
        if not self.controller.enabled:
            self.controller.enable()  # bumpless from position hold
        self.behavior = behavior
        self._behavior_started_at = self.time
        self._behavior_detail = ""
        spec = behavior.monitor_spec()
        ctl = self.controller
        self.monitor = FrictionMonitor(spec, self.control_dt) if spec is not None else None
        behavior.start(ctl, self.time, self.frames)
        ctl.start_running(self.monitor.ticks_per_window if self.monitor is not None else 0)
        if isinstance(behavior, Gripper):
            self._behavior_detail = self._actuate_gripper(behavior.params.action)
        return preempted

    def gripper_close_time_s(self) -> float | None:
        """The loaded gripper's closing time constant [s] (the scene's own unless set); None: no
        gripper that closes on a part (none, or a grasp held from the start)."""
        gripper = self.scene.gripper
        return close_time(self.model, gripper) if gripper is not None and takes_close_time(gripper) else None

    def _actuate_gripper(self, action: str) -> str:
        gripper = self.scene.gripper
        if gripper is None:
            return f"the {self.scene.name} scene's tool has no gripper"
        return actuate(self.model, self.data, gripper, self.layout.port_site, action)

    def abort(self, detail: str = "aborted") -> BehaviorReport | None:
        """End the running behavior `aborted`; the attractor freezes where it is."""
        if self.behavior is None:
            return None
        return self._finish(ExitCondition.ABORTED, detail)

    def run_behavior(self, behavior: Behavior, max_seconds: float = 700.0) -> BehaviorReport:
        """Start `behavior` and step until it ends (its watchdog ends it in bounded time)."""
        self.start(behavior)
        left = round(max_seconds / self.control_dt)
        while left > 0:
            report, ran = self.advance(left)
            if report is not None:
                return report
            left -= ran
        report = self.abort(f"still running after {max_seconds} s")
        assert report is not None
        return report

    def _finish(self, exit_condition: ExitCondition, detail: str = "") -> BehaviorReport:
        assert self.behavior is not None
        ctl = self.controller
        if not detail:
            detail = self._behavior_detail
        if not detail:
            short = self.behavior.shortfall(ctl) if exit_condition is not ExitCondition.GOAL_REACHED else ""
            held_back = held_back_detail(ctl.held_seconds(), ctl.held_joint_ends(), self.layout.joint_range)
            detail = "; ".join(part for part in (short, held_back) if part)
        report = BehaviorReport(
            behavior=self.behavior.kind,
            exit=exit_condition,
            started_at=self._behavior_started_at,
            ended_at=self.time,
            peak_force=float(ctl.f[tick.PEAK_FORCE]),
            peak_torque=float(ctl.f[tick.PEAK_TORQUE]),
            final_wrench=tuple(float(v) for v in ctl.w_world_env_on_port),
            final_port=_pose(ctl.p_world_port, ctl.q_world_port),
            detail=detail,
        )
        self.behavior = None  # the attractor stays where the behavior left it
        ctl.stop_running()
        self.last_report = report
        return report

    def _recover_from_fault(self, message: str) -> BehaviorReport | None:
        """End the behavior `fault` and reload the scene at home: a safe, known state."""
        self.fault_count += 1
        self.last_fault = message
        report = self._finish(ExitCondition.FAULT, message) if self.behavior is not None else None
        self.reset(self.scene.name, self.seed, gripper_close_s=self.gripper_close_s)
        return report

    def add_operator_frame(self, name: str, pose: Pose | None = None) -> TaskFrame:
        """An operator's task frame at `pose`, or at the port's pose now (None); it lasts until
        deleted or the scene (re)loads (a reset, a fault)."""
        if pose is None:
            pose = self.state().port
            defined_by = f"tool pose at sim time {self.time:.3f} s"
        else:
            defined_by = "typed pose"
        frame = TaskFrame(name, pose.position, unit_quaternion(pose.quaternion), "operator", defined_by)
        self.frames.add(frame)
        return frame

    # -------------------------------------------------------------------------- state
    def state(self) -> RobotState:
        ctl = self.controller
        return RobotState(
            sim_time=self.time,
            port=_pose(ctl.p_world_port, ctl.q_world_port),
            attractor=_pose(ctl.p_world_attractor, ctl.q_world_attractor),
            wrench=tuple(float(v) for v in ctl.w_world_env_on_port),
            joint_positions=tuple(float(v) for v in self.data.qpos[self.layout.qpos_adr]),
            manipulability=ctl.manipulability,
            scene=self.scene.name,
            behavior=self.behavior.kind if self.behavior is not None else None,
            limited=ctl.limited.value if ctl.limited is not None else None,
        )

    def task(self) -> TaskProgress:
        return self.scene.predicate(self)

    def hold_position(self) -> BehaviorReport | None:
        """Stop: end any behavior `aborted` and hold the port where it is.

        The attractor goes where its virtual wrench balances the measured one (the bumpless
        rule): in free space that is the port pose, so motion stops; in contact the held force
        stays, so STOP never jerks a press off or into a surface.
        """
        report = self.abort("stopped")
        ctl = self.controller
        if ctl.enabled:
            ctl.balance(ctl.control_wrench())
        else:
            ctl.enable()
        return report
