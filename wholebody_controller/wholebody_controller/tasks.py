"""One skin link's interaction task as an object: a handle on its rows (:mod:`task_rows`).

:class:`ContactTask` owns nothing the step does not: its state is one state row — its own, or a
view of the controller's (``WholeBodyController.tasks``) — and :meth:`ContactTask.step` runs
:func:`~wholebody_controller.task_step.step_task` on it through the configured kernel, the same
function the controller's step runs. The properties read the row (no side effects): the locked
reference and Ω_d, the admittance state, the contact-safety state.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from phri_common.records import ContactState
from wholebody_controller import task_rows as rows
from wholebody_controller.admittance import transition
from wholebody_controller.config import ControllerConfig, LinkTaskConfig, diag6
from wholebody_controller.contact_task import TaskOutput
from wholebody_controller.kernels import step_kernel
from wholebody_controller.task_rows import contact_rows, link_params, task_outputs

Array = NDArray[np.float64]


def admittance_transition(link: LinkTaskConfig, config: ControllerConfig) -> Array:
    """``[Φ Γ]`` (12×18) of a link's admittance (13) at the control period."""
    gains = link.admittance
    return transition(diag6(gains.inertia), diag6(gains.damping), diag6(gains.stiffness),
                      config.dt)


class ContactTask:
    """One skin link's interaction task: Algorithm 1 around (8), (10)–(20) with contact safety.

    Args:
        link: the link's task configuration.
        config: the controller-wide settings (gains, safety, kernel); default
            ``ControllerConfig(links=(link,))``.
        state: the state row to work on (a view of the controller's rows); default a new one,
            inactive.
        params, phi_gamma: the link's parameter row and ``[Φ Γ]`` when already computed.
    """

    def __init__(self, link: LinkTaskConfig, config: ControllerConfig | None = None, *,
                 state: Array | None = None, params: Array | None = None,
                 phi_gamma: Array | None = None) -> None:
        self.config = link
        self.controller_config = config or ControllerConfig(links=(link,))
        self.params = link_params(link, self.controller_config) if params is None else params
        self.phi_gamma = (admittance_transition(link, self.controller_config)
                          if phi_gamma is None else phi_gamma)
        self.state = np.zeros(rows.N_STATE) if state is None else state
        self._kernel = step_kernel(self.controller_config.kernel)
        self.yield_excess = 0.0
        """σ of the last :meth:`step` (:func:`~wholebody_controller.contact_safety.yield_scale`;
        0 unless the link yields)."""

    @property
    def link(self) -> str:
        return self.config.link

    def step(self, contact: ContactState, rot: Sequence[float], pos: Sequence[float],
             yaw: float) -> TaskOutput:
        """One control step of this link (:func:`~wholebody_controller.task_step.step_task`).

        Args:
            contact: the link's latest contact state (link frame).
            rot: ⁰R_i, the link frame's rotation in the world, row-major (9 floats).
            pos: ⁰p_γi, the link frame's origin in the world [m].
            yaw: base heading [rad].
        """
        contact_row, touched = contact_rows((self.link,), {self.link: contact})
        outputs = np.empty((1, rows.N_OUT))
        self._kernel.step_links(self.state[None], self.params[None], self.phi_gamma[None],
                                contact_row,
                                np.asarray(rot, dtype=np.float64).reshape(1, 9),
                                np.asarray(pos, dtype=np.float64).reshape(1, 3), float(yaw),
                                outputs)
        self.yield_excess = float(outputs[0, rows.O_YIELD])
        return task_outputs((self.link,), outputs, touched)[0]

    def reset(self) -> None:
        """Back to inactive: admittance at rest, nothing locked, safety state cleared."""
        self.state[:] = 0.0

    # -- read-only views of the state row ------------------------------------------------
    @property
    def deflection(self) -> Array:
        """x̃ (14) [m, rad]."""
        return self.state[rows.S_X : rows.S_X + 6].copy()

    @property
    def deflection_velocity(self) -> Array:
        """ẋ̃ [m/s, rad/s]."""
        return self.state[rows.S_V : rows.S_V + 6].copy()

    @property
    def point(self) -> Array:
        """ᶦp_η [m]: the contact centre of the last touch (the Jacobian point of (8))."""
        return self.state[rows.S_POINT : rows.S_POINT + 3].copy()

    @property
    def psi_prev(self) -> float:
        """ψ of the previous step (Algorithm 1)."""
        return float(self.state[rows.S_PSI_PREV])

    @property
    def locked_reference(self) -> tuple[Array, Array] | None:
        """The reference pose (⁰R_r 3×3, ⁰p_r [m]) of the link frame, while active."""
        if not self.state[rows.S_REF_SET]:
            return None
        return (self.state[rows.S_REF_ROT : rows.S_REF_ROT + 9].reshape(3, 3).copy(),
                self.state[rows.S_REF_POS : rows.S_REF_POS + 3].copy())

    @property
    def desired_region(self) -> tuple[Array, Array] | None:
        """Ω_d (link frame, margin included) [m] while locked."""
        if not self.state[rows.S_BOX_SET]:
            return None
        box = self.state[rows.S_BOX : rows.S_BOX + 6]
        return box[0:3].copy(), box[3:6].copy()

    @property
    def yielding(self) -> bool:
        """The contact force reached the force limit and has not fallen below r·F since."""
        return bool(self.state[rows.S_YIELDING])

    @property
    def peak_force(self) -> float:
        """Largest contact force since the last reset [N]."""
        return float(self.state[rows.S_PEAK])

    @property
    def transient_exceeded(self) -> bool:
        """The transient force limit was exceeded since the last reset."""
        return bool(self.state[rows.S_TRANSIENT])

    @property
    def force_limit(self) -> float:
        """Quasi-static force limit F [N]."""
        return float(self.params[rows.P_LIMIT])

    @property
    def transient_force_limit(self) -> float:
        """Transient force limit [N]."""
        return float(self.params[rows.P_TRANSIENT])

    @property
    def regain(self) -> tuple[float, float, bool]:
        """The regain budget: (travel [m], time [s] without contact, spent)."""
        return (float(self.state[rows.S_TRAVEL]), float(self.state[rows.S_ELAPSED]),
                bool(self.state[rows.S_EXHAUSTED]))
