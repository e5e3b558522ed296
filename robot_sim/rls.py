"""Recursive least squares with one forgetting factor per parameter (Vahidi et al. 2005), the
estimator of the teleoperation paper's force task monitor (its 2.4.1 and 2.5.2).

y = phi . theta. A factor near 1 keeps a long memory (a friction coefficient that should not
drift); a lower one lets its parameter follow recent data (a constant force that may change).
Each update scales the covariance by Lambda^-1/2 on both sides, Lambda = diag(factors), which
for equal factors is the usual P / lambda. Forgetting inflates the covariance of a parameter the
data do not excite, so each diagonal entry is capped at `max_variance` (anti-windup).
"""

import numpy as np


class VectorForgettingRls:
    def __init__(
        self,
        theta0: np.ndarray,
        variance0: "float | np.ndarray",
        forgetting: np.ndarray,
        max_variance: "float | np.ndarray",
    ) -> None:
        """variance0, max_variance: one for all parameters, or one each."""
        self.theta = np.array(theta0, dtype=float)
        n = self.theta.size
        self.P = np.diag(np.broadcast_to(np.asarray(variance0, dtype=float), (n,))).copy()
        self._scale = 1.0 / np.sqrt(np.asarray(forgetting, dtype=float))  # Lambda^-1/2, diagonal
        self._max_variance = max_variance
        self.updates = 0

    def predict(self, phi: np.ndarray) -> float:
        return float(phi @ self.theta)

    def update(self, phi: np.ndarray, y: float) -> None:
        P_phi = self.P @ phi
        gain = P_phi / (1.0 + float(phi @ P_phi))
        self.theta += gain * (y - float(phi @ self.theta))
        P = self.P - np.outer(gain, P_phi)
        P *= np.outer(self._scale, self._scale)
        variance = np.diag(P)
        over = variance > self._max_variance
        if np.any(over):
            shrink = np.where(over, np.sqrt(self._max_variance / np.maximum(variance, 1e-300)), 1.0)
            P *= np.outer(shrink, shrink)
        self.P = 0.5 * (P + P.T)  # symmetric against round-off
        self.updates += 1
