"""What the robot offers, as GET /api/presets, /api/scenes and /api/tasks answer it: built from
the package's own configuration, so a console can show its panels before the robot has answered
across a slow link (and then check that the robot's answers agree)."""

from typing import Any

from robot_sim.machines.library import builtin_machines
from robot_sim.policies import POLICIES
from robot_sim.presets import default_presets
from robot_sim.scenes import SCENES
from server.models import GainsPreset, SceneModel, TaskInfoModel


def preset_catalog() -> dict[str, Any]:
    """Stiffness/damping presets by name, plus the dither presets under `dither`."""
    loaded = default_presets()
    out: dict[str, Any] = {
        name: GainsPreset(
            **spec.model_dump(), description=loaded.stiffness_descriptions.get(name, "")
        ).model_dump()
        for name, spec in loaded.stiffness.items()
    }
    out["dither"] = {name: p.model_dump(exclude={"type", "preset"}) for name, p in loaded.dither.items()}
    return out


def scene_catalog() -> list[SceneModel]:
    return [SceneModel(name=s.name, description=s.description) for s in SCENES.values()]


def task_catalog() -> list[TaskInfoModel]:
    return [
        TaskInfoModel(
            name=name,
            summary=policy.summary,
            settings=policy.settings_model.model_json_schema()["properties"],
            machine=spec.model_dump(exclude_none=True) if (spec := builtin_machines().get(name)) else None,
        )
        for name, policy in POLICIES.items()
    ]
