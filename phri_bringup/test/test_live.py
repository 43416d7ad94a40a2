"""The Foxglove live view: the server starts on localhost only and advertises its channels."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from phri_bringup.graph.nodes import PATCHES

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "bringup.md"


def _documented_channels() -> set[str]:
    """Channel names of the Foxglove table in docs/bringup.md (``<patch>`` per skin patch)."""
    lines = GUIDE.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| channel | schema |"))
    names = set()
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        name = line.split("|")[1].strip().strip("`")
        names |= {name.replace("<patch>", p) for p in PATCHES} if "<patch>" in name else {name}
    return names


def _listening_addresses(port: int) -> set[str]:
    """Local addresses (hex, /proc/net/tcp) listening on ``port``."""
    out = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        path = Path(table)
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            parts = line.split()
            addr, hexport = parts[1].split(":")
            if int(hexport, 16) == port and parts[3] == "0A":
                out.add(addr)
    return out


@pytest.mark.parametrize("protocols", [
    ["foxglove.sdk.v1", "foxglove.websocket.v1"],  # current Foxglove
    ["foxglove.websocket.v1"],  # Lichtblick, Foxglove Studio before 2025 (the SDK alone: 400)
    ["foxglove.sdk.v1"],
])
def test_server_starts_on_localhost_and_advertises_channels(protocols: list[str]) -> None:
    websockets = pytest.importorskip("websockets.sync.client")
    from phri_bringup.observer.foxglove import FoxgloveSink

    sink = FoxgloveSink(port=0)
    try:
        assert sink.port > 0
        assert _listening_addresses(sink.port) == {"0100007F"}  # 127.0.0.1 only
        topics: set[str] = set()
        documented = _documented_channels()
        assert len(documented) == 4 + len(PATCHES)
        with websockets.connect(f"ws://127.0.0.1:{sink.port}", subprotocols=protocols,
                                open_timeout=60) as ws:
            assert ws.subprotocol in protocols
            channels: dict[str, int] = {}
            for _ in range(10):
                msg = ws.recv(timeout=60)
                if isinstance(msg, str):
                    doc = json.loads(msg)
                    if doc.get("op") == "advertise":
                        channels |= {c["topic"]: c["id"] for c in doc["channels"]}
                        topics |= {c["topic"] for c in doc["channels"]}
                if documented <= topics:
                    break
            # Subscribe to the robot scene and get a binary message-data frame (opcode 1,
            # then our subscription id) through the relay.
            ws.send(json.dumps({"op": "subscribe",
                                "subscriptions": [{"id": 7, "channelId": channels["/robot"]}]}))
            data, attempt = b"", 0
            deadline = time.monotonic() + 60.0  # bounds a stalled machine only
            while time.monotonic() < deadline:  # log until a frame comes back
                attempt += 1
                sink.robot.log(sink._robot_update, log_time=attempt)
                try:
                    frame = ws.recv(timeout=0.1)
                except TimeoutError:
                    continue
                if isinstance(frame, bytes):
                    data = frame
                    break
            assert data[:1] == b"\x01" and int.from_bytes(data[1:5], "little") == 7
        assert topics == documented
    finally:
        sink.close()


def test_arrow_orientation_turns_x_onto_the_direction() -> None:
    import numpy as np
    from scipy.spatial.transform import Rotation

    from phri_bringup.observer.foxglove import arrow_orientation

    rng = np.random.default_rng(3)
    for d in [*rng.normal(size=(20, 3)), np.array([-1.0, 0, 0]), np.array([2.0, 0, 0])]:
        w, x, y, z = arrow_orientation(d)
        rotated = Rotation.from_quat([x, y, z, w]).apply([1.0, 0.0, 0.0])
        assert np.allclose(rotated, d / np.linalg.norm(d), atol=1e-9)
