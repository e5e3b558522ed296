"""Errors as JSON {"detail": ...}: readable text naming the field, plus a list for programs.

Domain errors become HTTP errors here and only here (STYLE 4).
"""

from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from robot_sim.errors import UnknownNameError
from server.commands import QueueFullError

_TAGS = {"ptwl", "rwe", "dither"}


def _field(loc: tuple[Any, ...]) -> str:
    """`body.ptwl.duration` -> `duration`; list indices as `translation[1]`."""
    parts = [p for p in loc if p not in ("body", "query", "path") and p not in _TAGS]
    text = ""
    for part in parts:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "body"


def _message(err: dict[str, Any]) -> str:
    msg = str(err.get("msg", "invalid")).removeprefix("Value error, ")
    if err.get("type") == "json_invalid":
        ctx = err.get("ctx") or {}
        return f"malformed JSON: {ctx.get('error', msg)}"
    if err.get("type") == "union_tag_invalid":
        return msg + " (field `type`)"
    return msg


def validation_response(errors: list[dict[str, Any]]) -> JSONResponse:
    items = [
        {"field": _field(tuple(e.get("loc", ()))), "message": _message(e), "type": e.get("type")}
        for e in errors
    ]
    detail = "; ".join(f"{i['field']}: {i['message']}" for i in items)
    return JSONResponse({"detail": detail, "errors": items}, status_code=422)


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        return validation_response(list(exc.errors()))

    @app.exception_handler(UnknownNameError)
    async def _unknown_name(_: Request, exc: UnknownNameError) -> JSONResponse:
        return JSONResponse({"detail": str(exc), "valid": exc.valid}, status_code=422)

    @app.exception_handler(QueueFullError)
    async def _queue_full(_: Request, exc: QueueFullError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=429, headers={"Retry-After": "1"})
