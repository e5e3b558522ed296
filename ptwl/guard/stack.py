"""The one stack of guards every server of ours puts in front of its routes, outermost first:
who may ask (Host, Origin, token: ptwl/guard/asgi.py), how much (64 KiB: ptwl/guard/body_limit.py), then
strict JSON (ptwl/guard/json_body.py). The robot, the link and the replay all call this."""

from starlette.applications import Starlette

from ptwl.guard.access import AccessPolicy
from ptwl.guard.asgi import AccessGuard
from ptwl.guard.body_limit import BODY_LIMIT_BYTES, BodyLimitMiddleware
from ptwl.guard.json_body import StrictJsonBody


def install_guards(app: Starlette, policy: AccessPolicy) -> None:
    # add_middleware wraps what is there: the last added runs first.
    app.add_middleware(StrictJsonBody)
    app.add_middleware(BodyLimitMiddleware, limit=BODY_LIMIT_BYTES)
    app.add_middleware(AccessGuard, policy=policy)
