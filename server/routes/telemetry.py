"""WS /api/telemetry: the task frames first, then state at telemetry_hz, an event on every
command status change and a `frames` message on every change of the task frames.

A relaying link may tell the socket its downlink rate (ptwl/guard/link_notice.py): states are
then thinned to what it carries.

Each message gets `sent_at` (server wall clock, Unix seconds) as it leaves, so a client can
measure how old it is on arrival.
"""

import asyncio
import contextlib

from fastapi import APIRouter, WebSocket, WebSocketDisconnect

from ptwl.guard.link_notice import is_notice, parse_notice
from ptwl.guard.outbox import Close, Outbox, is_state
from server.telemetry import Broadcaster, stamped

router = APIRouter(tags=["telemetry"])
CLOSE_INVALID = 1007  # a link notice that does not validate


async def _until_closed(ws: WebSocket, sub: Outbox) -> None:
    """Read the socket until the client leaves; a link notice sets the state rate (others are
    ignored: the socket carries nothing else from a client)."""
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            text = message.get("text")
            if text is not None and is_notice(text):
                try:
                    sub.set_downlink(parse_notice(text))
                except ValueError as err:
                    # A close reason is at most 123 bytes of UTF-8.
                    await ws.close(CLOSE_INVALID, str(err).encode()[:120].decode(errors="ignore"))
                    return


@router.websocket("/api/telemetry")
async def telemetry(ws: WebSocket) -> None:
    await ws.accept()
    broadcaster: Broadcaster = ws.app.state.broadcaster
    sub = broadcaster.subscribe()
    # First the task frames whole: later `frames` messages carry only what changed. Taken after
    # subscribing, so no change falls between (one already in it comes again: older `rev`, skipped).
    sub.put(ws.app.state.runner.frames_text)
    # The sender awaits its outbox alone (no task per message: with 100 clients at 50 Hz that
    # cost more than the sending); the reader of the socket wakes it when the client leaves.
    closed = asyncio.create_task(_until_closed(ws, sub))
    closed.add_done_callback(lambda _: sub.client_gone())
    try:
        while True:
            message = await sub.get()
            if isinstance(message, Close):
                if not sub.gone:
                    await ws.close(message.code, message.reason)
                return
            text = str(message)
            await ws.send_text(stamped(text, sub.thinning_fields() if is_state(text) else ""))
    except (WebSocketDisconnect, RuntimeError):
        return
    finally:
        broadcaster.unsubscribe(sub)
        closed.cancel()
