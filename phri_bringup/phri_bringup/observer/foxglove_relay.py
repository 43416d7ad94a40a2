"""WebSocket relay that lets clients of either Foxglove subprotocol reach the foxglove-sdk server.

foxglove-sdk (every release on PyPI, checked 0.14 to 0.30) accepts only the subprotocol
``foxglove.sdk.v1`` and answers HTTP 400 to clients that offer only ``foxglove.websocket.v1`` —
Lichtblick and Foxglove Studio builds from before 2025. Both names denote the same protocol (the
SDK renamed it; Lichtblick added the new name alongside the old one), so this relay accepts
either, opens one upstream connection per client with ``foxglove.sdk.v1`` and copies frames both
ways unchanged. The live view listens through it
(:class:`phri_bringup.observer.foxglove.FoxgloveSink`).
"""

from __future__ import annotations

import threading
from typing import Any

SUBPROTOCOLS: tuple[str, ...] = ("foxglove.sdk.v1", "foxglove.websocket.v1")
"""Accepted from clients, the SDK's own name first."""
UPSTREAM_SUBPROTOCOL = "foxglove.sdk.v1"


def _pump(source: Any, sink: Any) -> None:
    """Copy every frame (text or binary) from ``source`` to ``sink`` until either closes."""
    from websockets.exceptions import ConnectionClosed

    try:
        for frame in source:
            sink.send(frame)
    except ConnectionClosed:
        pass
    finally:
        sink.close()


class SubprotocolRelay:
    """Listens on ``host:port`` (0 = any free port) and relays each client to the server at
    ``ws://127.0.0.1:<upstream_port>``; :attr:`port` is the port it listens on."""

    def __init__(self, upstream_port: int, host: str = "127.0.0.1", port: int = 0) -> None:
        from websockets.sync.server import serve
        from websockets.typing import Subprotocol

        self.upstream = f"ws://127.0.0.1:{int(upstream_port)}"
        accepted = [Subprotocol(p) for p in SUBPROTOCOLS]
        self.server = serve(self._handle, host, port, subprotocols=accepted, max_size=None,
                            compression=None)
        self.port = int(self.server.socket.getsockname()[1])
        self.thread = threading.Thread(target=self.server.serve_forever, name="foxglove-relay",
                                       daemon=True)
        self.thread.start()

    def _handle(self, client: Any) -> None:
        from websockets.sync.client import connect
        from websockets.typing import Subprotocol

        with connect(self.upstream, subprotocols=[Subprotocol(UPSTREAM_SUBPROTOCOL)],
                     max_size=None, compression=None, open_timeout=5) as upstream:
            down = threading.Thread(target=_pump, args=(upstream, client), daemon=True)
            down.start()
            _pump(client, upstream)
            down.join(timeout=5)

    def close(self) -> None:
        """Stop listening and wait for the server thread (open connections are closed)."""
        self.server.shutdown()
        self.thread.join(timeout=5)
