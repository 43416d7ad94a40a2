"""TaxelCloudEncoder.taxels (a frame handed over in-process) against the decoded message: the
same taxel array bit for bit, dtype and layout included, so an estimator fed either way computes
the same numbers."""

from __future__ import annotations

import numpy as np
import pytest

from phri_common.taxels import TaxelCloudEncoder, msg_to_taxels


@pytest.mark.parametrize("weighted", [False, True])
def test_handed_over_frame_is_the_decoded_message(weighted: bool) -> None:
    rng = np.random.default_rng(11)
    n = 257
    encoder = TaxelCloudEncoder(rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), "link",
                                rng.uniform(0.0, 2.0, n) if weighted else None)
    for k in range(3):
        forces = rng.uniform(-1.0, 30.0, n)  # float64: both must round them to float32 alike
        direct = encoder.taxels(forces, 1000 + k)
        decoded = msg_to_taxels(encoder.encode(forces, 1000 + k))
        assert direct == decoded
        assert (direct.frame_id, direct.stamp_ns) == ("link", 1000 + k)
        for name in ("positions", "normals", "forces", "weights"):
            a, b = getattr(direct, name), getattr(decoded, name)
            if b is None:
                assert a is None
                continue
            assert a.dtype == b.dtype == np.float32 and a.strides == b.strides
            assert a.tobytes() == b.tobytes()
        assert not np.shares_memory(direct.forces, encoder.taxels(forces, 0).forces)
