"""When the ghost can be believed. Its readout judged predictions that came true (or not); the
ghost is marked UNSURE whenever that judgment does not cover what it shows now:

- its thread is behind the wall clock by more than LAG_LIMIT_S (a busy machine: the ghost froze
  while the delayed picture moved past it),
- a STOP is on its way (the twin still replays the move STOP ends, until the robot confirms),
- no prediction was judged for JUDGED_WITHIN_S (after a scene reset, before re-syncing; after a
  jam the twin did not foresee; before the first state came back).
"""

from dataclasses import dataclass

from web.twin import GroundTwin
from web.twin_judge import describe_error

LAG_LIMIT_S = 0.2
JUDGED_WITHIN_S = 1.0  # states come every 20 ms, each judging a prediction: a second is many


@dataclass(frozen=True)
class TwinTrust:
    sure: bool
    reason: str = ""  # why not, in the operator's words


def judge_twin(
    now_wall: float,
    advanced_wall: float | None,
    judged_wall: float | None,
    stop_sent_wall: float | None,
) -> TwinTrust:
    """[s] Unix times: now, the twin's last step to "now", its last judged prediction, a STOP
    sent and not yet confirmed."""
    if stop_sent_wall is not None:
        return TwinTrust(False, f"STOP sent {now_wall - stop_sent_wall:.1f} s ago, not confirmed yet")
    if advanced_wall is None:
        return TwinTrust(False, "not started")
    lag_s = now_wall - advanced_wall
    if lag_s > LAG_LIMIT_S:
        return TwinTrust(False, f"{lag_s:.1f} s behind (the machine is busy)")
    if judged_wall is None:
        return TwinTrust(False, "not judged yet")
    if now_wall - judged_wall > JUDGED_WITHIN_S:
        return TwinTrust(False, f"not judged for {now_wall - judged_wall:.1f} s")
    return TwinTrust(True)


def ghost_label(trust: TwinTrust, readout: str) -> str:
    """The ghost's own label, short (it floats in the view; the bar's twin line says why)."""
    return f"predicted · {readout}" if trust.sure else "predicted · UNSURE (the status bar says why)"


def twin_readout(now_wall: float, twin: GroundTwin) -> tuple[TwinTrust, str]:
    """The twin's trust now and its readout: how far off its judged predictions were, or why it
    cannot be believed now (with the last judgment, if any)."""
    trust = judge_twin(now_wall, twin.advanced_wall, twin.judged_wall(), twin.stop_sent_wall)
    judged = describe_error(twin.error_summary())
    registered = twin.registered  # once: the twin's thread replaces it
    # The twin's model is not the nominal one: say how not.
    model = "" if registered is None else f"; {registered.describe()}"
    if trust.sure:
        return trust, judged + model
    last = "" if judged == "not judged yet" else f" (last judged: {judged})"
    return trust, f"UNSURE: {trust.reason}{last}{model}"
