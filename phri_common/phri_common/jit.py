"""Marking a plain Python function as callable from compiled (numba) code.

A function decorated with :func:`jitable` stays an ordinary Python function — the readable path,
``kernel: python`` and every test call it as it is — and becomes compilable into a numba kernel
that calls it (numba's ``register_jitable``). So each formula is written once and runs both
ways. Without numba installed the decorator does nothing and only the Python path exists.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

F = TypeVar("F", bound=Callable[..., object])

_register: Callable[..., object] | None
try:
    from numba.extending import register_jitable as _register
except ImportError:  # pragma: no cover - numba is a dependency; the Python path needs none
    _register = None


def jitable(function: F) -> F:
    """``function`` itself, registered for compiled callers when numba is available."""
    if _register is not None:
        _register(function)
    return function


def numba_available() -> bool:
    """Whether compiled kernels can be built here."""
    return _register is not None
