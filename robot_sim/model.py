"""Assemble a MuJoCo model: scene fixtures + IRB120 arm + a tool on the wrist sensor.

The arm, each tool and each scene are separate MJCF files under assets/; MjSpec.attach puts
the arm on the scene's `robot_mount` site and the tool on the arm's `tool_mount` site, so one
arm description serves every scene. Physics options live here, in one place, because an
attached child's <option> is ignored.
"""

from pathlib import Path

import mujoco

ASSETS_DIR = Path(__file__).parent / "assets"

PHYSICS_TIMESTEP_S = 0.001
# Contact softness: time constant 10 physics steps, critically damped. Shorter time constants
# chatter under the stiff joint servos; this one settles a 6 N press in ~15 ms.
CONTACT_SOLREF = (10 * PHYSICS_TIMESTEP_S, 1.0)

MUJOCO_DEFAULT_SOLREF = (0.02, 1.0)

# Attached specs get a name prefix (MuJoCo needs one to save models); look names up through
# these: the port site is ARM_PREFIX + TOOL_PREFIX + "port".
ARM_PREFIX = "arm/"
TOOL_PREFIX = "tool/"


def build_model(scene_file: str, tool_file: str) -> mujoco.MjModel:
    """Compile scene + arm + tool into one model with the project's physics options."""
    spec = mujoco.MjSpec.from_file(str(ASSETS_DIR / "scenes" / scene_file))
    arm = mujoco.MjSpec.from_file(str(ASSETS_DIR / "irb120.xml"))
    tool = mujoco.MjSpec.from_file(str(ASSETS_DIR / "tools" / tool_file))
    # Tool onto arm, then arm onto scene: tool names end up as ARM_PREFIX + TOOL_PREFIX + name.
    arm.attach(tool, site=arm.site("tool_mount"), prefix=TOOL_PREFIX)
    spec.attach(arm, site=spec.site("robot_mount"), prefix=ARM_PREFIX)

    opt = spec.option
    opt.timestep = PHYSICS_TIMESTEP_S
    opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    # Dense constraint Jacobian: small model, and it avoids MuJoCo 4.0.0's sparse-Cholesky
    # supernode bug (fixed in 4.0.1, which the registry may not have yet).
    opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    opt.noslip_iterations = 0
    for geom in spec.geoms:
        # A geom that sets its own solref keeps it: MuJoCo scales contact stiffness by the
        # effective mass, so a light part (a detent ball) needs a shorter time constant to
        # stay out of what it touches.
        if tuple(geom.solref) == MUJOCO_DEFAULT_SOLREF:
            geom.solref = list(CONTACT_SOLREF)
    return spec.compile()
