"""Task frames: list the loaded scene's, add an operator's, delete one no command names."""

from fastapi import APIRouter, HTTPException, Response, status

from robot_sim.behaviors.base import Pose
from robot_sim.errors import UnknownNameError
from robot_sim.task_frames import FrameInUseError, FrameLimitError, TaskFrame, frame_dict
from robot_sim.telemetry import FRAMES_REV_HEADER
from server.models import (
    ADD_FRAME_RESPONSES,
    FRAME_NOT_FOUND_RESPONSES,
    SIM_RESPONSES,
    FrameModel,
    FrameRequest,
)
from server.routes.deps import Runner, on_sim_thread

router = APIRouter(prefix="/api", tags=["frames"])


def _model(frame: TaskFrame) -> FrameModel:
    return FrameModel.model_validate(frame_dict(frame))


_LISTED = {
    "description": "the task frames",
    "headers": {
        FRAMES_REV_HEADER: {
            "description": "the `rev` of the telemetry `frames` message this list matches",
            "schema": {"type": "integer"},
        }
    },
}


@router.get("/frames", response_model=list[FrameModel], responses={200: _LISTED, **SIM_RESPONSES})
async def list_frames(runner: Runner, response: Response) -> list[FrameModel]:
    """The loaded scene's task frames: its own (on fixtures, where the seed put them), then the
    operators'. Commands name them in `frame` and `gains_frame`, beside `tool` and `base`."""
    frames, rev = await on_sim_thread(runner, runner.frames_listed)
    response.headers[FRAMES_REV_HEADER] = str(rev)
    return [_model(f) for f in frames]


@router.post(
    "/frames",
    status_code=status.HTTP_201_CREATED,
    response_model=FrameModel,
    responses=ADD_FRAME_RESPONSES,
)
async def add_frame(body: FrameRequest, runner: Runner) -> FrameModel:
    """Add a task frame at the tool's pose now (`"pose": "tool"`) or at a typed pose. It lasts
    until deleted or the scene is reset; every telemetry client hears of it (`frames` message).
    A scene holds at most 64 operators' frames (task_frames.MAX_OPERATOR_FRAMES; 409 past it)."""
    pose = None
    if not isinstance(body.pose, str):
        pose = Pose.of(body.pose.position, body.pose.quaternion)
    try:
        frame = await on_sim_thread(runner, lambda: runner.add_frame(body.name, pose))
    except (FrameInUseError, FrameLimitError) as err:
        raise HTTPException(status.HTTP_409_CONFLICT, str(err)) from None
    return _model(frame)


@router.delete("/frames/{name}", response_model=FrameModel, responses=FRAME_NOT_FOUND_RESPONSES)
async def delete_frame(name: str, runner: Runner) -> FrameModel:
    """Delete an operator's frame; a scene's own, or one a queued or running command names, stays
    (409)."""
    try:
        frame = await on_sim_thread(runner, lambda: runner.remove_frame(name))
    except UnknownNameError as err:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(err)) from None
    except FrameInUseError as err:
        raise HTTPException(status.HTTP_409_CONFLICT, str(err)) from None
    return _model(frame)
