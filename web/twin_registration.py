"""The ground twin registers its fixture from the contacts the robot reports (issue 29 point 6;
the teleoperation paper's 2.5 Model Update: in force-controlled directions the measured position
corrects the model).

The twin knows the nominal scene. When the robot's fixture is 1 mm lower than that, the twin
restarts with its tool 1 mm inside its own plate, feels a spurious ~50 N, and ends the replayed
slide the robot goes on with. So at each restart (the twin at the robot's reported joints) it
compares the two: the robot's measured force says whether the tool touches (at the tasks' forces
the contacts give < 0.1 mm); the twin's model gives the signed distance d between tool and
fixture and its normal n. Moving the fixture by x changes that distance to d - n.x, so each
informative restart says one thing of the shift x (d0: the distance with the fixture at its
nominal place), and the fixture goes where the last WINDOW of them agree best in least squares
(the least shift where they say nothing, e.g. sideways under a press):

    the robot touches (|f| >= CONTACT_N)         n.x = d0: the twin must touch too
    the robot is free, the twin's tool is inside n.x <= d0: the fixture is at least that far off
                                                 (a bound, kept only where the fit breaks it)

A free robot and a free twin say nothing. Translation only: a tilt of 1-2 degrees moves a 25 mm
face by under 0.5 mm. Not thread-safe: the twin's thread alone runs it.
"""

from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np

from robot_sim.sim import Simulation

CONTACT_N = 3.0  # [N] a reported force at least this: the robot's tool is touching the fixture
REACH_M = 0.01  # [m] distances looked at: a twin farther off than this is wrong in another way
MAX_SHIFT_M = 0.01  # [m] the fixture moves at most this far from its nominal place
WINDOW = 20  # informative restarts solved over (10 s at one every 0.5 s), each 1-ROUNDS equations
MIN_DISTANCE_M = 1e-6  # [m] closer than this the normal is undefined: the sample says nothing
# Never restart inside: while the fit leaves the twin's tool deeper than INSIDE_M in its fixture
# (the window's older equations, from other places on a 16-sided sleeve, outvote the new one: a
# sleeve 0.9 mm into its peg was thrown 15 mm), the deepest pair there is another bound.
INSIDE_M = 1e-5
ROUNDS = 6
NOW_WEIGHT = 100.0  # this restart's rows against the older ones (10^4 in the squared residuals)


@dataclass(frozen=True)
class Registered:
    """Where the twin put its fixture, for the console's readout."""

    body: str
    shift_m: tuple[float, float, float]  # from its nominal place, base axes
    samples: int  # the equations it rests on

    @property
    def moved_mm(self) -> float:
        return 1000.0 * float(np.linalg.norm(self.shift_m))

    def describe(self) -> str:
        """In the operator's words: what the twin changed in its model, and by how much."""
        x, y, z = (1000.0 * v for v in self.shift_m)
        return (
            f"its {self.body} moved {self.moved_mm:.1f} mm ({x:+.1f}, {y:+.1f}, {z:+.1f}) to fit the "
            f"robot's contacts"
        )


class FixtureRegistration:
    """One scene's fixture in one twin model: its nominal place, its shift, and the evidence."""

    def __init__(self, sim: Simulation) -> None:
        model = sim.model
        assert sim.scene.fixture_body is not None
        self.body = model.body(sim.scene.fixture_body).id
        self.name = sim.scene.fixture_body
        self._nominal = model.body_pos[self.body].copy()
        self._shift = np.zeros(3)
        # Per informative restart, its equations (n, d0, a bound only): n.x = d0, or n.x <= d0
        self._restarts: deque[list[tuple[np.ndarray, float, bool]]] = deque(maxlen=WINDOW)
        fixture, tool = _subtree(model, self.body), _subtree(model, sim.layout.tool_body)
        self._pairs = [
            (f, t)
            for f in _colliding_geoms(model, fixture)
            for t in _colliding_geoms(model, tool)
            if _may_touch(model, f, t)
        ]
        self._fromto = np.zeros(6)

    @staticmethod
    def applies_to(sim: Simulation) -> bool:
        return sim.scene.fixture_body is not None

    def observe(self, sim: Simulation, force_n: float) -> None:
        """The twin has just been put at the robot's reported joints; the robot measured `force_n`
        [N]. Adds what this says of the fixture, solves, and moves the twin's fixture."""
        self.ensure_placed(sim)
        touching = force_n >= CONTACT_N
        now: list[tuple[np.ndarray, float, bool]] = []  # this restart's equations
        for round_ in range(ROUNDS):
            found = self._closest(sim)
            if found is None:
                return
            distance_m, normal = found
            if round_ == 0 and not touching and distance_m >= 0.0:
                return  # both free: nothing learnt
            if round_ > 0 and distance_m >= -INSIDE_M:
                return  # the fit has the twin out of its own fixture
            d0 = distance_m + float(normal @ self._shift)  # with the fixture at its nominal place
            # Touching, the closest pair: n.x = d0. Free while the twin overlaps (d0 < 0), or a
            # later round's pair (the robot's force says the closest pair touches, not this
            # one): only a bound, n.x <= d0 (the real distance d0 - n.x is >= 0: the fixture is
            # at least that far off; how much farther, this does not say).
            now.append((normal, d0, not touching or round_ > 0))
            if round_ == 0:
                self._restarts.append(now)
            self._solve()
            self._place(sim)

    def ensure_placed(self, sim: Simulation) -> None:
        """The fixture where the fit put it, in a model made anew (the twin's own fault reloads
        its scene at the nominal place)."""
        if not np.array_equal(sim.model.body_pos[self.body], self._nominal + self._shift):
            self._place(sim)

    def forget(self, sim: Simulation) -> None:
        """Back to the nominal place, with no evidence (the robot's scene reloaded)."""
        self._shift = np.zeros(3)
        self._restarts.clear()
        self._place(sim)

    def registered(self) -> Registered:
        x, y, z = (float(v) for v in self._shift)
        return Registered(self.name, (x, y, z), sum(len(group) for group in self._restarts))

    def _closest(self, sim: Simulation) -> tuple[float, np.ndarray] | None:
        """(signed distance [m], unit normal from fixture to tool) of the closest pair in reach."""
        best: tuple[float, np.ndarray] | None = None
        for fixture_geom, tool_geom in self._pairs:
            d = mujoco.mj_geomDistance(sim.model, sim.data, fixture_geom, tool_geom, REACH_M, self._fromto)
            if d >= REACH_M or abs(d) < MIN_DISTANCE_M:
                continue
            if best is None or d < best[0]:
                # fromto runs from the fixture's point to the tool's: d times the normal
                best = (d, (self._fromto[3:6] - self._fromto[0:3]) / d)
        return best

    def _solve(self) -> None:
        """Least squares over the equations, with each bound the fit breaks taken as an
        equation too (an active set: a few rounds suffice for a handful of bounds). The latest
        restart's rows are scaled by NOW_WEIGHT: near constraints, what the robot shows now;
        the older rows fill in the directions those leave free (sideways under a press). With
        equal weights, twenty older rows from elsewhere on a 16-sided bore outvoted the new one
        and left the twin 0.1-0.9 mm inside its peg."""
        *older, latest = list(self._restarts) or [[]]
        weighted = [(n, d0, bound) for group in older for n, d0, bound in group] + [
            (NOW_WEIGHT * n, NOW_WEIGHT * d0, bound) for n, d0, bound in latest
        ]
        equalities = [(n, d0) for n, d0, bound in weighted if not bound]
        bounds = [(n, d0) for n, d0, bound in weighted if bound]
        shift = np.zeros(3)
        active: list[tuple[np.ndarray, float]] = []
        for _ in range(1 + len(bounds)):
            rows = equalities + active
            if rows:
                shift, *_ = np.linalg.lstsq(
                    np.array([n for n, _ in rows]), np.array([d0 for _, d0 in rows]), rcond=1e-3
                )  # least norm where unseen
            broken = [
                (n, d0) for n, d0 in bounds if float(n @ shift) > d0 + MIN_DISTANCE_M * np.linalg.norm(n)
            ]
            if not broken:
                break
            active += [row for row in broken if not any(row is kept for kept in active)]
        size = float(np.linalg.norm(shift))
        self._shift = shift if size <= MAX_SHIFT_M else shift * (MAX_SHIFT_M / size)

    def _place(self, sim: Simulation) -> None:
        sim.model.body_pos[self.body] = self._nominal + self._shift
        mujoco.mj_forward(sim.model, sim.data)


def _subtree(model: mujoco.MjModel, root: int) -> list[int]:
    return [b for b in range(model.nbody) if _descends(model, b, root)]


def _descends(model: mujoco.MjModel, body: int, root: int) -> bool:
    while body != root and body != 0:
        body = int(model.body_parentid[body])
    return body == root


def _colliding_geoms(model: mujoco.MjModel, bodies: list[int]) -> list[int]:
    return [
        g
        for g in range(model.ngeom)
        if model.geom_bodyid[g] in bodies and (model.geom_contype[g] or model.geom_conaffinity[g])
    ]


def _may_touch(model: mujoco.MjModel, a: int, b: int) -> bool:
    """MuJoCo's own filter: either's contype meets the other's conaffinity."""
    return bool(
        model.geom_contype[a] & model.geom_conaffinity[b] or model.geom_contype[b] & model.geom_conaffinity[a]
    )
