"""Smooth 0 → 1 time profiles for scripted motions (pure): cosine ramp and minimum jerk."""

from __future__ import annotations

import math


def smoothstep(x: float) -> float:
    """0 → 1 cosine ramp on x ∈ [0, 1] (clamped), zero slope at both ends."""
    x = min(max(x, 0.0), 1.0)
    return 0.5 - 0.5 * math.cos(math.pi * x)


def smoothstep_rate(x: float, duration: float) -> float:
    """d/dt of :func:`smoothstep` (x = t / duration) [1/s]."""
    if not 0.0 < x < 1.0:
        return 0.0
    return 0.5 * math.pi * math.sin(math.pi * x) / duration


def minimum_jerk(x: float) -> float:
    """0 → 1 minimum-jerk profile 10x³ − 15x⁴ + 6x⁵ on x ∈ [0, 1] (clamped): zero velocity and
    acceleration at both ends, as a person moves a hand or the body between two poses."""
    x = min(max(x, 0.0), 1.0)
    return x * x * x * (10.0 + x * (-15.0 + 6.0 * x))


def minimum_jerk_rate(x: float, duration: float) -> float:
    """d/dt of :func:`minimum_jerk` (x = t / duration) [1/s]."""
    if not 0.0 < x < 1.0:
        return 0.0
    return 30.0 * x * x * (1.0 - x) * (1.0 - x) / duration
