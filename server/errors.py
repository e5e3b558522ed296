"""Errors as JSON {"detail": ...}: readable text naming the field, plus a list for programs.

Domain errors become HTTP errors here and only here (STYLE 4).
"""

from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.routing import APIRoute
from starlette.exceptions import HTTPException as StarletteHTTPException

from robot_sim.command_book import FutureSentAtError, QueueFullError
from robot_sim.command_request import error_detail, field_errors
from robot_sim.errors import UnknownNameError
from robot_sim.executor import DecisionError, DecisionInvalid
from server.commands import IdRecordError


def validation_response(errors: list[dict[str, Any]]) -> JSONResponse:
    items = field_errors(errors)
    detail = error_detail(items)
    return JSONResponse({"detail": detail, "errors": items}, status_code=422)


def _methods_for(app: FastAPI, path: str) -> set[str]:
    methods: set[str] = set()
    for route in app.routes:
        if isinstance(route, APIRoute) and route.path_regex.match(path):
            methods |= route.methods or set()
    return methods


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        return validation_response(list(exc.errors()))

    @app.exception_handler(UnknownNameError)
    async def _unknown_name(_: Request, exc: UnknownNameError) -> JSONResponse:
        item = {"field": "body", "message": str(exc), "type": "unknown_name"}
        return JSONResponse({"detail": str(exc), "errors": [item], "valid": exc.valid}, status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        headers = dict(exc.headers or {})
        if exc.status_code == 405:
            # One path can have several routes (GET and POST /api/commands): list them all.
            headers["Allow"] = ", ".join(sorted(_methods_for(app, request.url.path)))
        return JSONResponse({"detail": exc.detail}, status_code=exc.status_code, headers=headers)

    @app.exception_handler(FutureSentAtError)
    async def _future_sent_at(_: Request, exc: FutureSentAtError) -> JSONResponse:
        return validation_response([{"loc": ("body", exc.field), "msg": str(exc), "type": "value_error"}])

    @app.exception_handler(IdRecordError)
    async def _id_record(_: Request, exc: IdRecordError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=503)  # nothing queued; the sim runs on

    @app.exception_handler(DecisionError)
    async def _decision(_: Request, exc: DecisionError) -> JSONResponse:
        # 409: well-formed, but not the decision the robot is waiting for (or none is).
        # 422: it names what the machine has not; 409: well-formed, but not the decision waiting.
        invalid = isinstance(exc, DecisionInvalid)
        item = {
            "field": exc.field,
            "message": str(exc),
            "type": "value_error" if invalid else "decision_conflict",
        }
        return JSONResponse(
            {"detail": f"{exc.field}: {exc}", "errors": [item]}, status_code=422 if invalid else 409
        )

    @app.exception_handler(QueueFullError)
    async def _queue_full(_: Request, exc: QueueFullError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=429, headers={"Retry-After": "1"})
