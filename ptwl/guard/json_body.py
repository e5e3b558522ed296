"""Strict JSON request bodies: duplicate keys and deep nesting are errors, not silent choices.

json.loads keeps the last of two equal keys (so `{"force_threshold": 20, "force_threshold": 1e4}`
means whatever the parser likes) and answers 20k-deep nesting with a RecursionError (a 500).
"""

import json
from typing import Any

from ptwl_config import PtwlError
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from ptwl.guard.respond import send_json

MAX_DEPTH = 32  # our deepest body (a profile's blackout list) is 3 levels


class JsonBodyError(PtwlError, ValueError):
    """Why a body is not acceptable JSON, as the 422 says it."""


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise JsonBodyError(f"duplicate key {key!r}: each field may appear once")
        result[key] = value
    return result


def _depth(value: Any) -> int:
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            deepest = max(deepest, depth)
            children = item.values() if isinstance(item, dict) else item
            stack.extend((child, depth + 1) for child in children)
    return deepest


def parse_json(body: bytes) -> Any:
    try:
        value = json.loads(body, object_pairs_hook=_no_duplicates)
    except RecursionError:
        raise JsonBodyError(f"JSON nested deeper than {MAX_DEPTH} levels") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise JsonBodyError(f"malformed JSON: {err}") from None
    if _depth(value) > MAX_DEPTH:
        raise JsonBodyError(f"JSON nested deeper than {MAX_DEPTH} levels")
    return value


def _is_json(scope: Scope) -> bool:
    for name, value in scope.get("headers", []):
        if name == b"content-type":
            return value.split(b";")[0].strip().lower().endswith(b"json")
    return False


class StrictJsonBody:
    """Check a JSON body before the app parses it; 422 {"detail", "errors"} naming the problem."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not _is_json(scope):
            await self.app(scope, receive, send)
            return
        chunks: list[bytes] = []
        while True:
            message = await receive()
            if message["type"] != "http.request":
                return  # the client went away
            chunks.append(message.get("body", b""))
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        if body:
            try:
                parse_json(body)
            except JsonBodyError as err:
                await _unprocessable(send, str(err))
                return
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)


async def _unprocessable(send: Send, detail: str) -> None:
    item = {"field": "body", "message": detail, "type": "json_invalid"}
    await send_json(send, 422, {"detail": f"body: {detail}", "errors": [item]})
