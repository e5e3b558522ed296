"""Commands: queue a behavior, follow it, stop everything."""

from typing import Annotated

from fastapi import APIRouter, Body, Header, HTTPException, Query, Request, status
from fastapi.exceptions import RequestValidationError

from ptwl.guard.disconnect import client_gone
from robot_sim.command_request import Command
from robot_sim.machines.command import DecisionRequest, StateMachineParams
from robot_sim.params import GripperParams, PtwlParams
from robot_sim.ptwl_warnings import ptwl_warnings
from server.models import (
    COMMAND_STATUS_RESPONSES,
    DECISION_RESPONSES,
    SENDER_DOC,
    SENDER_HEADER,
    SENDER_PATTERN,
    SIM_RESPONSES,
    SUBMIT_RESPONSES,
    CommandAccepted,
    CommandStatus,
    StopResult,
)
from server.routes.deps import Book, DoneWaiters, Runner, on_sim_thread

router = APIRouter(prefix="/api", tags=["commands"])


MAX_WAIT_S = 60.0


@router.post(
    "/commands",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=CommandAccepted,
    responses=SUBMIT_RESPONSES,
)
async def submit_command(
    request: Request,
    book: Book,
    runner: Runner,
    params: Annotated[Command, Body(discriminator="type")],
    sender: Annotated[
        str | None,
        Header(
            alias=SENDER_HEADER,
            pattern=SENDER_PATTERN,
            description=SENDER_DOC,
        ),
    ] = None,
) -> CommandAccepted:
    """Validate and queue a PTWL, RWE, Dither, a gripper close/open (scenes whose tool has one) or
    a task's state machine (which runs its behaviors as one command, each step announced as it
    ends); commands run in order, one at a time.

    `warnings` says what is accepted but worth knowing (an approach that will overshoot the
    force threshold on impact, a move within its tolerances, a goal the arm cannot reach)."""

    def admit() -> CommandAccepted:
        """(simulation thread) Checked against the scene, its frames and the gains as they are,
        and queued in the same step: a frame cannot vanish between its check and the queue."""
        sim = runner.sim
        needs = params.scene() if isinstance(params, StateMachineParams) else None
        if needs is not None and sim.scene.name != needs:
            message = f"the {needs} state machine needs scene {needs}; {sim.scene.name} is loaded"
            raise RequestValidationError([{"loc": ("body", "task"), "msg": message, "type": "value_error"}])
        if isinstance(params, GripperParams) and sim.scene.gripper is None:
            message = f"the {sim.scene.name} scene's tool has no gripper"
            raise RequestValidationError([{"loc": ("body", "type"), "msg": message, "type": "value_error"}])
        unknown_frames = sim.frames.unknown_errors(params)
        if unknown_frames:
            raise RequestValidationError(unknown_frames)
        # Before the queue: a check that failed after it would answer 500 for a queued command.
        warnings = ptwl_warnings(params, sim) if isinstance(params, PtwlParams) else []
        record = book.submit(params, sender)
        return CommandAccepted(id=record.id, instance=record.instance, warnings=warnings)

    return await on_sim_thread(runner, admit)


@router.get("/commands", response_model=list[CommandStatus])
async def list_commands(
    book: Book, limit: Annotated[int, Query(ge=1, le=1000, description="how many")] = 100
) -> list[CommandStatus]:
    """Recent commands, newest last."""
    return book.recent(limit)


@router.get("/commands/{command_id}", response_model=CommandStatus, responses=COMMAND_STATUS_RESPONSES)
async def get_command(
    request: Request,
    command_id: int,
    book: Book,
    waiters: DoneWaiters,
    wait: Annotated[float, Query(ge=0.0, le=MAX_WAIT_S, description="[s] hold until done, up to this")] = 0.0,
) -> CommandStatus:
    """A command's status; with `wait`, answers as soon as it is done (or when `wait` runs out)."""
    found = book.get(command_id)
    if found is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no command {command_id}")
    if wait > 0.0 and found.status != "done":
        await waiters.until_done(command_id, wait, lambda: book.is_done(command_id), client_gone(request))
        found = book.get(command_id)
        assert found is not None  # a record is kept while it is not done, and we just saw it
    return found


@router.post("/commands/{command_id}/decision", response_model=CommandStatus, responses=DECISION_RESPONSES)
async def decide(command_id: int, decision: DecisionRequest, book: Book, runner: Runner) -> CommandStatus:
    """Answer the running state machine's pending decision (telemetry's `machine.pending`, or
    this command's `machine.pending`): confirm the proposed transition, decide by another
    outcome, force a state, or stop the machine. `decision` names which one, so an answer that
    arrives after the robot has moved on is refused (409), never applied to a later one."""

    if book.get(command_id) is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no command {command_id}")

    def answer() -> CommandStatus:
        runner.decide(command_id, decision)
        found = book.get(command_id)
        assert found is not None  # it was running a moment ago, on this thread
        return found

    return await on_sim_thread(runner, answer)


@router.post("/stop", response_model=StopResult, responses=SIM_RESPONSES)
async def stop(runner: Runner) -> StopResult:
    """Abort the running command, drop the queue, hold the robot where it is."""
    return StopResult(**await on_sim_thread(runner, runner.stop_all))
