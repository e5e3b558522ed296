"""Scenes: list them, reset to one; the tasks with an onboard state machine."""

from fastapi import APIRouter

from server.catalog import scene_catalog, task_catalog
from server.models import SIM_RESPONSES, GeometryModel, SceneModel, SceneRequest, StopResult, TaskInfoModel
from server.routes.deps import Runner, on_sim_thread

router = APIRouter(prefix="/api", tags=["scenes"])


@router.get("/scenes", response_model=list[SceneModel])
async def scenes() -> list[SceneModel]:
    return scene_catalog()


@router.get("/tasks", response_model=list[TaskInfoModel])
async def tasks() -> list[TaskInfoModel]:
    """Tasks whose state machine runs onboard as one command: `POST /api/commands` with
    `{"type": "state_machine", "task": NAME}` while the scene NAME is loaded."""
    return task_catalog()


@router.post("/scene", response_model=StopResult, responses=SIM_RESPONSES)
async def reset_scene(body: SceneRequest, runner: Runner) -> StopResult:
    """Stop everything (running and queued commands end `aborted`) and load the scene fresh."""
    return StopResult(
        **await on_sim_thread(runner, lambda: runner.reset_scene(body.name, body.seed, body.gripper_close_s))
    )


@router.get("/geometry", response_model=GeometryModel, responses=SIM_RESPONSES)
async def geometry(runner: Runner) -> GeometryModel:
    """The loaded scene's geoms and bodies, to draw it; moving bodies' poses come with telemetry."""

    return GeometryModel(**await on_sim_thread(runner, runner.geometry))
