"""The paper's figure panels (Fig. 6–8, and Fig. 1 for the waltz) from a recording.

:func:`read_run` reads an MCAP recording back with rosbags (CDR deserialised by rclpy, ~40×
faster than rosbags' own deserialiser; the structured PointCloud2 records decoded by phri's own
codecs) into numpy series;
:func:`make_plots` draws the panels as PNG files and returns the key numbers (also written as
``plots.json``):

| file | content (paper) |
|---|---|
| ``contact_force.png`` | resultant force ‖ᶦf_η‖ per skin link, estimated (9a) and true (Fig. 6–8) |
| ``contact_torque.png`` | torque about the contact centre ᶦτ_η (9b), link frame (Fig. 6) |
| ``contact_centre.png`` | contact centre ᶦp_η (5), link frame, estimated and true (Fig. 6, 7) |
| ``priority_psi.png`` | weight ψ (15) per link (Fig. 8) |
| ``arm_joint_velocities.png`` | measured arm joint velocities, ±0.15 rad/s bound (Fig. 6–8) |
| ``base_velocity.png`` | base twist commanded (/cmd_vel) and measured (/odom) (Fig. 8) |
| ``waltz_path.png`` | waltz only: the person's torso and the robot base in the plane (Fig. 1) |
| ``waltz_contact_force.png`` | waltz only: waist force on the left forearm vs the desired 10 N |
| ``fig6_contact_centring.png`` … | the paper's Fig. 6 / 7 / 8 page (:mod:`.paper_figures`) |
"""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_bringup.graph.nodes import ARMS, CONTROLLER, SKIN_LINKS
from phri_bringup.observer.bag import find_recording, ros_type
from phri_common import paper
from phri_common.planar import yaw_from_quaternion
from phri_description.description import BASE_JOINTS
from phri_sim.scenarios.catalogue import WALTZ_LINK

FloatArray = NDArray[np.float64]

VELOCITY_LIMIT = paper.VELOCITY_LIMIT
"""Table II joint speed bound [rad/s, m/s], drawn on the velocity panels."""
WALTZ_FORCE = paper.WALTZ_DESIRED_FORCE
"""Desired waist force of the waltz [N] (Sec. VI-B)."""


@dataclass
class Series:
    """Samples of a vector signal: times [s] (sim time) and values (N × k)."""

    t: FloatArray
    v: FloatArray

    @classmethod
    def of(cls, rows: list[tuple[float, list[float]]], width: int) -> Series:
        if not rows:
            return cls(np.zeros(0), np.zeros((0, width)))
        return cls(np.array([r[0] for r in rows]), np.array([r[1] for r in rows], dtype=float))


@dataclass
class RunData:
    """Everything the panels need, from one recording."""

    force: dict[str, Series] = field(default_factory=dict)
    torque: dict[str, Series] = field(default_factory=dict)
    centre: dict[str, Series] = field(default_factory=dict)
    in_contact: dict[str, Series] = field(default_factory=dict)
    true_force: dict[str, Series] = field(default_factory=dict)
    true_centre: dict[str, Series] = field(default_factory=dict)
    psi: dict[str, Series] = field(default_factory=dict)
    track_force: dict[str, Series] = field(default_factory=dict)
    region: dict[str, Series] = field(default_factory=dict)
    """Ω_i per link: lower then upper corner (6) [m]."""
    joint_names: list[str] = field(default_factory=list)
    joint_velocity: Series = field(default_factory=lambda: Series.of([], 12))
    cmd_vel: Series = field(default_factory=lambda: Series.of([], 3))
    odom: Series = field(default_factory=lambda: Series.of([], 6))
    torso: Series = field(default_factory=lambda: Series.of([], 2))


Rows = dict[str, list[tuple[float, list[float]]]]
"""Samples per series key while reading: (time [s], values)."""


STATE_PREFIX = f"/{CONTROLLER}/state/"
"""Topic prefix of the controller's per-link task state."""
PLOTTED_PREFIXES = ("/contacts/left", "/contacts/right", "/sim/", STATE_PREFIX,
                    "/joint_states", "/cmd_vel", "/odom")
"""Topics the panels read (by prefix)."""


class RunBuilder:
    """The panels' series from a run's messages, one at a time in the order recorded
    (:meth:`add`), then :meth:`result`: what :func:`read_run` reads from a recording, and what
    the recording process builds while it records (``phri sim`` then draws without reading
    the recording back)."""

    def __init__(self) -> None:
        self.rows: Rows = defaultdict(list)
        self.data = RunData()

    def add(self, topic: str, type_name: str, raw: bytes, t: float) -> None:
        """A message of ``topic`` (``pkg/msg/Type``) as CDR bytes at time ``t`` [s]."""
        from rclpy.serialization import deserialize_message

        if not topic.startswith(PLOTTED_PREFIXES):
            return
        if not _add_cdr_sample(topic, raw, t, self.rows, self.data):
            msg = deserialize_message(raw, ros_type(type_name))
            _add_sample(topic, msg, t, self.rows, self.data)

    def result(self) -> RunData:
        """The series of every message added."""
        rows, data = self.rows, self.data
        for link in SKIN_LINKS:
            data.force[link] = Series.of(rows["force/" + link], 3)
            data.torque[link] = Series.of(rows["torque/" + link], 3)
            data.centre[link] = Series.of(rows["centre/" + link], 3)
            data.in_contact[link] = Series.of(rows["in_contact/" + link], 1)
            data.true_force[link] = Series.of(rows["true_force/" + link], 3)
            data.true_centre[link] = Series.of(rows["true_centre/" + link], 3)
            data.psi[link] = Series.of(rows["psi/" + link], 1)
            data.track_force[link] = Series.of(rows["track/" + link], 3)
            data.region[link] = Series.of(rows["region/" + link], 6)
        data.joint_velocity = Series.of(rows["qd"], 12)
        data.cmd_vel = Series.of(rows["cmd_vel"], 3)
        data.odom = Series.of(rows["odom"], 6)
        data.torso = Series.of(rows["torso"], 2)
        return data


class PanelsBuilder:
    """A :class:`RunBuilder` whose :meth:`result` also draws the panels (:func:`make_plots`)
    into ``out_dir``. ``phri sim`` hands it to the recording process, which then draws them
    while the run's metrics and following plot are computed (docs/benchmarks.md, "Main
    command")."""

    def __init__(self, out_dir: str, scenario: str | None = None) -> None:
        self.series = RunBuilder()
        self.out_dir = out_dir
        self.scenario = scenario
        warm = figure(1, "warm-up")[0]  # matplotlib's import and fonts now, during the run
        warm.canvas.draw()
        _close(warm)

    def add(self, topic: str, type_name: str, raw: bytes, t: float) -> None:
        """As :meth:`RunBuilder.add`."""
        self.series.add(topic, type_name, raw, t)

    def result(self) -> tuple[list[Path], dict[str, Any]]:
        """The panels' files and key numbers, as :func:`make_plots` returns them."""
        return make_plots(self.series.result(), self.out_dir, scenario=self.scenario)


def read_run(path: str | Path) -> RunData:
    """Read a recording (run directory, recording directory or ``.mcap``) with rosbags."""
    from rosbags.highlevel import AnyReader

    builder = RunBuilder()
    with AnyReader([find_recording(path)]) as reader:
        wanted = [c for c in reader.connections if c.topic.startswith(PLOTTED_PREFIXES)]
        for conn, stamp, raw in reader.messages(connections=wanted):
            builder.add(conn.topic, conn.msgtype, raw, stamp * 1e-9)
    return builder.result()


def _add_contact(link: str, c: Any, t: float, rows: Rows) -> None:
    rows["force/" + link].append((t, list(c.force)))
    rows["torque/" + link].append((t, list(c.torque)))
    rows["centre/" + link].append((t, list(c.center)))
    rows["in_contact/" + link].append((t, [float(c.in_contact)]))
    rows["region/" + link].append((t, [*c.region_min, *c.region_max]))


def _add_state(link: str, state: dict[str, float], t: float, rows: Rows) -> None:
    rows["psi/" + link].append((t, [state["psi"]]))
    rows["track/" + link].append((t, [state[f"track_force_{a}"] for a in "xyz"]))


def _add_cdr_sample(topic: str, raw: bytes, t: float, rows: Rows, data: RunData) -> bool:
    """File a message read straight from its serialized bytes (no rclpy message objects: a
    recording holds a quarter of a million; contact and task states carry 17 or 40
    ``PointField`` s); False for big-endian bytes or another topic, which :func:`_add_sample`
    decodes."""
    if topic.startswith(("/contacts/", STATE_PREFIX)):
        return _add_cdr_state(topic, raw, t, rows)
    return _add_cdr_sim(topic, raw, t, rows, data)


def _add_cdr_sim(topic: str, raw: bytes, t: float, rows: Rows, data: RunData) -> bool:
    """:func:`_add_cdr_sample` for the simulator's and the robot's standard messages (the
    same series as :func:`_add_sample`)."""
    import phri_common.cdr as cdr

    if topic.endswith(("/wrench", "/center")) and topic.startswith("/sim/contacts/"):
        xyz = cdr.stamped_xyz_from_cdr(raw, topic)
        key = "true_force/" if topic.endswith("/wrench") else "true_centre/"
        if xyz is not None:
            rows[key + topic.split("/")[3]].append((t, list(xyz)))
        return xyz is not None
    if topic == "/sim/person/poses":
        poses = cdr.pose_array_from_cdr(raw)
        if poses:
            rows["torso"].append((t, list(poses[0][:2])))
        return poses is not None
    if topic == "/joint_states":  # the arm joints (the base is in /odom)
        js = cdr.joint_state_arrays_from_cdr(raw)
        if js is not None:
            arm = [i for i, name in enumerate(js[0]) if name not in BASE_JOINTS]
            data.joint_names = [js[0][i] for i in arm]
            if len(js[2]) == len(js[0]):  # a state without velocities has none to plot
                rows["qd"].append((t, [js[2][i] for i in arm]))
        return js is not None
    if topic == "/cmd_vel":
        tw = cdr.twist_from_cdr(raw)
        if tw is not None:
            rows["cmd_vel"].append((t, [tw[0], tw[1], tw[5]]))
        return tw is not None
    if topic == "/odom":
        odom = cdr.odometry_from_cdr(raw)
        if odom is not None:
            (x, y, _z, qx, qy, qz, qw), tw = odom
            rows["odom"].append((t, [x, y, yaw_from_quaternion(qw, qx, qy, qz),
                                     tw[0], tw[1], tw[5]]))
        return odom is not None
    return False


def _add_cdr_state(topic: str, raw: bytes, t: float, rows: Rows) -> bool:
    """:func:`_add_cdr_sample` for phri's contact and task states."""
    from phri_common.contact_cdr import contact_from_cdr
    from wholebody_controller.messages import task_state_from_cdr

    if topic.startswith("/contacts/"):
        contact = contact_from_cdr(raw)
        if contact is not None:
            _add_contact(topic.split("/")[-1], contact, t, rows)
        return contact is not None
    if topic.startswith(STATE_PREFIX):
        state = task_state_from_cdr(raw)
        if state is not None:
            _add_state(topic[len(STATE_PREFIX):], state, t, rows)
        return state is not None
    return False


def _add_sample(topic: str, msg: Any, t: float, rows: Rows, data: RunData) -> None:
    """File one decoded message at time ``t`` [s] under its series key(s)."""
    from phri_common.contact import msg_to_contact
    from wholebody_controller.messages import msg_to_task_state

    if topic.startswith("/contacts/"):
        _add_contact(topic.split("/")[-1], msg_to_contact(msg), t, rows)
    elif topic.startswith(STATE_PREFIX):
        _add_state(topic[len(STATE_PREFIX):], msg_to_task_state(msg), t, rows)
    elif topic.endswith("/wrench"):
        f = msg.wrench.force
        rows["true_force/" + topic.split("/")[3]].append((t, [f.x, f.y, f.z]))
    elif topic.endswith("/center"):
        p = msg.point
        rows["true_centre/" + topic.split("/")[3]].append((t, [p.x, p.y, p.z]))
    elif topic == "/sim/person/poses":
        if msg.poses:
            rows["torso"].append((t, [msg.poses[0].position.x, msg.poses[0].position.y]))
    elif topic == "/joint_states":  # the arm joints (the base is in /odom)
        arm = [i for i, name in enumerate(msg.name) if name not in BASE_JOINTS]
        data.joint_names = [msg.name[i] for i in arm]
        if len(msg.velocity) == len(msg.name):
            rows["qd"].append((t, [msg.velocity[i] for i in arm]))
    elif topic == "/cmd_vel":
        rows["cmd_vel"].append((t, [msg.linear.x, msg.linear.y, msg.angular.z]))
    elif topic == "/odom":
        p, q, tw = msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist
        yaw = yaw_from_quaternion(q.w, q.x, q.y, q.z)
        rows["odom"].append((t, [p.x, p.y, yaw, tw.linear.x, tw.linear.y, tw.angular.z]))


def _norm(s: Series) -> FloatArray:
    return np.linalg.norm(s.v, axis=1) if len(s.t) else np.zeros(0)


def key_numbers(data: RunData) -> dict[str, Any]:
    """Headline numbers of the panels."""
    out: dict[str, Any] = {"links": {}}
    for link in SKIN_LINKS:
        f = _norm(data.force[link])
        touched = data.in_contact[link].v[:, 0] > 0 if len(f) else np.zeros(0, bool)
        out["links"][link] = {
            "peak_force": float(f.max()) if len(f) else 0.0,
            "mean_force_in_contact": float(f[touched].mean()) if touched.any() else 0.0,
            "contact_share": float(touched.mean()) if len(touched) else 0.0,
            "peak_torque": float(np.abs(data.torque[link].v).max()) if len(f) else 0.0,
            "max_psi": float(data.psi[link].v.max()) if len(data.psi[link].t) else 0.0,
        }
    qd = data.joint_velocity.v
    out["max_arm_joint_speed"] = float(np.abs(qd).max()) if len(qd) else 0.0
    cmd = data.cmd_vel.v
    out["max_base_command"] = float(np.abs(cmd).max()) if len(cmd) else 0.0
    od = data.odom.v
    if len(od):
        out["base_travel"] = float(np.sum(np.linalg.norm(np.diff(od[:, :2], axis=0), axis=1)))
    if len(data.torso.t):
        out["torso_travel"] = float(np.sum(np.linalg.norm(np.diff(data.torso.v, axis=0),
                                                          axis=1)))
    return out


def figure(rows: int, title: str, row_height: float = 2.4) -> tuple[Any, Any]:
    """A titled figure of ``rows`` panels stacked on one time axis (Agg backend): ``(fig,
    axes)``; ``row_height`` [in] per panel."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(rows, 1, figsize=(9, row_height * rows + 0.6), sharex=True,
                             squeeze=False)
    fig.suptitle(title)
    return fig, axes[:, 0]


def _save(fig: Any, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    _close(fig)
    return path


def _close(fig: Any) -> None:
    import matplotlib.pyplot as plt

    plt.close(fig)


def make_plots(recording: str | Path | RunData, out_dir: str | Path,
               scenario: str | None = None) -> tuple[list[Path], dict[str, Any]]:
    """Draw every panel of a recording (or of its series, already read or built while it was
    recorded) into ``out_dir``; return the files and key numbers. ``scenario`` ('waltz' adds
    the waltz panels; centring, sliding, whole_body the paper's page) defaults to the one the
    recording shows (a recording whose left forearm is pushed for most of the run by the torso
    is a waltz)."""
    data = recording if isinstance(recording, RunData) else read_run(recording)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = [panel(data, out) for panel in (_force_panel, _torque_panel, _centre_panel,
                                            _psi_panel, _arm_panel, _base_panel)]
    numbers = key_numbers(data)
    if scenario is None:
        share = numbers["links"][WALTZ_LINK]["contact_share"]
        scenario = "waltz" if len(data.torso.t) and numbers.get("torso_travel", 0.0) > 0.1 \
            and share > 0.2 else ""
    if scenario == "waltz":
        files += _waltz_panels(data, out, numbers)
    if scenario in PAPER_PAGES:  # the paper's figure, panel by panel (paper_figures.py)
        from phri_bringup.reports.paper_figures import figure_page, series_from_run

        files.append(figure_page(scenario, series_from_run(data, scenario), out))
    numbers["scenario"] = scenario
    (out / "plots.json").write_text(json.dumps(numbers, indent=2) + "\n", encoding="utf-8")
    return files, numbers


AXES_XYZ = ("x", "y", "z")
PAPER_PAGES = ("centring", "sliding", "whole_body")
"""Scenarios whose recordings also get the paper's composed figure page (Figs 6, 7, 8)."""


def _force_panel(data: RunData, out: Path) -> Path:
    fig, axes = figure(3, "Resultant contact force ‖f_η‖ (eq. 9a)")
    for ax, link in zip(axes, SKIN_LINKS, strict=True):
        ax.plot(data.force[link].t, _norm(data.force[link]), label="estimated")
        if len(data.true_force[link].t):
            ax.plot(data.true_force[link].t, _norm(data.true_force[link]), "--",
                    label="true (simulator)")
        ax.set_ylabel(f"{link}\n[N]")
        ax.legend(loc="upper right", fontsize=7)
    axes[-1].set_xlabel("time [s]")
    return _save(fig, out / "contact_force.png")


def _torque_panel(data: RunData, out: Path) -> Path:
    fig, axes = figure(3, "Torque about the contact centre τ_η (eq. 9b), link frame")
    for ax, link in zip(axes, SKIN_LINKS, strict=True):
        for k in range(3):
            ax.plot(data.torque[link].t, data.torque[link].v[:, k], label=f"τ_{AXES_XYZ[k]}")
        ax.set_ylabel(f"{link}\n[N·m]")
        ax.legend(loc="upper right", fontsize=7)
    axes[-1].set_xlabel("time [s]")
    return _save(fig, out / "contact_torque.png")


def _centre_panel(data: RunData, out: Path) -> Path:
    fig, axes = figure(3, "Contact centre p_η (eq. 5), link frame; dashed: true")
    for ax, link in zip(axes, SKIN_LINKS, strict=True):
        c, touched = data.centre[link], data.in_contact[link]
        mask = touched.v[:, 0] > 0 if len(touched.t) else np.zeros(0, bool)
        for k in range(3):
            y = np.where(mask, c.v[:, k], np.nan) if len(c.t) else c.v[:, k]
            line = ax.plot(c.t, y, label=f"{AXES_XYZ[k]}")[0]
            tc = data.true_centre[link]
            if len(tc.t):
                ax.plot(tc.t, tc.v[:, k], "--", color=line.get_color(), linewidth=0.8)
        ax.set_ylabel(f"{link}\n[m]")
        ax.legend(loc="upper right", fontsize=7)
    axes[-1].set_xlabel("time [s]")
    return _save(fig, out / "contact_centre.png")


def _psi_panel(data: RunData, out: Path) -> Path:
    fig, axes = figure(1, "Weight ψ (eq. 15) per contact link")
    for link in SKIN_LINKS:
        axes[0].semilogy(data.psi[link].t, np.maximum(data.psi[link].v[:, 0], 1e-6)
                         if len(data.psi[link].t) else data.psi[link].v[:, 0], label=link)
    axes[0].set_ylabel("ψ [-]")
    axes[0].set_xlabel("time [s]")
    axes[0].legend(fontsize=7)
    return _save(fig, out / "priority_psi.png")


def _arm_panel(data: RunData, out: Path) -> Path:
    fig, axes = figure(2, "Arm joint velocities (Table II bound ±0.15 rad/s)")
    names = data.joint_names or [f"joint {i}" for i in range(12)]
    for a, (ax, arm) in enumerate(zip(axes, ARMS, strict=True)):
        for k in range(6):
            i = 6 * a + k
            if data.joint_velocity.v.shape[1] > i:
                ax.plot(data.joint_velocity.t, data.joint_velocity.v[:, i],
                        label=names[i].removeprefix(f"{arm}_"))
        for s in (-VELOCITY_LIMIT, VELOCITY_LIMIT):
            ax.axhline(s, color="k", linestyle=":", linewidth=0.8)
        ax.set_ylabel(f"{arm} arm\n[rad/s]")
        ax.legend(loc="upper right", fontsize=6, ncol=3)
    axes[-1].set_xlabel("time [s]")
    return _save(fig, out / "arm_joint_velocities.png")


def _base_panel(data: RunData, out: Path) -> Path:
    fig, axes = figure(3, "Base velocity (base frame): commanded and measured")
    labels = ("v_x [m/s]", "v_y [m/s]", "ω_z [rad/s]")
    for k, ax in enumerate(axes):
        ax.plot(data.cmd_vel.t, data.cmd_vel.v[:, k], label="/cmd_vel")
        ax.plot(data.odom.t, data.odom.v[:, 3 + k], "--", label="/odom")
        ax.set_ylabel(labels[k])
        ax.legend(loc="upper right", fontsize=7)
    axes[-1].set_xlabel("time [s]")
    return _save(fig, out / "base_velocity.png")


def _waltz_panels(data: RunData, out: Path, numbers: dict[str, Any]) -> list[Path]:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 6))
    if len(data.torso.t):
        ax.plot(data.torso.v[:, 0], data.torso.v[:, 1], label="person's torso")
    if len(data.odom.t):
        ax.plot(data.odom.v[:, 0], data.odom.v[:, 1], label="robot base")
        ax.plot(data.odom.v[:1, 0], data.odom.v[:1, 1], "ko", label="start")
    ax.set_xlabel("x [m] (odom)")
    ax.set_ylabel("y [m] (odom)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, linewidth=0.3)
    ax.legend()
    ax.set_title("Waltz: the torso leads, the base follows (Fig. 1)")
    files = [_save(fig, out / "waltz_path.png")]

    link = WALTZ_LINK
    f = _norm(data.force[link])
    fig, axes = figure(1, "Waltz: waist contact force on the left forearm")
    axes[0].plot(data.force[link].t, f, label="estimated ‖f_η‖")
    if len(data.true_force[link].t):
        axes[0].plot(data.true_force[link].t, _norm(data.true_force[link]), "--", label="true")
    axes[0].axhline(WALTZ_FORCE, color="k", linestyle=":", label=f"desired {WALTZ_FORCE:g} N")
    axes[0].set_ylabel("[N]")
    axes[0].set_xlabel("time [s]")
    axes[0].legend(fontsize=7)
    files.append(_save(fig, out / "waltz_contact_force.png"))
    touched = data.in_contact[link].v[:, 0] > 0 if len(f) else np.zeros(0, bool)
    numbers["waltz"] = {
        "contact_share": float(touched.mean()) if len(touched) else 0.0,
        "mean_force_in_contact": float(f[touched].mean()) if touched.any() else 0.0,
        "median_force_in_contact": float(np.median(f[touched])) if touched.any() else 0.0,
        "torso_travel": numbers.get("torso_travel", 0.0),
        "base_travel": numbers.get("base_travel", 0.0),
    }
    return files
