"""Access token: with a token set, requests need `Authorization: Bearer <token>`.

Browsers cannot set headers on a WebSocket, so the telemetry socket also accepts `?token=`.
No token set (loopback only, enforced at start) means open access.
"""

import hmac
from typing import Annotated

from fastapi import Depends, HTTPException, Request, WebSocket, status


def _check(expected: str | None, presented: str | None) -> None:
    if expected is None:
        return
    if presented is None:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            "missing access token: send Authorization: Bearer <token>",
            headers={"WWW-Authenticate": "Bearer"},
        )
    if not hmac.compare_digest(presented.encode(), expected.encode()):
        raise HTTPException(status.HTTP_403_FORBIDDEN, "access token rejected")


def _bearer(header: str | None) -> str | None:
    if header and header.lower().startswith("bearer "):
        return header[7:].strip()
    return None


def require_token(request: Request) -> None:
    _check(request.app.state.config.token, _bearer(request.headers.get("authorization")))


def websocket_token_ok(ws: WebSocket) -> tuple[bool, int, str]:
    """(allowed, close code, reason) for a telemetry socket."""
    expected = ws.app.state.config.token
    presented = _bearer(ws.headers.get("authorization")) or ws.query_params.get("token")
    try:
        _check(expected, presented)
    except HTTPException as err:
        return False, 4401 if err.status_code == 401 else 4403, str(err.detail)
    return True, 1000, ""


Authorized = Annotated[None, Depends(require_token)]
