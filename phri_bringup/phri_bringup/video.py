"""MP4 video of a recorded run, rendered offscreen with MuJoCo (``MUJOCO_GL=egl``).

The video is rendered *from the recording* (joint states, odometry, the person's poses and the
estimated contacts), so any recording can be turned into a video afterwards, and a run is not
slowed by rendering. Each frame shows the simulation scene at that instant with the estimated
contact force of every touched skin link as a red arrow pointing along the push (length
``FORCE_SCALE`` per newton). Frames are encoded by the ffmpeg binary of ``imageio-ffmpeg``
(H.264, yuv420p: plays in browsers and every player).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from phri_bringup.graph import SKIN_LINKS
from phri_bringup.recording import find_recording, ros_type
from phri_common.planar import yaw_from_quaternion
from phri_description.description import BASE_JOINTS

FloatArray = NDArray[np.float64]

FORCE_SCALE = 0.02
"""Arrow length per newton of contact force [m/N]."""


class VideoUnavailable(RuntimeError):
    """Offscreen rendering or encoding is not possible here (the message says why)."""


@dataclass(frozen=True)
class VideoOptions:
    """Frame size [px], frame rate [1/s], playback speed (1 = real time)."""

    width: int = 1024
    height: int = 576
    fps: float = 25.0
    speed: float = 1.0


@dataclass
class _Track:
    """A recorded signal as sample times [s] and values; :meth:`at` = latest sample ≤ t."""

    t: FloatArray
    v: list[object]

    def at(self, t: float) -> object | None:
        i = int(np.searchsorted(self.t, t, side="right")) - 1
        return self.v[i] if i >= 0 else None


def _read_tracks(path: Path) -> dict[str, _Track]:
    from rclpy.serialization import deserialize_message
    from rosbags.highlevel import AnyReader

    from phri_common.contact import msg_to_contact

    rows: dict[str, list[tuple[float, object]]] = {}
    topics = {"/joint_states", "/odom", "/sim/person/poses",
              *(f"/contacts/{link}" for link in SKIN_LINKS)}
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic in topics]
        for conn, stamp, raw in reader.messages(connections=conns):
            msg = deserialize_message(raw, ros_type(conn.msgtype))
            value: object
            if conn.topic == "/joint_states":
                value = (list(msg.name), list(msg.position))
            elif conn.topic == "/odom":
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                value = (p.x, p.y, yaw_from_quaternion(q.w, q.x, q.y, q.z))
            elif conn.topic == "/sim/person/poses":
                value = [((p.position.x, p.position.y, p.position.z),
                          (p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z))
                         for p in msg.poses]
            else:
                value = msg_to_contact(msg)
            rows.setdefault(conn.topic, []).append((stamp * 1e-9, value))
    return {k: _Track(np.array([r[0] for r in v]), [r[1] for r in v]) for k, v in rows.items()}


def render_video(
    recording: str | Path,
    output: str | Path,
    options: VideoOptions | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Render ``recording`` into the MP4 file ``output``; return its path.

    Raises:
        VideoUnavailable: no offscreen OpenGL (set ``MUJOCO_GL=egl`` with Mesa's EGL, or
            ``osmesa``) or no ffmpeg; the message says which.
        FileNotFoundError: no recording.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco

    from phri_sim.person import PERSON_PARTS
    from phri_sim.scene import scene_spec

    opts = options or VideoOptions()
    tracks = _read_tracks(find_recording(recording))
    if "/joint_states" not in tracks:
        raise ValueError(f"{recording}: the recording has no /joint_states to render")
    model = scene_spec().compile()
    model.vis.global_.offwidth = max(opts.width, int(model.vis.global_.offwidth))
    model.vis.global_.offheight = max(opts.height, int(model.vis.global_.offheight))
    # Multisampled offscreen buffers make reading pixels ~20× slower in Mesa's software GL.
    model.vis.quality.offsamples = 0
    data = mujoco.MjData(model)
    try:
        renderer = mujoco.Renderer(model, opts.height, opts.width)
    except Exception as err:  # GL backends raise many types
        raise VideoUnavailable(
            f"offscreen rendering unavailable ({type(err).__name__}: {err}); set MUJOCO_GL=egl "
            "(Mesa EGL) or MUJOCO_GL=osmesa and try again"
        ) from err
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
    except Exception as err:
        renderer.close()
        raise VideoUnavailable(f"no ffmpeg for MP4 encoding: {err}") from err

    joint_adr = {model.joint(j).name: int(model.jnt_qposadr[j]) for j in range(model.njnt)}
    part_adr = [joint_adr[p.name + "_free"] for p in PERSON_PARTS]
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.distance, camera.azimuth, camera.elevation = 2.8, 120.0, -20.0
    model.vis.headlight.ambient[:] = 0.45
    model.vis.headlight.diffuse[:] = 0.6
    t_end = float(tracks["/joint_states"].t[-1])
    t0 = float(tracks["/joint_states"].t[0])
    n_frames = max(1, int((t_end - t0) * opts.fps / opts.speed))
    out = Path(output)
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = imageio_ffmpeg.write_frames(str(out), (opts.width, opts.height), fps=opts.fps,
                                         codec="libx264", macro_block_size=16,
                                         ffmpeg_log_level="error")
    writer.send(None)
    lookat = None
    try:
        for i in range(n_frames):
            t = t0 + i * opts.speed / opts.fps
            js = tracks["/joint_states"].at(t)
            if js is not None:
                names: list[str] = js[0]  # type: ignore[index]
                positions: list[float] = js[1]  # type: ignore[index]
                for name, value in zip(names, positions, strict=False):
                    if name in joint_adr:
                        data.qpos[joint_adr[name]] = value
            base = tracks["/odom"].at(t) if "/odom" in tracks else None
            if base is not None:
                for name, value in zip(BASE_JOINTS, base, strict=True):  # type: ignore[call-overload]
                    data.qpos[joint_adr[name]] = value
            poses = tracks["/sim/person/poses"].at(t) if "/sim/person/poses" in tracks else None
            if poses is not None:
                for adr, (pos, quat) in zip(part_adr, poses, strict=False):  # type: ignore[call-overload]
                    data.qpos[adr:adr + 3] = pos
                    data.qpos[adr + 3:adr + 7] = quat
            mujoco.mj_kinematics(model, data)
            # Look between the base and the arms' workspace in front of it (the partner).
            target = np.array([data.qpos[joint_adr[BASE_JOINTS[0]]] + 0.3,
                               data.qpos[joint_adr[BASE_JOINTS[1]]] + 0.1, 0.9])
            # Follow the base smoothly so the couple stays in view without jitter.
            lookat = target if lookat is None else lookat + 0.05 * (target - lookat)
            camera.lookat[:] = lookat
            renderer.update_scene(data, camera)
            for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                         mujoco.mjtRndFlag.mjRND_SKYBOX):
                renderer.scene.flags[flag] = False
            _add_force_arrows(mujoco, model, data, renderer.scene, tracks, t)
            writer.send(np.ascontiguousarray(renderer.render()))
            if progress is not None:
                progress(i + 1, n_frames)
    finally:
        writer.close()
        renderer.close()
    return out


def _add_force_arrows(mujoco: object, model: object, data: object, scene: object,
                      tracks: dict[str, _Track], t: float) -> None:
    """Red arrows for the estimated contact forces (push direction, ending at the centre)."""
    import mujoco as mj

    for link in SKIN_LINKS:
        track = tracks.get(f"/contacts/{link}")
        contact = track.at(t) if track is not None else None
        if contact is None or not getattr(contact, "in_contact", False):
            continue
        body = model.body(link).id  # type: ignore[attr-defined]
        rot = data.xmat[body].reshape(3, 3)  # type: ignore[attr-defined]
        centre = rot @ np.asarray(contact.center) + data.xpos[body]  # type: ignore[attr-defined]
        force = rot @ np.asarray(contact.force)  # type: ignore[attr-defined]
        if np.linalg.norm(force) < 1e-3 or scene.ngeom >= scene.maxgeom:  # type: ignore[attr-defined]
            continue
        geom = scene.geoms[scene.ngeom]  # type: ignore[attr-defined]
        mj.mjv_initGeom(geom, mj.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.zeros(9),
                        np.array([0.9, 0.1, 0.1, 1.0], dtype=np.float32))
        mj.mjv_connector(geom, mj.mjtGeom.mjGEOM_ARROW, 0.012,
                         centre - FORCE_SCALE * force, centre)
        scene.ngeom += 1  # type: ignore[attr-defined]
