"""Dependencies shared by the routers: the running pieces, from app.state."""

import asyncio
from collections.abc import Callable
from typing import Annotated, TypeVar

from fastapi import Depends, HTTPException, Request, status

from server.commands import CommandBook
from server.runner import SimRunner
from server.waiters import Waiters


def _runner(request: Request) -> SimRunner:
    return request.app.state.runner


def _book(request: Request) -> CommandBook:
    return request.app.state.book


def _waiters(request: Request) -> Waiters:
    return request.app.state.waiters


Runner = Annotated[SimRunner, Depends(_runner)]
Book = Annotated[CommandBook, Depends(_book)]
DoneWaiters = Annotated[Waiters, Depends(_waiters)]


T = TypeVar("T")
SIM_THREAD_TIMEOUT_S = 5.0


async def on_sim_thread(runner: SimRunner, action: Callable[[], T]) -> T:
    """Run `action` between simulation batches and await its result (503 if the thread is gone)."""
    try:
        return await asyncio.wait_for(asyncio.wrap_future(runner.call(action)), SIM_THREAD_TIMEOUT_S)
    except TimeoutError:
        raise HTTPException(
            status.HTTP_503_SERVICE_UNAVAILABLE, "simulation thread is not responding"
        ) from None
