"""Benchmark: how stiff the tight fits' contacts are against their rigid geometry (issue 29
point 1). The fits' geoms carry solimp="0.99 0.999 0.001" (impedance 0.99 at contact, 0.999
past 1 mm): MuJoCo's default (0.9 0.95) let the sleeve tilt 0.89 deg against the rigid 0.50 and the
socket turn 7.95 deg against 3.09, with 0.044 mm and 0.37 mm of overlap.

    sleeve_on_peg  the sleeve slid 12 mm over the peg (aligned, 25 N threshold), then tilted
                   about the tool's x one way, the other and back, each until it presses back
                   with TILT_TORQUE_NM: half the range between the stops beside the rigid fit's
                   2 c / L (c the radial clearance, L the engagement over the peg's cylinder,
                   below its chamfer), and the deepest overlap of sleeve and peg
    socket_wrench  its state machine, then the issue's turn: PTWL 0.2 rad about the tool axis at
                   up to 8 N m: how far the port turned and at what torque, beside the rigid
                   play of the square shank in its square bore, and the deepest overlap

Prints JSON. Deterministic (no seed), seconds of CPU.

    python -m bench.fit
"""

import json
import math

import mujoco

from robot_sim.behaviors import BehaviorReport
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.params import PtwlParams
from robot_sim.policies import run_onboard
from robot_sim.policies.sleeve_on_peg import CHAMFER_M, RADIAL_CLEARANCE_M
from robot_sim.policies.travel import twist_about_tool_axis_rad
from robot_sim.scenes.sleeve_on_peg import sleeve_insertion_depth
from robot_sim.sim import Simulation

ENGAGED_M = 0.012  # [m] the sleeve over the peg: within the 10-15 mm
# The socket's rigid play: a square shank of half-width a turns in a square bore of half-width b
# until its corner (a sqrt 2 out) touches a wall: sqrt 2 a sin(theta + 45 deg) = b.
SHANK_HALF_M, BORE_HALF_M = 0.004765, 0.0100075 - 0.0049925
SOCKET_RIGID_PLAY_DEG = math.degrees(math.asin(BORE_HALF_M / (math.sqrt(2.0) * SHANK_HALF_M))) - 45.0
TILT_TORQUE_NM = 1.0  # [N m] a tilt pressed this hard has taken up the play
SOCKET_TORQUE_NM = 8.0


def deepest_overlap_m(sim: Simulation, bodies: set[int]) -> float:
    """[m] the largest penetration among contacts that touch any of `bodies`."""
    data, model = sim.data, sim.model
    deepest = 0.0
    for i in range(data.ncon):
        contact = data.contact[i]
        if {int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])} & bodies:
            deepest = max(deepest, -float(contact.dist))
    return deepest


def run_watching(sim: Simulation, params: PtwlParams, bodies: set[int]) -> tuple[float, BehaviorReport]:
    """Run a PTWL to its end; the deepest overlap with `bodies` on the way, and its report."""
    sim.start(Ptwl(params))
    deepest = 0.0
    while True:
        report = sim.step()
        deepest = max(deepest, deepest_overlap_m(sim, bodies))
        if report is not None:
            return deepest, report


def sleeve() -> dict[str, object]:
    sim = Simulation("sleeve_on_peg")
    peg = {sim.model.body("peg_base").id}
    down_m = ENGAGED_M - sleeve_insertion_depth(sim)
    insert = PtwlParams(
        translation=[0.0, 0.0, down_m], duration=3.0, force_threshold=25.0, position_tolerance=2e-4
    )
    inserted_overlap, _ = run_watching(sim, insert, peg)
    engaged_m = sleeve_insertion_depth(sim)
    engaged_tilt_deg = port_tilt_signed_deg(sim)
    tilts, overlaps, torques, exits = [], [], [], []
    for sign in (1.0, -1.0, 1.0):  # one way, the other way, back: the play between the two stops
        tilt = PtwlParams(
            rotation=[sign * math.radians(5.0), 0.0, 0.0],
            duration=2.0,
            torque_threshold=TILT_TORQUE_NM,
            force_threshold=100.0,
            orientation_tolerance=1e-4,  # ends on the torque (or its watchdog), not near the goal
        )
        overlap, report = run_watching(sim, tilt, peg)
        tilts.append(port_tilt_signed_deg(sim))
        overlaps.append(overlap)
        torques.append(report.peak_torque)
        exits.append(report.exit.value)
    return {
        "engaged_mm": round(1000 * engaged_m, 2),
        "tilt_after_insertion_deg": round(engaged_tilt_deg, 3),
        "free_tilt_deg": round((max(tilts) - min(tilts)) / 2.0, 3),  # half the stop-to-stop range
        # Over the peg's cylinder: the chamfer's 1.5 mm hold nothing.
        "rigid_tilt_deg": round(math.degrees(2 * RADIAL_CLEARANCE_M / (engaged_m - CHAMFER_M)), 3),
        "stops_deg": [round(t, 3) for t in tilts],
        "tilt_exits": exits,
        "tilt_peak_torques_nm": [round(t, 2) for t in torques],
        "overlap_inserting_mm": round(1000 * inserted_overlap, 4),
        "overlap_tilted_mm": round(1000 * max(overlaps), 4),
        "radial_clearance_mm": round(1000 * RADIAL_CLEARANCE_M, 4),
    }


def port_tilt_signed_deg(sim: Simulation) -> float:
    """[deg] the port's tilt about the base x (the way the tilts above turn it)."""
    z_port = sim.data.site_xmat[sim.layout.port_site].reshape(3, 3)[:, 2]
    return math.degrees(math.atan2(float(z_port[1]), float(-z_port[2])))


def socket() -> dict[str, object]:
    sim = Simulation("socket_wrench")
    run = run_onboard("socket_wrench", None, sim)
    socket_bodies = {b for b in range(sim.model.nbody) if "socket" in sim.model.body(b).name}
    start = sim.state().port
    turn = PtwlParams(
        rotation=[0.0, 0.0, 0.2],
        duration=2.0,
        torque_threshold=SOCKET_TORQUE_NM,
        force_threshold=100.0,
        orientation_tolerance=1e-4,
    )
    overlap, report = run_watching(sim, turn, socket_bodies)
    turned = twist_about_tool_axis_rad(start, sim.state().port)
    return {
        "machine_end": run.end,
        "turn_deg": round(math.degrees(turned), 2),
        "rigid_play_deg": round(SOCKET_RIGID_PLAY_DEG, 2),
        "turn_exit": report.exit.value,
        "turn_peak_torque_nm": round(report.peak_torque, 2),
        "overlap_mm": round(1000 * overlap, 4),
        "socket_bodies": len(socket_bodies),
    }


def main() -> None:
    mujoco.mj_version()  # the physics the figures are of
    print(json.dumps({"mujoco": mujoco.__version__, "sleeve_on_peg": sleeve(), "socket_wrench": socket()}))


if __name__ == "__main__":
    main()
