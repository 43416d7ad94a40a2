"""QoS profiles of the controller node's inputs."""

from __future__ import annotations

from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

CONTACT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=25,
                         reliability=ReliabilityPolicy.BEST_EFFORT)
"""Contact states: best effort (a late state is never worth a retransmission), but 25 deep —
50 ms of a link's 500 Hz states — because with the sensor-data depth of 5 a controller process
held off the CPU for over 10 ms lost states in the DDS queue (bench_chain: 0.04 % of frames on a
quiet machine, ≈ 5 % on a loaded one). Every queued state is read in order; the stamps' age
check (``contact_timeout``) still refuses what is stale."""


SCALING_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                         reliability=ReliabilityPolicy.BEST_EFFORT)
"""UR speed scaling: only the newest value matters (ur_robot_driver offers it reliable, which a
best-effort reader matches)."""
