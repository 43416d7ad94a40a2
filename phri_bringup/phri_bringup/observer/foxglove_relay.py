"""WebSocket relay that lets clients of either Foxglove subprotocol reach the foxglove-sdk server.

foxglove-sdk (every release on PyPI, checked 0.14 to 0.30) accepts only the subprotocol
``foxglove.sdk.v1`` and answers HTTP 400 to clients that offer only ``foxglove.websocket.v1`` —
Lichtblick and Foxglove Studio builds from before 2025. Both names denote the same protocol (the
SDK renamed it; Lichtblick added the new name alongside the old one), so this relay accepts
either, opens one upstream connection per client with ``foxglove.sdk.v1`` and copies messages
both ways unchanged. The live view listens through it
(:class:`phri_bringup.observer.foxglove.FoxgloveSink`).

Bounds (defaults, environment variables, and what happens beyond them: docs/bringup.md,
"Live view"):

* ``max_message_bytes``: a message above it, from the client or from the server, ends that
  client's session with close code 1009 (message too big) before it is buffered (websockets
  refuses a frame by its header); the relay and the other clients go on. Counted in
  :attr:`RelayStats.oversize_closes`.
* ``max_clients``: concurrent sessions. The next client gets an HTTP 503 answer to its opening
  handshake (:attr:`RelayStats.refused`). TCP connections beyond ``max_clients`` +
  :data:`MAX_HANDSHAKES` (sessions plus handshakes in progress) get the same answer at once,
  before their request is read, and are closed (:attr:`RelayStats.aborted`); a handshake not
  done within :data:`OPEN_TIMEOUT_S` is dropped.
* threads: one, whatever the number of clients. The relay is one asyncio event loop
  (websockets' asyncio API); each client costs two tasks and two sockets, no thread.
* memory: each direction of a session queues at most :data:`MAX_QUEUE` messages before it stops
  reading (TCP back-pressure), so a session holds at most about
  2 × (:data:`MAX_QUEUE` + 1) × ``max_message_bytes``.
"""

from __future__ import annotations

import asyncio
import os
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from http import HTTPStatus
from typing import Any

SUBPROTOCOLS: tuple[str, ...] = ("foxglove.sdk.v1", "foxglove.websocket.v1")
"""Accepted from clients, the SDK's own name first."""
UPSTREAM_SUBPROTOCOL = "foxglove.sdk.v1"

DEFAULT_MAX_CLIENTS = 8
"""Concurrent clients (sessions) by default."""
MAX_CLIENTS_RANGE = (1, 1024)
DEFAULT_MAX_MESSAGE_BYTES = 1 << 20
"""Largest message by default [bytes]: the live view's largest are the channel advertisement
(≈ 30 KB) and a skin cloud (28 B per taxel: 56 KB for 2,000 taxels, 460 KB for 16,384)."""
MAX_MESSAGE_BYTES_RANGE = (1 << 16, 1 << 30)
"""Allowed ``max_message_bytes`` [bytes]: below 64 KiB the channel advertisement itself would
end every session."""
MAX_QUEUE = 4
"""Messages a session's direction queues before it stops reading its socket."""
MAX_HANDSHAKES = 64
"""TCP connections in their opening handshake allowed beside the sessions."""
OPEN_TIMEOUT_S = 5.0
"""A client that has not completed its opening handshake by then is dropped [s]."""
ENV_MAX_CLIENTS = "PHRI_FOXGLOVE_MAX_CLIENTS"
ENV_MAX_MESSAGE_BYTES = "PHRI_FOXGLOVE_MAX_MESSAGE_BYTES"
MESSAGE_TOO_BIG = 1009
"""WebSocket close code of a session ended for a message above ``max_message_bytes``."""


@dataclass
class RelayStats:
    """Counters since the relay started (written by its event loop only).

    Attributes:
        sessions: clients admitted.
        active: sessions open now.
        refused: clients answered HTTP 503 (``max_clients`` sessions open).
        aborted: TCP connections answered 503 and closed at once, their request unread (too
            many handshakes in progress).
        oversize_closes: sessions ended for a message above ``max_message_bytes``.
    """

    sessions: int = 0
    active: int = 0
    refused: int = 0
    aborted: int = 0
    oversize_closes: int = 0


def _bounded_int(value: object, name: str, bounds: tuple[int, int]) -> int:
    """``value`` (an int, or a string of one) within ``bounds``; ValueError naming ``name``
    and the range."""
    low, high = bounds
    number: int | None = None
    if isinstance(value, int) and not isinstance(value, bool):
        number = value
    elif isinstance(value, str):
        try:
            number = int(value.strip(), 0)
        except ValueError:
            number = None
    if number is None or not low <= number <= high:
        raise ValueError(f"{name} refused value {value!r}: allowed an integer in "
                         f"[{low}, {high}]")
    return number


def relay_limits(max_clients: int | None = None, max_message_bytes: int | None = None,
                 env: Mapping[str, str] | None = None) -> tuple[int, int]:
    """(max_clients, max_message_bytes [bytes]): the arguments, else the environment variables
    :data:`ENV_MAX_CLIENTS` and :data:`ENV_MAX_MESSAGE_BYTES`, else the defaults.

    Raises:
        ValueError: a value outside its range, naming the argument or variable and the range.
    """
    env = os.environ if env is None else env
    clients: object = max_clients
    clients_name = "max_clients"
    if clients is None:
        clients = env.get(ENV_MAX_CLIENTS, DEFAULT_MAX_CLIENTS)
        clients_name = ENV_MAX_CLIENTS
    size: object = max_message_bytes
    size_name = "max_message_bytes"
    if size is None:
        size = env.get(ENV_MAX_MESSAGE_BYTES, DEFAULT_MAX_MESSAGE_BYTES)
        size_name = ENV_MAX_MESSAGE_BYTES
    return (_bounded_int(clients, clients_name, MAX_CLIENTS_RANGE),
            _bounded_int(size, size_name, MAX_MESSAGE_BYTES_RANGE))


_BUSY_TEXT = b"phri relay: too many connections (max_clients); try again later\n"
_BUSY = (b"HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain\r\nContent-Length: "
         + str(len(_BUSY_TEXT)).encode() + b"\r\nConnection: close\r\n\r\n" + _BUSY_TEXT)
"""The answer to a connection beyond the handshakes allowed: sent at once, then closed."""


def _too_big(connection: Any) -> bool:
    """Did the relay close ``connection`` for a message above its size limit?"""
    sent = getattr(connection.protocol, "close_sent", None)
    return sent is not None and sent.code == MESSAGE_TOO_BIG


async def _pump(source: Any, sink: Any) -> None:
    """Copy every message (text or binary) from ``source`` to ``sink`` until either closes."""
    from websockets.exceptions import ConnectionClosed

    try:
        async for message in source:
            await sink.send(message)
    except ConnectionClosed:
        pass


class SubprotocolRelay:
    """Listens on ``host:port`` (0 = any free port) and relays each client to the server at
    ``ws://127.0.0.1:<upstream_port>``, within the bounds of the module docstring;
    :attr:`port` is the port it listens on, :attr:`stats` its counters.

    ``max_clients`` (1…1024) and ``max_message_bytes`` (65,536…2³⁰ bytes) default to the
    environment variables ``PHRI_FOXGLOVE_MAX_CLIENTS`` and ``PHRI_FOXGLOVE_MAX_MESSAGE_BYTES``,
    else 8 and 1 MiB (:func:`relay_limits`; ValueError names a value out of range).
    """

    def __init__(self, upstream_port: int, host: str = "127.0.0.1", port: int = 0, *,
                 max_clients: int | None = None,
                 max_message_bytes: int | None = None) -> None:
        self.max_clients, self.max_message_bytes = relay_limits(max_clients, max_message_bytes)
        self.upstream = f"ws://127.0.0.1:{int(upstream_port)}"
        self.stats = RelayStats()
        self._sessions: set[Any] = set()
        self._connections = 0
        self._loop = asyncio.new_event_loop()
        try:
            self.server = self._loop.run_until_complete(self._serve(host, port))
        except BaseException:
            self._loop.close()
            raise
        self.port = int(self.server.sockets[0].getsockname()[1])
        self.thread = threading.Thread(target=self._loop.run_forever, name="foxglove-relay",
                                       daemon=True)
        self.thread.start()

    async def _serve(self, host: str, port: int) -> Any:
        from websockets.asyncio.server import serve
        from websockets.typing import Subprotocol

        return await serve(
            self._handle, host, port, subprotocols=[Subprotocol(p) for p in SUBPROTOCOLS],
            process_request=self._admit, create_connection=self._connection_class(),
            max_size=self.max_message_bytes, max_queue=MAX_QUEUE, compression=None,
            open_timeout=OPEN_TIMEOUT_S, close_timeout=OPEN_TIMEOUT_S)

    def _connection_class(self) -> type:
        """websockets' server connection, counting TCP connections: beyond ``max_clients`` +
        :data:`MAX_HANDSHAKES` the new one is answered 503 and closed at once; a closed one
        frees its slot."""
        from websockets.asyncio.server import ServerConnection

        relay = self

        class CountedConnection(ServerConnection):
            def connection_made(self, transport: asyncio.BaseTransport) -> None:
                super().connection_made(transport)
                relay._connections += 1
                if relay._connections > relay.max_clients + MAX_HANDSHAKES:
                    relay.stats.aborted += 1
                    if isinstance(transport, asyncio.WriteTransport):
                        transport.write(_BUSY)
                    transport.close()

            def connection_lost(self, exc: Exception | None) -> None:
                relay._connections -= 1
                if self in relay._sessions:
                    relay._sessions.discard(self)
                    relay.stats.active = len(relay._sessions)
                super().connection_lost(exc)

        return CountedConnection

    def _admit(self, connection: Any, request: Any) -> Any:
        """``process_request``: a session slot, or HTTP 503 when ``max_clients`` are open."""
        if len(self._sessions) >= self.max_clients:
            self.stats.refused += 1
            return connection.respond(
                HTTPStatus.SERVICE_UNAVAILABLE,
                f"phri relay: {self.max_clients} clients connected (max_clients); try again "
                "later\n")
        self._sessions.add(connection)
        self.stats.sessions += 1
        self.stats.active = len(self._sessions)
        return None

    async def _handle(self, client: Any) -> None:
        """One session: an upstream connection and a pump each way; a message above
        ``max_message_bytes`` either way ends it with close code 1009."""
        from websockets.asyncio.client import connect
        from websockets.exceptions import InvalidHandshake
        from websockets.typing import Subprotocol

        try:
            upstream = await connect(
                self.upstream, subprotocols=[Subprotocol(UPSTREAM_SUBPROTOCOL)],
                max_size=self.max_message_bytes, max_queue=MAX_QUEUE, compression=None,
                open_timeout=OPEN_TIMEOUT_S, ping_interval=None)
        except (OSError, TimeoutError, InvalidHandshake) as err:
            await client.close(1011, f"upstream unavailable: {type(err).__name__}")
            return
        async with upstream:
            pumps = [asyncio.create_task(_pump(upstream, client)),
                     asyncio.create_task(_pump(client, upstream))]
            await asyncio.wait(pumps, return_when=asyncio.FIRST_COMPLETED)
            for task in pumps:
                task.cancel()
            await asyncio.gather(*pumps, return_exceptions=True)
        if _too_big(client):
            self.stats.oversize_closes += 1
        elif _too_big(upstream):
            self.stats.oversize_closes += 1
            await client.close(MESSAGE_TOO_BIG, "server message above max_message_bytes")

    def close(self) -> None:
        """Stop listening, close every session and stop the relay's thread (idempotent)."""
        if self._loop.is_closed():
            return

        async def shutdown() -> None:
            self.server.close()
            await self.server.wait_closed()

        if self.thread.is_alive():
            asyncio.run_coroutine_threadsafe(shutdown(), self._loop).result(timeout=60)
            self._loop.call_soon_threadsafe(self._loop.stop)
            self.thread.join(timeout=5)
        self._loop.close()
