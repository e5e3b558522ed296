"""Noticing that an HTTP client went away, so work held for it can stop."""

from starlette.requests import Request


async def client_gone(request: Request) -> None:
    """Returns when the client disconnects. Call it once the body is read: nothing else can arrive."""
    while (await request.receive())["type"] != "http.disconnect":
        pass
