"""The compiled calibration (kernel 'numba') against the numpy reference, frame by frame."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from skin_driver.calibration import CalibrationConfig, PatchCalibrator

N = 300
RATE = 500.0


def _frames(seed: int, frames: int) -> list[np.ndarray]:
    """Raw counts exercising every branch: noise, a press held from before the tare (touched
    at tare), a press that starts later, common-mode drift, a taxel that reads below its zero
    (release), a stuck channel, a saturated one."""
    rng = np.random.default_rng(seed)
    gain, offset = 0.0005, 1000.0
    out = []
    for k in range(frames):
        t = k / RATE
        force = np.zeros(N)
        force[10:20] = 2.0                              # held through the tare
        if k > 150:
            force[100:130] = 1.0 + 0.5 * np.sin(t)     # a later contact
        if 200 < k < 260:
            force[200:205] = -0.4                       # below the zero: released
        force += 0.02 * t                               # common-mode drift [N/s]
        counts = offset + force / gain + rng.normal(0.0, 3.0, N)
        counts[50] = 1234                               # stuck channel
        counts[60] = 70000                              # saturated (clipped to 65535)
        out.append(np.clip(np.rint(counts), 0, 65535).astype("<u2"))
    return out


@pytest.mark.parametrize(("seed", "config"), [
    (0, CalibrationConfig(tare_frames=50, stuck_time=0.2, drift_time_constant=0.5)),
    (1, CalibrationConfig(tare_frames=0, filter_window=3, stuck_time=0.0)),
    (2, CalibrationConfig(tare_frames=20, drift_time_constant=0.0, filter_window=1)),
    (3, CalibrationConfig(tare_frames=20, min_free_fraction=1.0, drift_band=0.5)),
])
def test_numba_kernel_matches_the_numpy_reference(seed: int, config: CalibrationConfig) -> None:
    dead = np.zeros(N, bool)
    dead[[3, 77]] = True
    gains = np.full(N, 0.0005) * (1 + 0.1 * np.random.default_rng(seed).random(N))
    numpy_cal = PatchCalibrator(N, replace(config, kernel="numpy"), gains=gains, dead=dead)
    numba_cal = PatchCalibrator(N, replace(config, kernel="numba"), gains=gains, dead=dead)
    outputs = 0
    for k, counts in enumerate(_frames(seed, 400)):
        if k == 300:  # a silence, then a re-tare: the filter and tare restart on both
            for cal in (numpy_cal, numba_cal):
                cal.reset_filter()
                cal.tare()
        t = k / RATE + (0.5 if k >= 300 else 0.0)
        expected, actual = numpy_cal.process(counts, t), numba_cal.process(counts, t)
        assert (expected is None) == (actual is None), k
        if expected is not None and actual is not None:
            outputs += 1
            np.testing.assert_allclose(actual, expected, rtol=1e-12, atol=1e-12, err_msg=str(k))
        np.testing.assert_allclose(numba_cal.baseline, numpy_cal.baseline, rtol=1e-12,
                                   atol=1e-12, err_msg=str(k))
        assert numba_cal.status() == numpy_cal.status(), k
    assert outputs >= 300
    status = numba_cal.status()
    assert status.saturated == 1 and status.dead >= 2
    if 0 < config.stuck_time < 0.5:  # shorter than the run
        assert status.stuck == 2  # the frozen channel and the saturated one (constant)


def test_the_kernel_setting_is_checked() -> None:
    with pytest.raises(ValueError, match="kernel refused value 'cuda': allowed numpy, numba"):
        CalibrationConfig(kernel="cuda")


def test_the_node_refuses_an_unknown_kernel_by_name() -> None:
    from phri_common.params import ParameterValueError
    from skin_driver.node import PARAMS, calibration_config

    values = {spec.name: spec.default for spec in PARAMS}
    assert calibration_config(values).kernel == "numba"
    with pytest.raises(ParameterValueError, match="parameter 'kernel' refused value 'cuda'"):
        calibration_config({**values, "kernel": "cuda"})
