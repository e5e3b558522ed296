"""Test hooks, mounted only with `ptwl serve --fault-injection`."""

from fastapi import APIRouter

from server.routes.deps import Runner, on_sim_thread

router = APIRouter(prefix="/api/_debug", tags=["debug"], include_in_schema=False)


@router.post("/fault")
async def inject_fault(runner: Runner) -> dict[str, str]:
    """Poison the physics (NaN velocity) so the next step faults, as a diverging simulation would."""
    await on_sim_thread(runner, runner.inject_fault)
    return {"detail": "NaN injected into qvel"}
