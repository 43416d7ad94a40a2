"""The ROS domain of an in-process run (`phri sim`, `phri followability`, `phri paper-report`).

A lock-step simulation runs every node in one process and talks to them over DDS. On a machine
where other ROS processes run in the same domain (another ``phri sim``, a robot, a colleague's
stack), their messages reach our nodes: another run's ``/cmd_vel`` moves our simulated base, and
contact states with foreign stamps stall the lock-step (measured: ``LockStepError: timed out
waiting for sensor data`` and commands "from nowhere" while two runs shared domain 0). So a run
picks its domain explicitly (pure: the caller applies the result to ``os.environ`` before
``rclpy.init``):

* ``--ros-domain-id N`` if given;
* else ``$ROS_DOMAIN_ID`` if the user has set one (they chose to share it, e.g. to watch with
  ``ros2 topic echo`` or rviz);
* else a private domain, 1 + pid mod 100, with discovery restricted to localhost.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

MAX_DOMAIN_ID = 232
"""Largest ROS 2 domain id whose DDS ports are valid on Linux (ROS 2 docs, "The ROS_DOMAIN_ID")."""


def private_domain_id(pid: int | None = None) -> int:
    """A domain id for this process, 1…100, from its pid."""
    return 1 + (os.getpid() if pid is None else pid) % 100


def run_domain(requested: int | None, environ: Mapping[str, str],
               pid: int | None = None) -> tuple[int, dict[str, str], str]:
    """(domain id, environment variables to set, a line saying why) for a run.

    Raises:
        ValueError: ``requested`` or ``$ROS_DOMAIN_ID`` outside 0…232, naming which.
    """
    if requested is not None:
        domain, why = _checked(requested, "--ros-domain-id"), "--ros-domain-id"
    elif environ.get("ROS_DOMAIN_ID", "").strip():
        text = environ["ROS_DOMAIN_ID"].strip()
        try:
            value = int(text)
        except ValueError:
            raise ValueError(f"ROS_DOMAIN_ID={text!r}: must be an integer 0…{MAX_DOMAIN_ID}") \
                from None
        domain, why = _checked(value, "ROS_DOMAIN_ID"), "$ROS_DOMAIN_ID (shared with other ROS "
        why += "processes in it: they can disturb a lock-step run)"
    else:
        domain = private_domain_id(pid)
        return domain, {"ROS_DOMAIN_ID": str(domain),
                        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}, (
            f"a private ROS domain {domain}, localhost only (watch it with "
            f"ROS_DOMAIN_ID={domain}; set ROS_DOMAIN_ID or --ros-domain-id to choose)")
    return domain, {"ROS_DOMAIN_ID": str(domain)}, f"ROS domain {domain} from {why}"


def _checked(value: int, name: str) -> int:
    if not 0 <= value <= MAX_DOMAIN_ID:
        raise ValueError(f"{name}={value}: must be 0…{MAX_DOMAIN_ID}")
    return value
