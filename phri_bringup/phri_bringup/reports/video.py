"""MP4 video of a recorded run, rendered offscreen with MuJoCo (``MUJOCO_GL=egl``).

The video is rendered *from the recording* (joint states, odometry, the person's poses, the
estimated contacts and the waist link's task state), so any recording can be turned into a video
afterwards, and a run is not slowed by rendering. Each frame shows the simulation scene at that
instant (the checkered floor of :mod:`phri_sim.world.scene` shows motion and turns) and adds, as
visual geoms in the rendered scene only (no physics):

* a **human figure** around the recorded person poses (:mod:`phri_bringup.reports.video_figure`):
  head, neck, shoulders, arms reaching the recorded hands, hips and legs that step;
* the **estimated contact force** of every touched skin link as a red arrow whose tail is at the
  estimated contact centre on the skin and which points along the push (length
  :data:`FORCE_SCALE` per newton), so it shows through and beyond the link;
* an **overlay** (:mod:`phri_bringup.reports.video_overlay`): sim time, the waist link's force and
  priority ψ, the accumulated turn of robot and partner.

The camera (:mod:`phri_bringup.reports.video_camera`) frames the couple and turns with it, smoothed.
Frames are encoded by the ffmpeg binary of ``imageio-ffmpeg`` (H.264, yuv420p: plays in
browsers and every player).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from phri_bringup.graph.nodes import CONTROLLER, SKIN_LINKS
from phri_bringup.observer.bag import find_recording, ros_type
from phri_bringup.reports.video_camera import CameraRig, SmoothCamera, couple_view
from phri_bringup.reports.video_figure import DIMS, Feet, Skeleton, bones, skeleton
from phri_bringup.reports.video_overlay import draw_overlay, overlay_lines
from phri_common.planar import yaw_from_quaternion
from phri_description.description import BASE_JOINTS

FloatArray = NDArray[np.float64]

FORCE_SCALE = 0.035
"""Arrow length per newton of contact force [m/N]."""
WAIST_LINK = "left_forearm_link"
"""The link whose force and ψ the overlay shows (the waltz's waist hold, VI-B)."""
FIGURE_RGBA = (0.85, 0.65, 0.55, 1.0)
"""Colour of the figure's skin (the person's geoms' default colour)."""
CLOTHES_RGBA = (0.25, 0.25, 0.35, 1.0)
"""Colour of the figure's legs and shoes."""
CHANGE_THRESHOLD = 12
"""A pixel "changes" when a colour channel differs by more than this (of 255) — above the
H.264 coding noise (:func:`changing_pixel_share`)."""
STATE_TOPIC = f"/{CONTROLLER}/state/{WAIST_LINK}"
MACRO_BLOCK = 8
"""Frame sides must be multiples of this for the encoder (360 = 45 × 8; with imageio's 16 the
ffmpeg process rescaled every 640 × 360 frame to 640 × 368)."""
FLOOR_GRID_SPACING = 0.5
"""Tessellation of the rendered floor plane [m] (MuJoCo's third plane size; visual only)."""


class VideoUnavailable(RuntimeError):
    """Offscreen rendering or encoding is not possible here (the message says why)."""


@dataclass(frozen=True)
class VideoOptions:
    """Frame size [px], frame rate [1/s], playback speed (1 = real time), camera rig, overlay.

    The defaults, 640 × 360 at 15 frames per second, show the couple, the steps, the force
    arrow and the overlay clearly at a third of the cost of 1024 × 576 at 25 (the renderer is
    Mesa's software rasteriser on a machine without a GPU; docs/benchmarks.md, "Main
    command"); ``phri video --size 1024x576 --fps 25`` renders the larger one."""

    width: int = 640
    height: int = 360
    fps: float = 15.0
    speed: float = 1.0
    camera: CameraRig = field(default_factory=CameraRig)
    overlay: bool = True


@dataclass
class Track:
    """A recorded signal as sample times [s] and values; :meth:`at` = latest sample ≤ t."""

    t: FloatArray
    v: list[Any]

    def at(self, t: float) -> Any:
        i = int(np.searchsorted(self.t, t, side="right")) - 1
        return self.v[i] if i >= 0 else None


class TrackLike(Protocol):
    """What a frame reads of a signal: its sample times [s] (``t[0]``, ``t[-1]``) and the latest
    sample at a time (:class:`Track`; a growing one in :mod:`phri_bringup.reports.video_live`)."""

    @property
    def t(self) -> FloatArray | Sequence[float]: ...

    def at(self, t: float) -> Any: ...


Tracks = Mapping[str, TrackLike]
"""Recorded signals by topic: ``/joint_states`` (names, positions), ``/odom`` (x, y, yaw),
``/sim/person/poses`` (list of ((x, y, z), (w, x, y, z))), ``/contacts/<link>``
(:class:`~phri_common.contact.ContactState`), :data:`STATE_TOPIC` (ψ)."""


def _decode(topic: str, msg: Any) -> Any:
    from phri_common.contact import msg_to_contact

    if topic == "/joint_states":
        return (list(msg.name), list(msg.position))
    if topic == "/odom":
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        return (p.x, p.y, yaw_from_quaternion(q.w, q.x, q.y, q.z))
    if topic == "/sim/person/poses":
        return [((p.position.x, p.position.y, p.position.z),
                 (p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z))
                for p in msg.poses]
    if topic == STATE_TOPIC:
        from wholebody_controller.messages import msg_to_task_state

        return msg_to_task_state(msg)["psi"]
    return msg_to_contact(msg)


def _decode_cdr(topic: str, raw: bytes) -> Any:
    """:func:`_decode` straight from the serialized bytes of phri's own layouts (no rclpy
    message objects: a contact or task state's PointCloud2 carries 17 or 40 ``PointField`` s);
    None for anything else, which :func:`read_tracks` deserializes and decodes."""
    from phri_common.cdr import joint_state_from_cdr, odometry_pose_from_cdr, pose_array_from_cdr
    from phri_common.contact_cdr import contact_from_cdr

    if topic == "/joint_states":
        js = joint_state_from_cdr(raw)
        return None if js is None else (list(js[0]), list(js[1]))
    if topic == "/odom":
        pose = odometry_pose_from_cdr(raw)
        if pose is None:
            return None
        x, y, _z, qx, qy, qz, qw = pose
        return (x, y, yaw_from_quaternion(qw, qx, qy, qz))
    if topic == "/sim/person/poses":
        poses = pose_array_from_cdr(raw)
        return None if poses is None else [(p[:3], (p[6], p[3], p[4], p[5])) for p in poses]
    if topic == STATE_TOPIC:
        from wholebody_controller.messages import task_state_from_cdr

        state = task_state_from_cdr(raw)
        return None if state is None else state["psi"]
    if topic.startswith("/contacts/"):
        return contact_from_cdr(raw)
    return None


VIDEO_TOPICS = frozenset({"/joint_states", "/odom", "/sim/person/poses", STATE_TOPIC,
                          *(f"/contacts/{link}" for link in SKIN_LINKS)})
"""The recorded topics a video shows (:data:`Tracks`)."""


def decode_record(topic: str, type_name: str, raw: bytes) -> Any:
    """The value a :class:`Track` of ``topic`` holds, from a message's CDR bytes (``type_name``
    ``pkg/msg/Type``): phri's own layouts straight from the bytes, anything else through its
    rclpy message class."""
    from rclpy.serialization import deserialize_message

    value = _decode_cdr(topic, raw)
    if value is None:
        value = _decode(topic, deserialize_message(raw, ros_type(type_name)))
    return value


def read_tracks(path: Path) -> Tracks:
    """The signals a video needs, from the recording at ``path`` (:data:`Tracks`)."""
    from rosbags.highlevel import AnyReader

    rows: dict[str, list[tuple[float, object]]] = {}
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic in VIDEO_TOPICS]
        for conn, stamp, raw in reader.messages(connections=conns):
            rows.setdefault(conn.topic, []).append(
                (stamp * 1e-9, decode_record(conn.topic, conn.msgtype, raw)))
    return {k: Track(np.array([r[0] for r in v]), [r[1] for r in v]) for k, v in rows.items()}


def render_video(
    recording: str | Path,
    output: str | Path,
    options: VideoOptions | None = None,
    progress: Callable[[int, int], None] | None = None,
    workers: int = 1,
) -> Path:
    """Render ``recording`` into the MP4 file ``output``; return its path. With ``workers`` > 1
    the frames are split into that many consecutive chunks, each rendered and encoded by its own
    process (its own MuJoCo renderer) and the chunks joined without re-encoding: the same frames
    (:meth:`FrameRenderer.frames`), in a fraction of the time on a multi-core machine.
    ``progress(done, total)`` counts frames (with workers: once per finished chunk).

    Raises:
        VideoUnavailable: no offscreen OpenGL (set ``MUJOCO_GL=egl`` with Mesa's EGL, or
            ``osmesa``) or no ffmpeg; the message says which.
        FileNotFoundError: no recording.
    """
    opts = options or VideoOptions()
    tracks = read_tracks(find_recording(recording))
    if "/joint_states" not in tracks:
        raise ValueError(f"{recording}: the recording has no /joint_states to render")
    out = Path(output)
    out.parent.mkdir(parents=True, exist_ok=True)
    n = frame_count(tracks, opts)
    chunks = chunk_ranges(n, workers)
    if len(chunks) == 1:
        _render_chunk(tracks, opts, out, 0, n, progress)
    else:
        _render_parallel(tracks, opts, out, chunks, progress)
    return out


def frame_count(tracks: Tracks, opts: VideoOptions) -> int:
    """Frames of the video of ``tracks``: the recording's span at ``opts.fps`` / ``speed``."""
    js = tracks["/joint_states"].t
    return max(1, int((float(js[-1]) - float(js[0])) * opts.fps / opts.speed))


def frame_time(t0: float, i: int, opts: VideoOptions) -> float:
    """Recording time [s] of frame ``i`` of a video whose first frame is at ``t0`` [s]."""
    return t0 + i * opts.speed / opts.fps


def chunk_ranges(n_frames: int, workers: int) -> list[tuple[int, int]]:
    """``n_frames`` split into at most ``workers`` consecutive (first, stop) ranges of nearly
    equal length, none shorter than a second of video at 25 fps."""
    count = max(1, min(int(workers), n_frames // 25))
    bounds = [round(k * n_frames / count) for k in range(count + 1)]
    return [(bounds[k], bounds[k + 1]) for k in range(count)]


def _render_chunk(tracks: Tracks, opts: VideoOptions, out: Path, first: int, stop: int,
                  progress: Callable[[int, int], None] | None = None) -> Path:
    """Frames ``first`` … ``stop - 1`` of the video of ``tracks`` encoded into ``out``."""
    frames = FrameRenderer(tracks, opts)
    writer = open_writer(out, opts)
    try:
        for i, frame in enumerate(frames.frames(first, stop)):
            writer.send(frame)
            if progress is not None:
                progress(i + 1, stop - first)
    finally:
        writer.close()
        frames.close()
    return out


def open_writer(out: Path, opts: VideoOptions) -> Any:
    """An H.264 encoder (the ffmpeg process of ``imageio-ffmpeg``) writing ``out``, primed:
    ``send`` it RGB frames of ``opts``' size, then ``close`` it.

    Raises:
        VideoUnavailable: no ffmpeg here.
    """
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
    except Exception as err:
        raise VideoUnavailable(f"no ffmpeg for MP4 encoding: {err}") from err
    writer = imageio_ffmpeg.write_frames(str(out), (opts.width, opts.height), fps=opts.fps,
                                         codec="libx264", macro_block_size=MACRO_BLOCK,
                                         ffmpeg_log_level="error",
                                         output_params=["-preset", "veryfast"])
    writer.send(None)
    return writer


def _render_parallel(tracks: Tracks, opts: VideoOptions, out: Path,
                     chunks: list[tuple[int, int]],
                     progress: Callable[[int, int], None] | None) -> None:
    """The chunks rendered by one process each (spawned: a fresh GL context per process), then
    joined in order with ffmpeg's concat demuxer (stream copy)."""
    import multiprocessing
    import subprocess
    import tempfile
    from concurrent.futures import ProcessPoolExecutor

    import imageio_ffmpeg

    with tempfile.TemporaryDirectory(prefix=f".{out.stem}-", dir=out.parent) as tmp:
        parts = [Path(tmp) / f"part{k:03d}.mp4" for k in range(len(chunks))]
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(len(chunks), mp_context=ctx) as pool:
            futures = [pool.submit(_render_chunk, tracks, opts, part, a, b)
                       for part, (a, b) in zip(parts, chunks, strict=True)]
            for (_a, b), future in zip(chunks, futures, strict=True):
                future.result()
                if progress is not None:
                    progress(b, chunks[-1][1])
        listing = Path(tmp) / "parts.txt"
        listing.write_text("".join(f"file '{part.name}'\n" for part in parts), encoding="utf-8")
        subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f",
                        "concat", "-safe", "0", "-i", str(listing), "-c", "copy",
                        "-movflags", "+faststart", str(out)], check=True)


class FrameRenderer:
    """Frames of a video of ``tracks`` (iterate it), rendered offscreen (module docstring)."""

    def __init__(self, tracks: Tracks, opts: VideoOptions) -> None:
        os.environ.setdefault("MUJOCO_GL", "egl")  # effective if MuJoCo is not imported yet
        import mujoco

        from phri_sim.world.person_body import PERSON_PARTS
        from phri_sim.world.scene import scene_spec

        self.tracks, self.opts = tracks, opts
        model = scene_spec().compile()
        model.vis.global_.offwidth = max(opts.width, int(model.vis.global_.offwidth))
        model.vis.global_.offheight = max(opts.height, int(model.vis.global_.offheight))
        # Multisampled offscreen buffers make reading pixels ~20× slower in Mesa's software GL.
        model.vis.quality.offsamples = 0
        # Capsules and spheres of 12 × 8 facets instead of 28 × 16 (MuJoCo's default): the
        # same picture at video size, a third less rendering in software GL.
        model.vis.quality.numslices, model.vis.quality.numstacks = 12, 8
        # The floor plane is tessellated at its grid spacing (5 cm: ~10⁴ quads in view); its
        # checker is a texture, so a coarse grid draws the same floor in a fraction of the time.
        model.geom_size[model.geom("floor").id, 2] = FLOOR_GRID_SPACING
        model.vis.headlight.ambient[:] = 0.45
        model.vis.headlight.diffuse[:] = 0.55
        self.model, self.data = model, mujoco.MjData(model)
        try:
            self.renderer = mujoco.Renderer(model, opts.height, opts.width)
        except Exception as err:  # GL backends raise many types
            raise VideoUnavailable(
                f"offscreen rendering unavailable ({type(err).__name__}: {err}); set "
                "MUJOCO_GL=egl (Mesa EGL) or MUJOCO_GL=osmesa and try again") from err
        self.joint_adr = {model.joint(j).name: int(model.jnt_qposadr[j])
                          for j in range(model.njnt)}
        names = [p.name for p in PERSON_PARTS]
        self.part_adr = [self.joint_adr[n + "_free"] for n in names]
        self.hand_index = [names.index(n) if n in names else None
                           for n in ("person_left_hand", "person_right_hand")]
        self.hand_geoms = [[g for g in range(model.ngeom) if model.geom_bodyid[g]
                            == model.body(names[i]).id] if i is not None else []
                           for i in self.hand_index]
        self.hand_rgba = model.geom_rgba.copy()
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.smooth = SmoothCamera(opts.camera.tau)
        self.feet = Feet()
        self.facing_offset: float | None = None
        self.turns = _Unwrapper(), _Unwrapper()
        self.t0 = float(tracks["/joint_states"].t[0])

    def close(self) -> None:
        """Release the GL context."""
        self.renderer.close()

    def __iter__(self) -> Iterator[NDArray[np.uint8]]:
        return self.frames(0, frame_count(self.tracks, self.opts))

    def time_of(self, i: int) -> float:
        """Recording time [s] of frame ``i``."""
        return frame_time(self.t0, i, self.opts)

    def frames(self, first: int, stop: int) -> Iterator[NDArray[np.uint8]]:
        """Frames ``first`` … ``stop - 1``; the frames before ``first`` are stepped through
        (:meth:`advance`) without rendering, but for the last one, rendered and dropped (the
        renderer's first frame differs from later ones by a few pixels), so the frames are
        those of the whole video, pixel for pixel."""
        for i in range(first - 1):
            self.advance(self.time_of(i))
        if first > 0:
            self.frame(self.time_of(first - 1))
        for i in range(first, stop):
            yield self.frame(self.time_of(i))

    def frame(self, t: float) -> NDArray[np.uint8]:
        """The frame at recording time ``t`` [s] (call with increasing ``t``)."""
        import mujoco

        poses, figure, lines = self.advance(t)
        self.renderer.update_scene(self.data, self.camera)
        scene = self.renderer.scene
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                     mujoco.mjtRndFlag.mjRND_SKYBOX):
            scene.flags[flag] = False
        if figure is not None:
            _add_figure_geoms(scene, figure[0], float(poses[0][0][2]))
        _add_force_arrows(self.model, self.data, scene, self.tracks, t)
        image = np.ascontiguousarray(self.renderer.render())
        if not self.opts.overlay:
            return image
        return draw_overlay(image, lines)

    def advance(self, t: float) -> tuple[Any, tuple[Skeleton, float] | None, list[str]]:
        """Everything of the frame at ``t`` but the pixels: the scene's state, the smoothed
        camera, the figure's steps, the overlay's accumulated turns (the state a frame carries
        to the next); returns (person poses, figure and facing, overlay lines). A chunk of the
        video rendered on its own replays this for every earlier frame
        (:func:`render_video` with ``workers``)."""
        import mujoco

        base, poses = self._set_state(t)
        mujoco.mj_kinematics(self.model, self.data)
        partner = None if not poses else np.array(poses[0][0])
        robot_xy = np.array(base[:2]) if base is not None else np.zeros(2)
        view = self.smooth.update(couple_view(robot_xy, None if partner is None else partner[:2],
                                              base[2] if base is not None else 0.0,
                                              self.opts.camera), self.opts.speed / self.opts.fps)
        self.camera.lookat[:] = view.lookat
        self.camera.azimuth, self.camera.elevation = view.azimuth, view.elevation
        self.camera.distance = view.distance
        figure = self._figure(t, poses, robot_xy) if poses else None
        lines = self._overlay(t, base, None if figure is None else figure[1])
        return poses, figure, lines

    def _set_state(self, t: float) -> tuple[Any, Any]:
        """Joint, base and person poses at ``t`` into ``data``; return (odom, poses)."""
        qpos, adr = self.data.qpos, self.joint_adr
        js = self.tracks["/joint_states"].at(t)
        if js is not None:
            for name, value in zip(js[0], js[1], strict=False):
                if name in adr:
                    qpos[adr[name]] = value
        base = self.tracks["/odom"].at(t) if "/odom" in self.tracks else None
        if base is not None:
            for name, value in zip(BASE_JOINTS, base, strict=True):
                qpos[adr[name]] = value
        track = self.tracks.get("/sim/person/poses")
        poses = track.at(t) if track is not None else None
        for a, (pos, quat) in zip(self.part_adr, poses or [], strict=False):
            qpos[a:a + 3] = pos
            qpos[a + 3:a + 7] = quat
        return base, poses

    def _figure(self, t: float, poses: list[Any], robot_xy: FloatArray) -> tuple[Skeleton, float]:
        """The human figure at ``t`` and the partner's facing [rad]; parked hands hidden."""
        torso = np.array(poses[0][0])
        yaw = yaw_from_quaternion(*poses[0][1])
        if self.facing_offset is None:  # at the start of the hold the partner faces the robot
            to_robot = robot_xy - torso[:2]
            facing = math.atan2(to_robot[1], to_robot[0]) if np.linalg.norm(to_robot) > 0.05 \
                else yaw
            self.facing_offset = facing - yaw
        facing = yaw + self.facing_offset
        hands: list[FloatArray | None] = [None if i is None or i >= len(poses)
                                          else np.array(poses[i][0]) for i in self.hand_index]
        feet = self.feet.update(t, torso[:2], facing)
        sk = skeleton(torso, facing, (hands[0], hands[1]), feet)
        self._hide_unused_hands(sk.joints, hands)
        return sk, facing

    def _hide_unused_hands(self, joints: dict[str, FloatArray],
                           hands: list[FloatArray | None]) -> None:
        """Parked hand geoms (far from the figure's wrist) are made invisible in this frame."""
        for side, geoms, hand in zip(("left", "right"), self.hand_geoms, hands, strict=True):
            used = hand is not None and np.linalg.norm(joints[f"{side}_wrist"] - hand) < 0.05
            for g in geoms:
                self.model.geom_rgba[g, 3] = self.hand_rgba[g, 3] if used else 0.0

    def _overlay(self, t: float, base: Any, partner_yaw: float | None) -> list[str]:
        track = self.tracks.get(f"/contacts/{WAIST_LINK}")
        contact = track.at(t) if track is not None else None
        force = None
        if contact is not None:
            force = float(np.linalg.norm(contact.force)) if contact.in_contact else 0.0
        psi_track = self.tracks.get(STATE_TOPIC)
        psi = psi_track.at(t) if psi_track is not None else None
        robot_turn = None if base is None else self.turns[0].update(base[2])
        partner_turn = None if partner_yaw is None else self.turns[1].update(partner_yaw)
        return overlay_lines(t - self.t0, force, psi, robot_turn, partner_turn, WAIST_LINK)


def _add_figure_geoms(scene: Any, sk: Skeleton, waist_z: float) -> None:
    """Capsules and spheres of the figure: skin colour, legs and feet in clothes colour."""
    skin = np.array(FIGURE_RGBA, dtype=np.float32)
    cloth = np.array(CLOTHES_RGBA, dtype=np.float32)
    for a, b, r in bones(sk):
        leg = a[2] < waist_z - 0.05 and b[2] < waist_z - 0.05
        _add_geom(scene, "capsule", a, b, r, cloth if leg else skin)
    j = sk.joints
    _add_geom(scene, "sphere", j["head"], j["head"], DIMS.head_radius, skin)
    _add_geom(scene, "sphere", j["nose"], j["nose"], 0.03, skin)
    _add_geom(scene, "sphere", j["hair"], j["hair"], 0.95 * DIMS.head_radius, cloth)
    for side in ("left", "right"):
        _add_geom(scene, "sphere", j[f"{side}_wrist"], j[f"{side}_wrist"], 0.042, skin)


class _Unwrapper:
    """Accumulated turn [deg] since the first sample of a heading signal [rad]."""

    def __init__(self) -> None:
        self.first: float | None = None
        self.last = 0.0
        self.total = 0.0

    def update(self, yaw: float) -> float:
        if self.first is None:
            self.first = self.last = yaw
        step = (yaw - self.last + math.pi) % (2.0 * math.pi) - math.pi
        self.total += step
        self.last = yaw
        return math.degrees(self.total)


def _add_geom(scene: Any, kind: str, a: FloatArray, b: FloatArray, radius: float,
              rgba: NDArray[np.float32]) -> None:
    """Append a capsule a → b, a sphere at a, or an arrow a → b of ``radius`` [m] to the
    rendered scene (skipped when the scene is full)."""
    import mujoco

    if scene.ngeom >= scene.maxgeom:
        return
    types = {"capsule": mujoco.mjtGeom.mjGEOM_CAPSULE, "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
             "arrow": mujoco.mjtGeom.mjGEOM_ARROW}
    geom = scene.geoms[scene.ngeom]
    mujoco.mjv_initGeom(geom, types[kind], np.full(3, radius), np.asarray(a, dtype=float),
                        np.eye(3).ravel(), rgba)
    if kind != "sphere":
        mujoco.mjv_connector(geom, types[kind], radius, np.asarray(a, dtype=float),
                             np.asarray(b, dtype=float))
    scene.ngeom += 1


def _add_force_arrows(model: Any, data: Any, scene: Any, tracks: Tracks, t: float) -> None:
    """Red arrows for the estimated contact forces: tail at the estimated contact centre on the
    skin, pointing along the push; a dot marks the centre."""
    red = np.array([0.9, 0.1, 0.1, 1.0], dtype=np.float32)
    for link in SKIN_LINKS:
        track = tracks.get(f"/contacts/{link}")
        contact = track.at(t) if track is not None else None
        if contact is None or not getattr(contact, "in_contact", False):
            continue
        body = model.body(link).id
        rot = data.xmat[body].reshape(3, 3)
        centre = rot @ np.asarray(contact.center) + data.xpos[body]
        force = rot @ np.asarray(contact.force)
        if np.linalg.norm(force) < 1e-3:
            continue
        _add_geom(scene, "arrow", centre, centre + FORCE_SCALE * force, 0.02, red)
        _add_geom(scene, "sphere", centre, centre, 0.022, red)


def changing_pixel_share(frames: Iterable[NDArray[np.uint8]], fps: float,
                         threshold: int = CHANGE_THRESHOLD) -> float:
    """Mean share of pixels [0–1] that change within one second: every frame is compared with
    the frame ``fps`` frames (1 s) later; a pixel changes when any channel differs by more than
    ``threshold``. 0 for a video shorter than a second."""
    lag = max(1, round(fps))
    window: list[NDArray[np.uint8]] = []
    shares: list[float] = []
    for frame in frames:
        window.append(frame)
        if len(window) > lag:
            old = window.pop(0)
            diff = np.abs(frame.astype(np.int16) - old.astype(np.int16)).max(axis=-1)
            shares.append(float(np.mean(diff > threshold)))
    return float(np.mean(shares)) if shares else 0.0


def video_frames(path: str | Path) -> tuple[Iterator[NDArray[np.uint8]], float]:
    """(decoded RGB frames, frame rate [1/s]) of an MP4 file (ffmpeg of imageio-ffmpeg)."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    w, h = meta["size"]

    def frames() -> Iterator[NDArray[np.uint8]]:
        for raw in reader:
            yield np.frombuffer(raw, dtype=np.uint8).reshape(h, w, 3)

    return frames(), float(meta["fps"])
