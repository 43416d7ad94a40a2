"""The scene compiles, steps without MuJoCo warnings, and the stored XML is the generated model."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from phri_sim.scenarios.catalogue import Q_HOME
from phri_sim.world.scene import MODELS_DIR, robot_spec, scene_spec, write_models


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


MODEL_FIELDS = ("body_parentid", "body_pos", "body_quat", "body_mass", "body_ipos",
                "body_inertia", "body_gravcomp", "jnt_type", "jnt_bodyid", "jnt_axis", "jnt_pos",
                "jnt_range", "dof_armature", "dof_damping", "geom_type", "geom_bodyid",
                "geom_size", "geom_pos", "geom_quat", "geom_contype", "geom_conaffinity",
                "geom_friction", "actuator_trnid", "actuator_gainprm", "actuator_biasprm",
                "actuator_forcerange", "actuator_ctrlrange", "opt.timestep", "opt.gravity")


def _field(model: mujoco.MjModel, name: str) -> np.ndarray:
    value: object = model
    for part in name.split("."):
        value = getattr(value, part)
    return np.asarray(value, dtype=float)


def test_stored_xml_matches_generator(tmp_path: Path) -> None:
    """The stored models compile to the generator's model. Compared compiled, to MuJoCo's
    six written digits: the XML text is MuJoCo's writer's, which other versions may format
    differently, and the last digits are arithmetic noise that differs between machines."""
    write_models(tmp_path)
    for name in ("robot.xml", "scene.xml"):
        stored = mujoco.MjModel.from_xml_path(str(MODELS_DIR / name))
        fresh = mujoco.MjModel.from_xml_path(str(tmp_path / name))
        hint = f"{name} is stale: run `.venv/bin/python -m phri_sim.world.scene` and commit it"
        for kind in (mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_JOINT,
                     mujoco.mjtObj.mjOBJ_GEOM, mujoco.mjtObj.mjOBJ_ACTUATOR):
            count = {mujoco.mjtObj.mjOBJ_BODY: "nbody", mujoco.mjtObj.mjOBJ_JOINT: "njnt",
                     mujoco.mjtObj.mjOBJ_GEOM: "ngeom", mujoco.mjtObj.mjOBJ_ACTUATOR: "nu"}[kind]
            names = [mujoco.mj_id2name(m, kind, i) for m in (stored, fresh)
                     for i in range(getattr(m, count))]
            half = len(names) // 2
            assert names[:half] == names[half:], f"{hint} ({count} names differ)"
        for field in MODEL_FIELDS:
            a, b = _field(stored, field), _field(fresh, field)
            assert a.shape == b.shape, f"{hint} ({field} shape {a.shape} vs {b.shape})"
            np.testing.assert_allclose(a, b, rtol=2e-5, atol=2e-6, err_msg=f"{hint} ({field})")


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
