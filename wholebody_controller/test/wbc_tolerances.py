"""What the equivalence tests (``test_equivalence.py``: the Python step against the reference;
``test_fused.py``: the compiled step against the Python step) share: tolerances, the admittance
gain sets they draw from, and the comparison."""

from __future__ import annotations

import numpy as np

from wholebody_controller.config import (
    CONTACT_CENTRING,
    CONTACT_TRACKING,
    WALTZ,
    WHOLE_BODY,
    AdmittanceGains,
)

TOL = 1e-9
"""Task outputs and QP data: the same formulas, so agreement to rounding."""
QP_TOL = 1e-7
"""The QP's answer: the reference's SO(3) maps (scipy) differ from production's by rounding
(~1e-16), and on a nearly degenerate QP daqp's active-set tolerances turn that into up to ~1e-9
(seen: 2.3e-9) of the command; 1e-7 stays far inside the 1e-6 exactness bar (design §7)."""
GAINS = [CONTACT_CENTRING, CONTACT_TRACKING, WHOLE_BODY, WALTZ,
         AdmittanceGains((0.3, 0.5, 0.7, 0.2, 0.4, 0.6), (10.0, 30.0, 0.0, 5.0, 8.0, 60.0),
                         (0.0, 20.0, 5.0, 0.0, 1.0, 3.0))]
"""The paper's gain sets and one with different values on every axis."""


def close(a: object, b: object, what: str, tol: float = TOL) -> None:
    """Assert ``a`` ≈ ``b`` elementwise within ``tol`` (relative and absolute), naming ``what``."""
    np.testing.assert_allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float),
                               rtol=tol, atol=tol, err_msg=what)
