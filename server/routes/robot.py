"""The robot's state, its task progress, health and presets."""

from typing import Any

from fastapi import APIRouter

from robot_sim.telemetry import task_fields
from server.catalog import preset_catalog
from server.models import SIM_RESPONSES, HealthModel, RobotStateModel, TaskModel
from server.routes.deps import Book, DoneWaiters, Runner, on_sim_thread

router = APIRouter(prefix="/api", tags=["robot"])


@router.get("/health", response_model=HealthModel)
async def health(runner: Runner, book: Book, waiters: DoneWaiters) -> HealthModel:
    """Liveness. `faults` counts simulation faults (each reset the scene); `instance` changes
    when the server restarts."""
    state = runner.latest_state
    return HealthModel(
        status="ok",
        sim_time=state["sim_time"],
        faults=state["faults"],
        last_fault=runner.last_fault,
        real_time_lag=runner.real_time_lag(),
        queued=book.queued_count(),
        instance=book.instance,
        long_polls=len(waiters),
    )


@router.get("/state", response_model=RobotStateModel)
async def state(runner: Runner) -> dict[str, Any]:
    """The latest telemetry state (at most one telemetry period old; see `sim_time`)."""
    return runner.latest_state


@router.get("/task", response_model=TaskModel, responses=SIM_RESPONSES)
async def task(runner: Runner) -> TaskModel:
    """The scene's success predicate, evaluated now."""

    def evaluate() -> TaskModel:
        progress = runner.sim.task()
        return TaskModel(scene=runner.sim.scene.name, **task_fields(progress))

    return await on_sim_thread(runner, evaluate)


@router.get("/presets")
async def presets() -> dict[str, Any]:
    """Stiffness/damping presets by name, `{name: {stiffness, damping}}`, plus the dither presets
    under `dither`."""
    return preset_catalog()
