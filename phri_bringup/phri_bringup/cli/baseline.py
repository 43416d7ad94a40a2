"""``phri sim``'s motionless baseline, run beside the simulation in a process of its own.

The baseline (:func:`phri_sim.ros.motionless.run_motionless`: the same scenario and options
played on the simulated world alone, a robot never commanded) needs nothing from the run, so
:class:`MotionlessBaseline` starts it with the run, in a spawned process on the machine's other
core, and :meth:`~MotionlessBaseline.result` collects it afterwards. The process builds the same
scenario value from the same recipe (:class:`Recipe`: the scenario's name, parameter file and
partner options). It runs no node, so it needs no ROS domain of its own. It ignores Ctrl-C (the
command stops it when it stops).
"""

from __future__ import annotations

import argparse
import multiprocessing
import signal
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Recipe:
    """How ``phri sim`` made its scenario value: the canonical scenario name, the parameter file
    (None: the scenario's own) and the partner options (``lead``, ``tempo_scale``, ``sway``,
    ``partner_hand`` of the command line)."""

    name: str
    params: str | None
    partner: argparse.Namespace

    @classmethod
    def of(cls, name: str, params: str | None, args: argparse.Namespace) -> Recipe:
        partner = argparse.Namespace(lead=args.lead, tempo_scale=args.tempo_scale,
                                     sway=args.sway, partner_hand=args.partner_hand)
        return cls(name, params, partner)

    def scenario(self) -> Any:
        """The scenario value (:func:`~phri_bringup.cli.session.session_scenario` with the
        partner variant), as ``run_session`` builds it."""
        from phri_bringup.cli.main import partner_variant
        from phri_bringup.cli.session import session_scenario

        values = session_scenario(self.name, self.params)
        vary = partner_variant(self.partner)
        return values if vary is None else vary(values)


class MotionlessBaseline:
    """The motionless baseline of ``recipe`` with ``options`` running in its own process
    (module docstring)."""

    def __init__(self, recipe: Recipe, options: Any) -> None:
        ctx = multiprocessing.get_context("spawn")
        self._conn, child = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=_baseline_process, name="phri-baseline",
                                    args=(recipe, options, child), daemon=True)
        self._process.start()
        child.close()

    def result(self) -> tuple[dict[str, Any], Any]:
        """(metrics, following series) of the baseline, once it has run.

        Raises:
            RuntimeError: the baseline failed (the message says how).
        """
        try:
            status, value = self._conn.recv()
        except EOFError:
            status, value = "error", "the baseline process ended without a result"
        self._process.join()
        if status != "ok":
            raise RuntimeError(f"motionless baseline: {value}")
        metrics, series = value
        return metrics, series

    def cancel(self) -> None:
        """Stop the baseline (not needed, or the command stops)."""
        if self._process.is_alive():
            self._process.terminate()
        self._process.join()


def _baseline_process(recipe: Recipe, options: Any, conn: Any) -> None:
    """The baseline process: the run, the result through ``conn``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from phri_sim.ros.motionless import run_motionless

    try:
        result: tuple[str, Any] = ("ok", run_motionless(recipe.scenario(), options))
    except Exception as err:  # reported by the parent
        result = ("error", f"{type(err).__name__}: {err}")
    conn.send(result)
    conn.close()
