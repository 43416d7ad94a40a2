"""The scene compiles, steps without MuJoCo warnings, and the stored XML is the generated model."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from phri_sim.scenarios import Q_HOME
from phri_sim.scene import MODELS_DIR, robot_spec, scene_spec, write_models


def _step_without_warnings(model: mujoco.MjModel, seconds: float = 0.5) -> mujoco.MjData:
    data = mujoco.MjData(model)
    for _ in range(round(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    warnings = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(data.warning)
                if w.number}
    assert not warnings, f"MuJoCo warnings: {warnings}"
    assert np.all(np.isfinite(data.qpos))
    return data


@pytest.mark.parametrize("name", ["robot.xml", "scene.xml"])
def test_stored_scene_compiles_and_steps_without_warnings(name: str) -> None:
    model = mujoco.MjModel.from_xml_path(str(MODELS_DIR / name))
    _step_without_warnings(model)


def test_stored_xml_matches_generator(tmp_path: Path) -> None:
    write_models(tmp_path)
    for name in ("robot.xml", "scene.xml"):
        assert (tmp_path / name).read_text() == (MODELS_DIR / name).read_text(), (
            f"{name} is stale: run python -m phri_sim.scene"
        )


def test_joint_ranges_are_radians() -> None:
    model = robot_spec().compile()
    elbow = model.joint("left_elbow_joint")
    assert elbow.range[1] == pytest.approx(np.pi)


def test_unloaded_arms_hold_still_at_zero_command() -> None:
    """Velocity servos with gravity compensation: a zero command holds the configuration."""
    model = scene_spec().compile()
    data = mujoco.MjData(model)
    idx = [model.jnt_qposadr[model.joint(n).id] for n in
           ["left_shoulder_lift_joint", "left_elbow_joint", "right_elbow_joint"]]
    data.qpos[[model.jnt_qposadr[model.joint("base_x").id] + i for i in range(15)]] = Q_HOME
    q0 = data.qpos[idx].copy()
    for _ in range(500):
        mujoco.mj_step(model, data)
    assert np.max(np.abs(data.qpos[idx] - q0)) < 1e-3
