"""ROS 2 node: skin taxel arrays → one contact state per link per frame, plus rviz markers.

Thin wrapper around :class:`contact_estimation.estimator.ContactEstimator`. Interface
(documented in docs/contact_estimation.md):

* subscribes ``skin/<patch>/taxels`` (sensor_msgs/PointCloud2, see phri_common.taxels) for every
  patch in ``patches``;
* publishes ``contacts/<link>`` (sensor_msgs/PointCloud2, see phri_common.contact) once for
  every accepted frame of one of the link's patches;
* publishes ``contacts/markers`` (visualization_msgs/MarkerArray) when ``publish_markers``,
  per link at most ``marker_rate_hz`` (on state time) and whenever contact starts or ends;
* publishes ``/diagnostics`` (diagnostic_msgs/DiagnosticArray) every ``diagnostics_period``;
* serves ``~/reset_geometry`` (std_srvs/Trigger): every patch forgets its geometry, and its next
  frame sets it (the announcement of a new layout).

A refused frame (malformed message, NaN/Inf anywhere, a force beyond ``max_taxel_force``, an
empty cloud, wrong frame_id, wrong size, a stuck skin repeating its loaded frame for longer than
``stuck_timeout``; checked on every frame; a geometry other than the patch's: another taxel count
or weighting on every frame, other positions or normals every ``geometry_check_interval``-th
frame; a patch learns its geometry from its first frame and changes it only after
``~/reset_geometry``) is counted, reported on
diagnostics and logged (throttled); no contact state is published for it, the node stays up and
keeps serving every other patch. Downstream treats the missing state as stale.
"""

from __future__ import annotations

import math
import sys
import threading
from collections.abc import Sequence
from functools import partial
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from contact_estimation.estimator import (
    DEFAULT_MAX_TAXEL_FORCE,
    KERNELS,
    MAX_TAXEL_FORCE_RANGE,
    PAPER_TORQUE_LIMIT,
    ContactEstimator,
    EstimatorConfig,
    GeometryMismatch,
    InvalidTaxelData,
)
from contact_estimation.markers import MarkerScales, MarkerThrottle, contact_markers
from contact_estimation.plausibility import (
    DeadRegionDetector,
    FrozenDetector,
    PlausibilityConfig,
    SkinImplausible,
)
from phri_common.contact_cdr import contact_to_cdr
from phri_common.params import ParamSpec, ParamValue
from phri_common.protected import UNLOCK_PARAM
from phri_common.records import ContactState, TaxelArray
from phri_common.ros_main import run_nodes
from phri_common.ros_params import declare_parameters
from phri_common.taxels import TaxelMessageError, msg_to_taxels
from phri_common.taxels_cdr import taxel_table_from_cdr
from phri_description.description import SKIN_LINKS, SKIN_PATCHES

DEFAULT_PATCHES = list(SKIN_PATCHES)
"""The robot description's skin patches."""
DEFAULT_PATCH_LINKS = list(SKIN_LINKS)
"""The links that carry them (same order)."""

PARAMS: list[ParamSpec] = [
    ParamSpec("patches", DEFAULT_PATCHES, "skin patch names; patch P is read from "
              "skin/P/taxels", read_only=True, min_length=1),
    ParamSpec("patch_links", DEFAULT_PATCH_LINKS, "link frame of each patch, same order as "
              "patches; several patches may share a link", read_only=True, min_length=1),
    ParamSpec("subscribe_taxels", True, "subscribe to skin/<patch>/taxels; false when the skin "
              "drivers run in this process and hand frames over directly (skin_contact_node)",
              read_only=True),
    ParamSpec("force_threshold", 0.05, "σ_t: a taxel is in contact when its force is strictly "
              "greater", unit="N", low=0.0, high=1000.0),
    ParamSpec("torque_limit", list(PAPER_TORQUE_LIMIT), "per-axis bound on |τ| about the "
              "contact centre in the link frame (paper: τ(2) ≤ 1.2); .inf = none", unit="N·m",
              low=0.0, high=math.inf, length=3),
    ParamSpec("max_taxel_force", DEFAULT_MAX_TAXEL_FORCE, "the skin's rated range: a frame "
              "with any taxel |force| above it is refused as corrupted (the default skin "
              "saturates at ≈ 32 N)", unit="N", low=MAX_TAXEL_FORCE_RANGE[0],
              high=MAX_TAXEL_FORCE_RANGE[1], loosens="up"),
    ParamSpec("stuck_timeout", 0.5, "a touched patch whose frame repeats bit for bit for longer "
              "than this is stuck: its frames are refused", unit="s", low=0.01, high=60.0,
              loosens="up"),
    ParamSpec("plausibility_dead_time", 1.0, "a taxel whose force has not changed for this "
              "long is silent (0 = no dead-region check)", unit="s", low=0.0, high=60.0,
              loosens="up_or_off"),
    ParamSpec("plausibility_dead_fraction", 0.25, "a patch with a larger share of silent taxels "
              "is a dead region: its frames are refused, diagnostics ERROR", low=0.0, high=1.0,
              loosens="up"),
    ParamSpec("plausibility_frozen_window", 2.0, "a link touched this long whose contact force "
              "and centre stay within the two bounds below is still: diagnostics WARN, its "
              "frames are kept (the controller checks a still skin against the joints; 0 = no "
              "stillness report)", unit="s", low=0.0, high=60.0, loosens="up_or_off"),
    ParamSpec("plausibility_frozen_force_ratio", 0.05, "still: contact force range below this "
              "fraction of its mean over the window", low=0.0, high=1.0, loosens="down"),
    ParamSpec("plausibility_frozen_center_range", 2e-3, "still: contact centre range below "
              "this on every axis over the window", unit="m", low=0.0, high=1.0,
              loosens="down"),
    ParamSpec("kernel", KERNELS[0], "how the per-link sums are computed: numba (compiled, "
              "default) or numpy (the reference); same states to rounding"),
    ParamSpec("publish_markers", True, "publish rviz markers on contacts/markers"),
    ParamSpec("marker_rate_hz", 30.0, "most marker arrays per second per link (state time; a "
              "contact that starts or ends is always drawn); 0 = every frame", unit="Hz",
              low=0.0, high=1000.0),
    ParamSpec("marker_force_scale", 0.01, "force arrow length per newton", unit="m/N",
              low=0.0, high=10.0),
    ParamSpec("marker_torque_scale", 0.1, "torque arrow length per N·m", unit="m/(N·m)",
              low=0.0, high=10.0),
    ParamSpec("geometry_check_interval", 50, "compare a patch's taxel positions/normals with "
              "its geometry every N-th frame and refuse a frame that differs (another taxel "
              "count is refused on every frame, and so are NaN/Inf values); 1 = every frame",
              unit="frames", low=1, high=1_000_000),
    ParamSpec("diagnostics_period", 1.0, "period of the /diagnostics report", unit="s",
              low=0.05, high=3600.0),
    UNLOCK_PARAM,
]

TAXEL_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
"""skin/<patch>/taxels: best effort (sensor data; matches the drivers' reliable writers). A
reliable reader acknowledges every message, CPU of this node on every frame at 500 Hz
(docs/benchmarks.md, "Contact estimation"), for a repair that only a lost frame would need and
that would arrive after the next frame anyway."""
STATE_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
"""contacts/<link>: reliable, for a reliable reader (a recorder); the controller reads them best
effort."""


def config_from_values(values: dict[str, ParamValue]) -> EstimatorConfig:
    """Parameter values → estimator config (raises ValueError naming the parameter)."""
    limit = values["torque_limit"]
    assert isinstance(limit, list)
    return EstimatorConfig(
        force_threshold=float(values["force_threshold"]),
        torque_limit=(float(limit[0]), float(limit[1]), float(limit[2])),
        max_taxel_force=float(values["max_taxel_force"]),
        stuck_timeout=float(values["stuck_timeout"]),
        kernel=str(values["kernel"]),
    )


def plausibility_from_values(values: dict[str, ParamValue]) -> PlausibilityConfig:
    """The skin-alone checks' settings (:mod:`contact_estimation.plausibility`)."""
    return PlausibilityConfig(
        dead_time=float(values["plausibility_dead_time"]),
        max_dead_fraction=float(values["plausibility_dead_fraction"]),
        frozen_window=float(values["plausibility_frozen_window"]),
        frozen_force_ratio=float(values["plausibility_frozen_force_ratio"]),
        frozen_center_range=float(values["plausibility_frozen_center_range"]),
    )


def patch_link_map(patches: Sequence[str], links: Sequence[str]) -> dict[str, str]:
    """Pair ``patches`` with ``patch_links``; ValueError names both parameters on mismatch."""
    if len(patches) != len(links):
        raise ValueError(
            f"parameters 'patches' ({len(patches)} entries) and 'patch_links' ({len(links)} "
            "entries) must have the same length"
        )
    if len(set(patches)) != len(patches):
        raise ValueError(
            f"parameter 'patches' refused value {list(patches)}: names must be unique"
        )
    bad = [p for p in [*patches, *links] if not p or "/" in p or " " in p]
    if bad:
        raise ValueError(
            f"parameters 'patches'/'patch_links' refused names {bad}: allowed non-empty names "
            "without '/' or spaces"
        )
    return dict(zip(patches, links, strict=True))


class ContactEstimationNode(Node):
    """Per-link contact estimation from skin patches (paper Sec. IV-A/B)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("contact_estimation", **kwargs)
        self._values = declare_parameters(self, PARAMS, on_change=self._on_change)
        patches = list(self._values["patches"])
        links = list(self._values["patch_links"])
        self._patch_links = patch_link_map(patches, links)
        # Taken by every frame and by reconfiguration: a composed skin driver calls on_frame
        # from its serial thread while the executor runs parameter changes.
        self._lock = threading.Lock()
        self._estimator = ContactEstimator(self._patch_links, config_from_values(self._values))
        plausibility = plausibility_from_values(self._values)
        self._dead = DeadRegionDetector(plausibility)
        self._frozen = FrozenDetector(plausibility)
        self._implausible: dict[str, str] = dict.fromkeys(patches, "")
        self._still: dict[str, str] = dict.fromkeys(patches, "")
        self._scales = self._marker_scales(self._values)
        self._publish_markers = bool(self._values["publish_markers"])
        self._geometry_interval = int(self._values["geometry_check_interval"])
        self._marker_throttle = MarkerThrottle(float(self._values["marker_rate_hz"]))
        self._received = dict.fromkeys(patches, 0)
        self._refused = dict.fromkeys(patches, 0)
        self._last_error: dict[str, str] = dict.fromkeys(patches, "")
        self._mismatches = dict.fromkeys(patches, 0)
        self._mismatch_taxels = dict.fromkeys(patches, 0)  # size of the last refused geometry
        self._state_pubs = {
            link: self.create_publisher(PointCloud2, f"contacts/{link}", STATE_QOS)
            for link in self._estimator.links
        }
        self._marker_pub = self.create_publisher(MarkerArray, "contacts/markers", 10)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        # raw=True: the serialized bytes, read as views without rclpy's message objects
        # (phri_common.taxels_cdr; other layouts take the full path of _on_taxels).
        self._subs = [
            self.create_subscription(
                PointCloud2, f"skin/{patch}/taxels", partial(self._on_taxel_bytes, patch),
                TAXEL_QOS, raw=True,
            )
            for patch in patches
            if self._values["subscribe_taxels"]
        ]
        period = float(self._values["diagnostics_period"])
        self._diag_timer = self.create_timer(period, self._publish_diagnostics)
        self._reset_srv = self.create_service(Trigger, "~/reset_geometry", self._on_reset_geometry)
        self.get_logger().info(
            f"estimating contacts of {len(self._estimator.links)} link(s) from "
            f"{len(patches)} patch(es): {self._patch_links}"
        )

    @staticmethod
    def _marker_scales(values: dict[str, ParamValue]) -> MarkerScales:
        return MarkerScales(
            force=float(values["marker_force_scale"]),
            torque=float(values["marker_torque_scale"]),
        )

    def _on_change(self, values: dict[str, ParamValue]) -> None:
        config = config_from_values(values)  # raises ValueError → change refused
        plausibility = plausibility_from_values(values)
        with self._lock:
            self._estimator.reconfigure(config)
            self._dead.config = self._frozen.config = plausibility
        self._scales = self._marker_scales(values)
        self._publish_markers = bool(values["publish_markers"])
        self._geometry_interval = int(values["geometry_check_interval"])
        period = float(values["diagnostics_period"])
        if period != float(self._values["diagnostics_period"]):
            self._diag_timer.timer_period_ns = int(period * 1e9)
        self._marker_throttle.set_rate(float(values["marker_rate_hz"]))
        self._values = values

    def _on_taxel_bytes(self, patch: str, data: bytes) -> None:
        frame = taxel_table_from_cdr(data)
        if frame is None:  # not phri's own layout: the reference decoder
            self._on_taxels(patch, deserialize_message(data, PointCloud2))
            return
        frame_id, stamp_ns, table = frame
        with self._lock:
            check = self._count_frame(patch)
            try:
                self._check_frame_id(patch, frame_id)
                state = self._estimator.update_table(patch, table, stamp_ns, check)
                self._check_plausible(patch, table[:, 6], state)
            except InvalidTaxelData as err:
                self._refuse(patch, err)
                return
            self._publish(state)

    def _on_taxels(self, patch: str, msg: PointCloud2) -> None:
        try:
            taxels = msg_to_taxels(msg)
        except TaxelMessageError as err:
            with self._lock:
                self._received[patch] += 1
                self._refuse(patch, err)
            return
        self.on_frame(patch, taxels)

    def on_frame(self, patch: str, taxels: TaxelArray) -> None:
        """Estimate and publish from one frame of ``patch`` (thread-safe).

        Called for every message on ``skin/<patch>/taxels`` of another layout than phri's
        own (whose bytes :meth:`_on_taxel_bytes` reads in place), and directly by a skin driver
        composed into the same process (``phri_bringup.skin_contact_node``), which skips the
        message round trip; refusals and diagnostics are the same either way.
        """
        with self._lock:
            check = self._count_frame(patch)
            try:
                self._check_frame_id(patch, taxels.frame_id)
                state = self._estimator.update(patch, taxels, check_geometry=check)
                self._check_plausible(patch, taxels.forces, state)
            except InvalidTaxelData as err:
                self._refuse(patch, err)
                return
            self._publish(state)

    def _check_plausible(self, patch: str, forces: Any, state: ContactState) -> None:
        """The skin-alone plausibility checks on an accepted frame (:mod:`~contact_estimation.
        plausibility`): a dead region raises :class:`SkinImplausible`, remembered for
        diagnostics (ERROR) until a frame of the patch passes again; a still link is remembered
        for diagnostics (WARN), its frames are kept."""
        try:
            self._dead.check(patch, forces, state.stamp_ns)
        except SkinImplausible as err:
            if not self._implausible[patch]:
                self.get_logger().error(f"{err}: its link's contact state is withheld (the "
                                        "controller's input goes stale: zero command)")
            self._implausible[patch] = str(err)
            raise
        if self._implausible[patch]:
            self.get_logger().info(f"patch {patch!r} plausible again")
        self._implausible[patch] = ""
        fx, fy, fz = state.force.tolist()
        still = self._frozen.check(patch, math.sqrt(fx * fx + fy * fy + fz * fz),
                                   tuple(state.center.tolist()), state.in_contact, state.stamp_ns)
        if still and not self._still[patch]:
            self.get_logger().info(f"patch {patch!r} still: {still}")
        self._still[patch] = still

    def _count_frame(self, patch: str) -> bool:
        """Count a frame of ``patch``; whether its geometry is to be compared with the known
        one (every ``geometry_check_interval``-th frame, the first included)."""
        count = self._received[patch] = self._received[patch] + 1
        interval = self._geometry_interval
        return interval == 1 or count % interval == 1

    def _check_frame_id(self, patch: str, frame_id: str) -> None:
        link = self._patch_links[patch]
        if frame_id != link:
            raise InvalidTaxelData(f"frame_id {frame_id!r}, expected the patch's link {link!r}")

    def _publish(self, state: ContactState) -> None:
        # Serialized here (phri_common.contact_cdr): rclpy's conversion of the message's
        # 17 PointField objects would cost several times more.
        self._state_pubs[state.link].publish(contact_to_cdr(state))
        if self._publish_markers and self._marker_throttle.due(state):
            self._marker_pub.publish(MarkerArray(markers=contact_markers(state, self._scales)))

    def _on_reset_geometry(self, request: Trigger.Request,
                           response: Trigger.Response) -> Trigger.Response:
        """``~/reset_geometry``: every patch forgets its geometry; its next frame sets it."""
        with self._lock:
            self._estimator.forget_geometry()
            self._dead.forget()
        response.success = True
        response.message = (f"geometry of {len(self._patch_links)} patch(es) forgotten: each "
                            "patch's next frame sets it")
        self.get_logger().info(f"~/reset_geometry: {response.message}")
        return response

    def _refuse(self, patch: str, err: Exception) -> None:
        self._refused[patch] += 1
        self._last_error[patch] = str(err)
        if isinstance(err, GeometryMismatch):
            self._mismatches[patch] += 1
            self._mismatch_taxels[patch] = err.received
        self.get_logger().warning(
            f"refused a frame of patch {patch!r}: {err}", throttle_duration_sec=1.0
        )

    def patch_status(self, patch: str) -> DiagnosticStatus:
        """The diagnostic status of ``patch``: frames received and refused, the refusals for
        another geometry with both sizes, the last error."""
        with self._lock:
            refused, received = self._refused[patch], self._received[patch]
            mismatches, wrong = self._mismatches[patch], self._mismatch_taxels[patch]
            taxels = self._estimator.taxel_count(patch)
            last_error = self._last_error[patch]
            implausible = self._implausible[patch]
            still = self._still[patch]
            silent = self._dead.silent.get(patch, 0)
        level = DiagnosticStatus.OK if refused == 0 and received else DiagnosticStatus.WARN
        message = "no frames yet" if received == 0 else (
            "ok" if refused == 0 else f"{refused} frame(s) refused")
        if still and level == DiagnosticStatus.OK:
            level, message = DiagnosticStatus.WARN, f"still contact: {still}"
        if implausible:
            level, message = DiagnosticStatus.ERROR, f"implausible skin: {implausible}"

        if mismatches:
            message += (f", {mismatches} of another geometry ({wrong} taxels, the patch has "
                        f"{taxels})")
        values = {"frames_received": received, "frames_refused": refused,
                  "taxels": "-" if taxels is None else taxels,
                  "geometry_mismatches": mismatches, "mismatch_taxels": wrong,
                  "silent_taxels": silent,
                  "implausible": implausible or "no", "still": still or "no",
                  "last_error": last_error}
        return DiagnosticStatus(
            level=level, name=f"contact_estimation: {patch}",
            hardware_id=self._patch_links[patch], message=message,
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])

    def _publish_diagnostics(self) -> None:
        statuses = [self.patch_status(patch) for patch in self._patch_links]
        msg = DiagnosticArray(status=statuses)
        msg.header.stamp = self.get_clock().now().to_msg()
        self._diag_pub.publish(msg)

    @property
    def patches(self) -> tuple[str, ...]:
        """The skin patches this node estimates from (parameter ``patches``)."""
        return tuple(self._patch_links)

    @property
    def received_frames(self) -> dict[str, int]:
        """Frames received per patch since start-up (refused ones included)."""
        return dict(self._received)

    @property
    def refused_frames(self) -> dict[str, int]:
        """Refused frames per patch since start-up."""
        return dict(self._refused)


def main(args: list[str] | None = None) -> None:
    """Entry point ``contact_estimation_node``: run the node until Ctrl-C or SIGTERM."""
    sys.exit(run_nodes(lambda: [ContactEstimationNode()], "contact_estimation", args))


__all__ = ["PARAMS", "ContactEstimationNode", "main"]
