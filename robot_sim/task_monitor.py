"""The force task monitor onboard (the teleoperation paper's 2.4.1 and 2.5.2), opt-in per
behavior (`monitor` in PTWL and Dither; MonitorSpec in params.py says what each setting does).

The friction model: while the port slides on a surface, the force along it is
F_t = mu |F_n| + c (Coulomb friction plus a constant, the paper's cutting force). The monitor
samples the measured force every 10 ms (the mean over the window, which also filters it),
learns (mu, c) by recursive least squares with a forgetting factor each (rls.py), and once it
has slid for `warmup` judges each sample against the prediction made before seeing it: outside
max(band_fraction |F_t_hat|, band_min) for `persist` is an anomaly. It neither learns nor judges
out of contact or while not sliding (the model holds only while sliding), and never learns
from a sample outside the band, so a jam cannot teach it that jamming is normal.

It also does not judge where it would be blind: below the normal force at which its band's
floor (`band_min`) is as wide as the friction force itself, even a doubling of friction (a rough
patch) stays inside the band. There it does not judge friction and does not learn (what it
cannot see it would learn as normal), but a force past the band is still a jam; it says so
(`not_judging`: "normal force 1.80 N < 3.33 N") instead of passing silently; out of contact it
says the same against `min_normal_force`.
"""

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_sim import tick
from robot_sim.controller import AdmittanceController
from robot_sim.params import MonitorSpec
from robot_sim.rls import VectorForgettingRls

WINDOW_S = 0.01  # [s] one sample per window: the mean force and the port's travel over it
# Initial covariance of (mu, c), both starting at 0: mu unknown, c believed within about +-1 N.
# Slid at a constant normal force, mu |F_n| + c cannot tell mu from c; equal priors split the
# force between them (at 4 N: mu 0.25-0.28 read for a true 0.3, and noise drifting along the
# unseen direction read 0.35), while a tighter prior on c gives it to mu (0.296 after 3 s). A
# real constant force is still learned once the normal force varies. Each is also its cap.
VARIANCE0 = np.array([100.0, 1.0])
MAX_VARIANCE = VARIANCE0


@dataclass
class Sample:
    normal_n: float  # [N] |F_n|
    tangential_n: float  # [N] |F_t|
    speed_m_s: float  # [m/s] port speed along the surface


class FrictionMonitor:
    def __init__(self, spec: MonitorSpec, control_dt_s: float) -> None:
        self.spec = spec
        self._normal = np.asarray(spec.normal, dtype=float)
        self.ticks_per_window = max(1, round(WINDOW_S / control_dt_s))
        self._window_s = self.ticks_per_window * control_dt_s
        self.rls = VectorForgettingRls(np.zeros(2), VARIANCE0, np.asarray(spec.forgetting), MAX_VARIANCE)
        self.learned_s = 0.0  # [s] of sliding in contact learned from
        self.outside_s = 0.0  # [s] outside the band, in a row
        self.last: Sample | None = None
        self.predicted_n = 0.0
        self.band_n = 0.0
        self.judging = False
        self.not_judging: str | None = None  # why it is blind now ("normal force X N < Y N")
        self.anomaly = False

    @property
    def mu(self) -> float:
        return float(self.rls.theta[0])

    @property
    def c_n(self) -> float:
        return float(self.rls.theta[1])

    def update(self, ctl: AdmittanceController) -> bool:
        """(every full window: the compiled loop sums the force over its ticks, tick.py) True
        when this window's sample is an anomaly. Starts the next window."""
        f, i = ctl.f, ctl.i
        force_sum = f[tick.MONITOR_FORCE_SUM : tick.MONITOR_FORCE_SUM + 3]
        p_start = f[tick.MONITOR_P_START : tick.MONITOR_P_START + 3]
        force = force_sum / i[tick.MONITOR_TICKS]
        travel = ctl.p_world_port - p_start
        force_sum[:] = 0.0
        i[tick.MONITOR_TICKS] = 0
        p_start[:] = ctl.p_world_port
        normal_n = float(force @ self._normal)
        tangential = force - normal_n * self._normal
        along = travel - float(travel @ self._normal) * self._normal
        sample = Sample(
            abs(normal_n), float(np.linalg.norm(tangential)), float(np.linalg.norm(along)) / self._window_s
        )
        self.last = sample
        return self._judge(sample)

    def judging_floor_n(self) -> float:
        """[N] the normal force below which it cannot judge: in contact, and where the friction
        it has learned, mu |F_n| + c, is at least the band's floor (a doubling would leave it)."""
        spec = self.spec
        if self.c_n >= spec.band_min:  # the constant force alone fills the band's floor
            return spec.min_normal_force
        if self.mu <= 0.0:  # no press is enough
            return math.inf
        return max(spec.min_normal_force, (spec.band_min - self.c_n) / self.mu)

    def _judge(self, sample: Sample) -> bool:
        spec = self.spec
        if sample.normal_n < spec.min_normal_force:  # out of contact: no model to hold
            self.outside_s = 0.0
            self.judging = False
            self.not_judging = f"normal force {sample.normal_n:.2f} N < {spec.min_normal_force:.2f} N"
            return False
        sliding = sample.speed_m_s >= spec.min_speed
        phi = np.array([sample.normal_n, 1.0])
        self.predicted_n = self.rls.predict(phi)
        self.band_n = max(spec.band_fraction * abs(self.predicted_n), spec.band_min)
        learned = self.learned_s >= spec.warmup
        floor_n = self.judging_floor_n()
        blind = learned and sample.normal_n < floor_n
        self.not_judging = f"normal force {sample.normal_n:.2f} N < {floor_n:.2f} N" if blind else None
        self.judging = learned and not blind
        residual_n = sample.tangential_n - self.predicted_n
        # Stuck, friction may hold anything up to mu |F_n|: only a force above the band (a jam)
        # is off the model. Sliding, it is off on either side (the paper's "higher or lower").
        # Blind to a change of friction, a force past the band is still a jam.
        off = residual_n > self.band_n or (self.judging and sliding and residual_n < -self.band_n)
        if learned and off:
            self.outside_s += self._window_s
            self.anomaly = self.outside_s >= spec.persist - 1e-9
            return self.anomaly
        self.outside_s = 0.0
        if blind:  # nor learns: a rough patch it cannot see would be learned as normal
            return False
        if sliding:  # learn from sliding samples (once judging, only those on the model: see above)
            self.rls.update(phi, sample.tangential_n)
            self.learned_s += self._window_s
        return False

    def detail(self) -> str:
        """What the anomaly was, for the behavior's report."""
        s = self.last
        measured = s.tangential_n if s is not None else float("nan")
        normal = s.normal_n if s is not None else float("nan")
        return (
            f"force task monitor: tangential force {measured:.2f} N at normal {normal:.2f} N, "
            f"predicted {self.predicted_n:.2f} +- {self.band_n:.2f} N (mu {self.mu:.3f}, c {self.c_n:.2f} N) "
            f"for {self.outside_s * 1000:.0f} ms"
        )

    def fields(self) -> dict[str, Any]:
        """For telemetry: the estimates and the last sample's residual."""
        s = self.last
        return {
            "model": self.spec.model,
            "mu": self.mu,
            "c": self.c_n,
            "normal_force": s.normal_n if s is not None else None,
            "tangential_force": s.tangential_n if s is not None else None,
            "predicted": self.predicted_n,
            "residual": (s.tangential_n - self.predicted_n) if s is not None else None,
            "band": self.band_n,
            "judging": self.judging,
            "not_judging": self.not_judging,
            "anomaly": self.anomaly,
            "samples_learned": self.rls.updates,
        }
