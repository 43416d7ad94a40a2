"""A small fake of a UR controller's RTDE server (port 30004) for tests and dry runs (no rclpy).

It speaks the receive side of Universal Robots' RTDE protocol, version 2, as documented in UR's
"Real-Time Data Exchange (RTDE) guide", enough for ur_rtde's ``RTDEReceiveInterface``:

* every package is ``uint16 size`` (big-endian, header included) + ``uint8 type`` + payload;
* ``V`` (86) request protocol version (``uint16``) → ``V`` + ``uint8 accepted``;
* ``v`` (118) get URControl version → ``v`` + 4 × ``uint32`` (major, minor, bugfix, build);
* ``O`` (79) setup outputs: ``double frequency`` + comma-separated variable names →
  ``O`` + ``uint8 recipe id`` + comma-separated types (``NOT_FOUND`` for an unknown name);
* ``I`` (73) setup inputs → ``I`` + recipe id 0 + ``NOT_FOUND`` per name (inputs, i.e. any
  control, are not served: a control client fails here);
* ``S`` (83) start / ``P`` (80) pause → same type + ``uint8 accepted``; after start the server
  sends ``U`` (85) data packages, ``uint8 recipe id`` + the values big-endian, at the frequency
  the client asked for.

Served outputs: ``timestamp``, ``actual_q``, ``actual_qd``, ``target_q``, ``target_qd``,
``robot_mode``, ``safety_mode``, ``safety_status_bits``, ``runtime_state``, ``speed_scaling``,
``target_speed_fraction``, ``actual_current``, ``target_current``, ``target_moment``, set from a
:class:`FakeRobotState` a test can change while the server runs (``speed_scaling`` and
``target_speed_fraction``: the trajectory limiter's scaling and the teach pendant's speed
slider, which ur_rtde's ``getSpeedScalingCombined`` multiplies, as ur_robot_driver does; the
currents [A] and target moments [N·m]: what the bridge turns into joint efforts).

Safety of the fake itself: it binds 127.0.0.1 only, serves at most :data:`MAX_CLIENTS` clients
at once (one thread each: ur_rtde's receive and control interfaces each open their own RTDE
connection), every loop is bounded by ``lifetime`` [s] (the server stops by itself) and every
wait has a timeout.
"""

from __future__ import annotations

import contextlib
import select
import socket
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

RTDE_PORT = 30004
MAX_CLIENTS = 4
HEADER = struct.Struct(">HB")
V_PROTOCOL, V_URCONTROL, M_TEXT, U_DATA = 86, 118, 77, 85
O_SETUP_OUTPUTS, I_SETUP_INPUTS, S_START, P_PAUSE = 79, 73, 83, 80

SAFETY_BIT_PROTECTIVE_STOP = 2
SAFETY_BIT_EMERGENCY_STOP = 7
"""Bits of ``safety_status_bits`` (RTDE guide): 2 protective stopped, 7 emergency stopped."""


@dataclass
class FakeRobotState:
    """What the fake controller reports; change it while the server runs (under ``lock``)."""

    q: tuple[float, ...] = (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)
    qd: tuple[float, ...] = (0.0,) * 6
    robot_mode: int = 7  # RUNNING
    safety_mode: int = 1  # NORMAL
    protective_stopped: bool = False
    emergency_stopped: bool = False
    speed_scaling: float = 1.0  # the trajectory limiter's scaling, 0–1
    target_speed_fraction: float = 1.0  # the teach pendant's speed slider, 0–1
    runtime_state: int = 2  # PLAYING (RTDE guide: 0 stopping … 4 paused, 5 resuming)
    actual_current: tuple[float, ...] = (0.0,) * 6  # [A]
    target_current: tuple[float, ...] = (0.0,) * 6  # [A]
    target_moment: tuple[float, ...] = (0.0,) * 6  # [N·m]
    lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def safety_status_bits(self) -> int:
        bits = 1 if self.safety_mode == 1 else 0
        bits |= int(self.protective_stopped) << SAFETY_BIT_PROTECTIVE_STOP
        bits |= int(self.emergency_stopped) << SAFETY_BIT_EMERGENCY_STOP
        return bits


# name → (RTDE type, struct format, value getter)
_OUTPUTS: dict[str, tuple[str, str, Callable[[FakeRobotState, float], object]]] = {
    "timestamp": ("DOUBLE", "d", lambda s, t: t),
    "actual_q": ("VECTOR6D", "6d", lambda s, t: s.q),
    "actual_qd": ("VECTOR6D", "6d", lambda s, t: s.qd),
    "target_q": ("VECTOR6D", "6d", lambda s, t: s.q),
    "target_qd": ("VECTOR6D", "6d", lambda s, t: s.qd),
    "robot_mode": ("INT32", "i", lambda s, t: s.robot_mode),
    "safety_mode": ("INT32", "i", lambda s, t: s.safety_mode),
    "safety_status_bits": ("UINT32", "I", lambda s, t: s.safety_status_bits()),
    "runtime_state": ("UINT32", "I", lambda s, t: s.runtime_state),
    "speed_scaling": ("DOUBLE", "d", lambda s, t: s.speed_scaling),
    "target_speed_fraction": ("DOUBLE", "d", lambda s, t: s.target_speed_fraction),
    "actual_current": ("VECTOR6D", "6d", lambda s, t: s.actual_current),
    "target_current": ("VECTOR6D", "6d", lambda s, t: s.target_current),
    "target_moment": ("VECTOR6D", "6d", lambda s, t: s.target_moment),
}


def package(kind: int, payload: bytes = b"") -> bytes:
    """One RTDE package: size (header included), type, payload."""
    return HEADER.pack(HEADER.size + len(payload), kind) + payload


class FakeRtdeServer:
    """Serve RTDE receive on 127.0.0.1 (see module docstring) on a thread.

    Args:
        state: the reported robot state.
        port: TCP port (ur_rtde always connects to 30004).
        lifetime: the server stops by itself after this many seconds.

    Attributes:
        received: package types received, in order (tests check what a client asked for).
        data_sent: data packages sent.
    """

    def __init__(
        self, state: FakeRobotState | None = None, port: int = RTDE_PORT, lifetime: float = 60.0
    ) -> None:
        self.state = state or FakeRobotState()
        self.received: list[int] = []  # appended by session threads (list.append is atomic)
        self.data_sent = 0
        self._lifetime = lifetime
        self._stop = threading.Event()
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind(("127.0.0.1", port))
        except OSError:
            self._listener.close()
            raise
        self._listener.listen(MAX_CLIENTS)
        self._thread = threading.Thread(target=self._serve, name="fake_rtde", daemon=True)
        self._sessions: list[threading.Thread] = []

    def start(self) -> FakeRtdeServer:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)
        for session in self._sessions:
            session.join(timeout=1.0)
        self._listener.close()

    def __enter__(self) -> FakeRtdeServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _serve(self) -> None:
        deadline = time.monotonic() + self._lifetime
        while not self._stop.is_set() and time.monotonic() < deadline:
            ready, _, _ = select.select([self._listener], [], [], 0.05)
            self._sessions = [t for t in self._sessions if t.is_alive()]
            if not ready or len(self._sessions) >= MAX_CLIENTS:
                continue
            client, _ = self._listener.accept()
            thread = threading.Thread(
                target=self._session, args=(client, deadline), name="fake_rtde_client",
                daemon=True,
            )
            self._sessions.append(thread)
            thread.start()
        self._stop.set()  # lifetime over: sessions end too

    def _session(self, client: socket.socket, deadline: float) -> None:
        with contextlib.closing(client):
            _Session(self, client, deadline).run()

    def stopped(self) -> bool:
        return self._stop.is_set()


class _Session:
    """One client connection: handshake replies, then data packages at the asked rate."""

    def __init__(self, server: FakeRtdeServer, client: socket.socket, deadline: float) -> None:
        self.server, self.client, self.deadline = server, client, deadline
        self.buffer = b""
        self.names: list[str] = []
        self.period = 0.0  # 0 = not streaming
        self.requested_period = 0.002  # from the output setup; streaming starts with S
        self.next_send = 0.0
        self.t0 = time.monotonic()

    def run(self) -> None:
        client = self.client
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        while not self.server.stopped() and time.monotonic() < self.deadline:
            now = time.monotonic()
            wait = 0.05 if self.period == 0.0 else max(0.0, self.next_send - now)
            ready, _, _ = select.select([client], [], [], min(wait, 0.05))
            if ready:
                try:
                    chunk = client.recv(4096)
                except OSError:
                    return
                if not chunk:
                    return  # the client closed the connection
                self.buffer += chunk
                self._handle_packages()
            if self.period and time.monotonic() >= self.next_send:
                self.next_send += self.period
                if not self._send(self._data_package()):
                    return

    def _handle_packages(self) -> None:
        while len(self.buffer) >= HEADER.size:
            size, kind = HEADER.unpack_from(self.buffer)
            if size < HEADER.size or len(self.buffer) < size:
                return
            payload, self.buffer = self.buffer[HEADER.size : size], self.buffer[size:]
            self.server.received.append(kind)
            reply = self._reply(kind, payload)
            if reply is not None:
                self._send(reply)

    def _reply(self, kind: int, payload: bytes) -> bytes | None:
        if kind == V_PROTOCOL:
            return package(V_PROTOCOL, b"\x01")
        if kind == V_URCONTROL:
            return package(V_URCONTROL, struct.pack(">IIII", 5, 15, 0, 0))  # e-Series 5.15
        if kind == O_SETUP_OUTPUTS:
            (frequency,) = struct.unpack_from(">d", payload)
            self.names = [n for n in payload[8:].decode("ascii").split(",") if n]
            self.requested_period = 1.0 / frequency if frequency > 0 else 0.002
            types = [_OUTPUTS[n][0] if n in _OUTPUTS else "NOT_FOUND" for n in self.names]
            return package(O_SETUP_OUTPUTS, b"\x01" + ",".join(types).encode("ascii"))
        if kind == I_SETUP_INPUTS:
            names = [n for n in payload.decode("ascii").split(",") if n]
            not_found = ",".join(["NOT_FOUND"] * len(names)).encode("ascii")
            return package(I_SETUP_INPUTS, b"\x00" + not_found)
        if kind == S_START:
            self.period = self.requested_period
            self.next_send = time.monotonic()
            return package(S_START, b"\x01")
        if kind == P_PAUSE:
            self.period = 0.0
            return package(P_PAUSE, b"\x01")
        return None  # data packages (inputs) and anything else: ignored

    def _data_package(self) -> bytes:
        state = self.server.state
        now = time.monotonic() - self.t0
        parts = [b"\x01"]
        with state.lock:
            for name in self.names:
                entry = _OUTPUTS.get(name)
                if entry is None:
                    continue
                value = entry[2](state, now)
                values = value if isinstance(value, tuple) else (value,)
                parts.append(struct.pack(">" + entry[1], *values))
        return package(U_DATA, b"".join(parts))

    def _send(self, data: bytes) -> bool:
        try:
            self.client.sendall(data)
        except OSError:
            return False
        if data[2] == U_DATA:
            self.server.data_sent += 1
        return True


__all__ = ["RTDE_PORT", "FakeRobotState", "FakeRtdeServer", "package"]
