"""The one stack of guards every server of ours puts in front of its routes, outermost first:
who may ask (Host, Origin, token: guard/asgi.py), how much (64 KiB: guard/body_limit.py), then
strict JSON (guard/json_body.py). The robot, the link and the replay all call this."""

from starlette.applications import Starlette

from guard.access import AccessPolicy
from guard.asgi import AccessGuard
from guard.body_limit import BODY_LIMIT_BYTES, BodyLimitMiddleware
from guard.json_body import StrictJsonBody


def install_guards(app: Starlette, policy: AccessPolicy) -> None:
    # add_middleware wraps what is there: the last added runs first.
    app.add_middleware(StrictJsonBody)
    app.add_middleware(BodyLimitMiddleware, limit=BODY_LIMIT_BYTES)
    app.add_middleware(AccessGuard, policy=policy)
