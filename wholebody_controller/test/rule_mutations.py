# ruff: noqa: E501  (the table of one-line changes reads best one entry per line)
"""Deliberate errors in single rules of the step, each of which a behavioural test must catch.

Every entry breaks one rule of the safety layer, Algorithm 1, Ω_d or one term of (19)–(20) by a
one-line change; the script applies it, runs the behavioural tests (everything but the
comparisons with another implementation: ``test_equivalence.py``, ``test_kernels.py``) with
``NUMBA_DISABLE_JIT=1`` and restores the file. Every line must read CAUGHT.

    .venv/bin/python wholebody_controller/test/rule_mutations.py [INDEX ...]
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
W = "wholebody_controller/wholebody_controller/"
MUTATIONS: list[tuple[str, str, str, str]] = [
 ("safety: yield ends at F, not r·F (no hysteresis)", W+"task_step.py",
  "threshold = p[P_RESET] * p[P_LIMIT] if s[S_YIELDING] != 0.0 else p[P_LIMIT]", "threshold = p[P_LIMIT]"),
 ("safety: no fade (approach scale 1 below F)", W+"contact_safety.py",
  "    start = fade_start * limit\n    if force <= start:\n        return 1.0", "    start = fade_start * limit\n    if force < limit:\n        return 1.0"),
 ("safety: approach towards the contact not limited", W+"contact_safety.py",
  "    if along >= 0.0:\n        return velocity", "    if True:\n        return velocity"),
 ("safety: regain budget never spent", W+"task_step.py",
  "        s[S_EXHAUSTED] = 1.0\n    return s[S_EXHAUSTED] == 0.0", "        pass\n    return s[S_EXHAUSTED] == 0.0"),
 ("safety: yield towards the person", W+"task_step.py",
  "        y = yield_speed_of(sigma, p[P_YIELD_SPEED], p[P_YIELD_MAX])", "        y = -yield_speed_of(sigma, p[P_YIELD_SPEED], p[P_YIELD_MAX])"),
 ("safety: yield speed not graded by the excess", W+"task_step.py",
  "        y = yield_speed_of(sigma, p[P_YIELD_SPEED], p[P_YIELD_MAX])", "        y = p[P_YIELD_SPEED]"),
 ("safety: excess scale always 0", W+"contact_safety.py",
  "    return sigma if sigma < 1.0 else 1.0", "    return 0.0"),
 ("safety: the whole body's bounds not opened while yielding", W+"whole_step.py",
  "    if sigma > 0.0:\n        bounds = np.empty", "    if False:\n        bounds = np.empty"),
 ("safety: the opened band ignored (velocity and acceleration only)", W+"qp.py",
  "            out[row, i] = a if a == b else a + sigma * (b - a)", "            out[row, i] = a"),
 ("safety: the opened bounds close while the partner still pushes", W+"task_step.py",
  "        s[S_OPENED] = max(s[S_OPENED], sigma)", "        s[S_OPENED] = sigma"),
 ("safety: the base's bounds opened while yielding", W+"controller.py",
  "        actuator[:3], fast[:3] = vmax[:3], rated[:3]", "        pass"),
 ("safe stop: a tripped stop does not zero the command", W+"node.py",
  "        if self._speed_scaling_refuses(now_ns) or self._safe_stopped():", "        if self._speed_scaling_refuses(now_ns):"),
 ("safe stop: ~/reset does not clear it", W+"node.py",
  "            cleared = self.safe_stop.clear()", "            cleared = []"),
 ("skin vs joints: a skin reading too much passes (ratio < 1/r)", W+"skin_torque_check.py",
  "                1.0 / cfg.max_gain_ratio <= self.ratio <= cfg.max_gain_ratio)", "                self.ratio <= cfg.max_gain_ratio)"),
 ("skin vs joints: hold time ignored", W+"skin_torque_check.py",
  "            if now - start >= hold - 1e-9:", "            if True:"),
 ("skin vs joints: silent skin not checked", W+"skin_torque_check.py",
  "        silent = not skin_in_contact and joint_norm >= cfg.silent_torque and backing_off", "        silent = False"),
 ("skin vs joints: a silent skin latched while the unsensed guard has not backed off", W+"skin_torque_check.py",
  "        silent = not skin_in_contact and joint_norm >= cfg.silent_torque and backing_off", "        silent = not skin_in_contact and joint_norm >= cfg.silent_torque"),
 ("skin vs joints: a gain judged where the scaled skin explains the torques badly", W+"skin_torque_check.py",
  "            off = self.residual <= cfg.max_residual and not (", "            off = not ("),
 ("skin vs joints: the node does not run the check", W+"node.py",
  "        kind, message = self.torque_watch.judge_skin(self.skin_check, self.contacts, now_ns * 1e-9)", "        kind, message = \"\", \"\""),
 ("skin vs joints: the verdict's own cycle still commands", W+"node.py",
  "            command = np.zeros(15)  # exact zero from this cycle on", "            pass"),
 ("skin vs joints: with the unsensed guard off a silent skin is never judged", W+"torque_guard.py",
  "        backing_off = report.state is GuardState.STOPPED or not self.config.enabled", "        backing_off = report.state is GuardState.STOPPED"),
 ("protected: loosening at run time not refused", "phri_common/phri_common/ros_params.py",
  "            if loosening and not _unlocked(node, proposed):", "            if False:"),
 ("protected: a larger desired force not a loosening", "phri_common/phri_common/protected.py",
  "        return _norm(new) > _norm(old)", "        return False"),
 ("ISO: force limits above the table accepted", W+"parameters.py",
  "    if not values.get(\"iso15066_override\", False):\n        above = above_iso_table", "    if False:\n        above = above_iso_table"),
 ("safety: desired force not gated by contact", W+"task_step.py",
  "    return scale, scale if gate else 0.0, has_normal, normal", "    return scale, scale, has_normal, normal"),
 ("Alg.1: user reference ignored at activation", W+"task_step.py",
  "        if p[P_USER_REF_SET] != 0.0:", "        if False:"),
 ("Alg.1: no admittance reset at deactivation (line 10)", W+"task_step.py",
  "        s[S_X : S_X + 12] = 0.0  # line 10", "        pass  # line 10"),
 ("Alg.1: deflection kept while inactive", W+"task_step.py",
  "        s[S_X : S_X + 6] = 0.0  # lines 7/10", "        pass  # lines 7/10"),
 ("Alg.1: priority (15) without the 1/2", W+"contact_task.py",
  "return math.tanh(0.5 * b * (", "return math.tanh(b * ("),
 ("Alg.1: activation on psi >= thr (no strict crossing)", W+"task_step.py",
  "    activating = prev <= thr < psi_raw", "    activating = psi_raw > thr"),
 ("Omega_d: margin not added at lock", W+"task_step.py",
  "            (a, b, cc), (d, e, f) = grow_box((hi, lo), lo, hi, p[P_MARGIN])", "            (a, b, cc), (d, e, f) = grow_box((hi, lo), lo, hi, 0.0)"),
 ("Omega_d: onset window never grows", W+"task_step.py",
  "    elif not user and s[S_AGE] < p[P_WINDOW] - _WINDOW_SLACK:", "    elif False:"),
 ("Omega_d: release keeps the old region", W+"task_step.py",
  "        if s[S_HAD] != 0.0:\n            reset_region(s)", "        if False:\n            reset_region(s)"),
 ("Omega_d: hysteresis ignored", W+"task_step.py",
  "    if p[P_HYSTERESIS] == 0.0:\n        return track_force", "    if True:\n        return track_force"),
 ("(19)-(20): omega_d x R_d p removed", W+"contact_task.py",
  "    wx, wy, wz = oy * qz - oz * qy, oz * qx - ox * qz, ox * qy - oy * qx", "    wx, wy, wz = 0.0, 0.0, 0.0"),
 ("(17): sliding term dropped from the control velocity", W+"task_step.py",
  "            lx + dx, ly + dy, lz + dz, ax, ay, az)", "            lx, ly, lz, ax, ay, az)"),
]


def run(index: int) -> bool:
    """Apply mutation ``index``, run the behavioural tests, restore; whether a test failed."""
    name, path, old, new = MUTATIONS[index]
    full = ROOT / path
    source = full.read_text()
    assert source.count(old) == 1, f"{name}: the line to break is not unique in {path}"
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", MUJOCO_GL="egl")
    test = "wholebody_controller/test"
    full.write_text(source.replace(old, new))
    try:
        result = subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", test,
             f"--ignore={test}/test_equivalence.py", f"--ignore={test}/test_kernels.py"],
            cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    finally:
        full.write_text(source)
    failed = [line for line in result.stdout.splitlines() if line.startswith("FAILED")]
    verdict = f"CAUGHT by {failed[0].split('::', 1)[1]}" if failed else "NOT CAUGHT"
    print(f"[{index}] {name}: {verdict}", flush=True)
    return bool(failed)


def main() -> None:
    chosen = [int(a) for a in sys.argv[1:]] or list(range(len(MUTATIONS)))
    missed = [i for i in chosen if not run(i)]
    sys.exit(1 if missed else 0)


if __name__ == "__main__":
    main()
