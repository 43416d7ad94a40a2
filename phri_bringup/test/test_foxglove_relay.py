"""The Foxglove relay's bounds, with real websocket clients: message size, concurrent clients,
threads (phri_bringup.observer.foxglove_relay). No wall clock: every wait is for an event, with a
generous bound that only stops a hung test."""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from websockets.asyncio.client import connect as async_connect
from websockets.asyncio.server import serve
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidStatus
from websockets.sync.client import connect

from phri_bringup.observer import foxglove_relay as ws_relay
from phri_bringup.observer.foxglove_relay import (
    DEFAULT_MAX_CLIENTS,
    DEFAULT_MAX_MESSAGE_BYTES,
    MESSAGE_TOO_BIG,
    SubprotocolRelay,
    relay_limits,
)

SMALL = 1 << 16  # the smallest allowed max_message_bytes


class Upstream:
    """A stand-in for the foxglove-sdk server: one asyncio thread; echoes every message,
    answers ``big:N`` with N bytes, and records the size of every message it received."""

    def __init__(self) -> None:
        self.received: list[int] = []
        self.loop = asyncio.new_event_loop()

        async def start() -> Any:
            return await serve(self._echo, "127.0.0.1", 0,
                               subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                               max_size=None)

        self.server = self.loop.run_until_complete(start())
        self.port = int(self.server.sockets[0].getsockname()[1])
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()

    async def _echo(self, ws: Any) -> None:
        async for message in ws:
            self.received.append(len(message))
            if isinstance(message, str) and message.startswith("big:"):
                await ws.send(bytes(int(message[4:])))
            else:
                await ws.send(message)

    def close(self) -> None:
        async def stop() -> None:
            self.server.close()
            await self.server.wait_closed()

        asyncio.run_coroutine_threadsafe(stop(), self.loop).result(timeout=30)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(timeout=30)
        self.loop.close()


@pytest.fixture
def upstream() -> Iterator[Upstream]:
    server = Upstream()
    yield server
    server.close()


def _url(relay: SubprotocolRelay) -> str:
    return f"ws://127.0.0.1:{relay.port}"


def _wait_for(condition: Callable[[], bool], what: str) -> None:
    """Wait for ``condition`` (an event of the relay's loop); the bound only stops a hang."""
    deadline = time.monotonic() + 30.0
    while not condition():
        assert time.monotonic() < deadline, f"gave up waiting for {what}"
        time.sleep(0.005)


def _echoes(ws: Any, message: str | bytes) -> bool:
    ws.send(message)
    return bool(ws.recv(timeout=30) == message)


def test_limits_come_from_arguments_then_environment_then_defaults() -> None:
    assert relay_limits(env={}) == (DEFAULT_MAX_CLIENTS, DEFAULT_MAX_MESSAGE_BYTES) == (8, 2**20)
    env = {"PHRI_FOXGLOVE_MAX_CLIENTS": "3", "PHRI_FOXGLOVE_MAX_MESSAGE_BYTES": "0x20000"}
    assert relay_limits(env=env) == (3, 0x20000)
    assert relay_limits(5, SMALL, env=env) == (5, SMALL)


@pytest.mark.parametrize(("kwargs", "env", "named"), [
    ({"max_clients": 0}, {}, r"max_clients refused value 0: allowed an integer in \[1, 1024\]"),
    ({"max_message_bytes": 1000}, {}, r"max_message_bytes refused value 1000: .*\[65536, "),
    ({}, {"PHRI_FOXGLOVE_MAX_CLIENTS": "many"}, r"PHRI_FOXGLOVE_MAX_CLIENTS refused value 'many'"),
    ({}, {"PHRI_FOXGLOVE_MAX_MESSAGE_BYTES": "-1"}, r"PHRI_FOXGLOVE_MAX_MESSAGE_BYTES refused"),
    ({"max_clients": True}, {}, r"max_clients refused value True"),
])
def test_a_bad_limit_is_refused_naming_it_and_its_range(kwargs: dict, env: dict,
                                                        named: str) -> None:
    with pytest.raises(ValueError, match=named):
        relay_limits(**kwargs, env=env)


def test_a_message_above_the_limit_from_a_client_ends_only_its_session(
        upstream: Upstream) -> None:
    relay = SubprotocolRelay(upstream.port, max_message_bytes=SMALL)
    try:
        with connect(_url(relay), subprotocols=["foxglove.websocket.v1"],  # type: ignore[list-item]
                     open_timeout=30) as other:
            assert _echoes(other, "hello")
            with connect(_url(relay), subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                         open_timeout=30, max_size=None) as big:
                assert _echoes(big, b"x" * SMALL)  # at the limit: relayed both ways
                with pytest.raises(ConnectionClosed) as closed:
                    big.send(b"x" * (SMALL + 1))
                    big.recv(timeout=30)
                assert closed.value.rcvd is not None
                assert closed.value.rcvd.code == MESSAGE_TOO_BIG
            _wait_for(lambda: relay.stats.oversize_closes == 1, "the oversize close")
            assert SMALL + 1 not in upstream.received  # never forwarded
            assert _echoes(other, "still here")  # the other session goes on
        _wait_for(lambda: relay.stats.active == 0, "both sessions to end")
        assert relay.stats.sessions == 2 and relay.stats.oversize_closes == 1
    finally:
        relay.close()


def test_a_message_above_the_limit_from_the_server_ends_the_session_with_1009(
        upstream: Upstream) -> None:
    relay = SubprotocolRelay(upstream.port, max_message_bytes=SMALL)
    try:
        with connect(_url(relay), subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                     open_timeout=30, max_size=None) as ws:
            ws.send(f"big:{SMALL}")
            assert len(ws.recv(timeout=30)) == SMALL
            ws.send(f"big:{64 * 2**20}")  # what grew the old relay by 314 MB
            with pytest.raises(ConnectionClosed) as closed:
                ws.recv(timeout=30)
            assert closed.value.rcvd is not None
            assert closed.value.rcvd.code == MESSAGE_TOO_BIG
        _wait_for(lambda: relay.stats.oversize_closes == 1, "the oversize close")
        with connect(_url(relay), subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                     open_timeout=30) as again:
            assert _echoes(again, "after")
    finally:
        relay.close()


async def _attempt(url: str, hold: list[Any]) -> str:
    """Open a session: 'open' (kept in ``hold``), 'refused' (HTTP 503) or 'closed'."""
    try:
        ws = await async_connect(url, subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                                 open_timeout=60)
    except InvalidStatus as err:
        assert err.response.status_code == 503
        assert b"max_clients" in err.response.body
        return "refused"
    except (InvalidHandshake, ConnectionClosed, OSError):  # closed before any answer
        return "closed"
    hold.append(ws)
    return "open"


def test_clients_beyond_max_clients_are_refused_and_threads_stay_bounded(
        upstream: Upstream) -> None:
    """Three sessions, then 200 more clients at once: each is answered 503 (or, beyond the
    handshakes allowed at a time, closed), none gets a session, and the relay starts no
    thread for any of them; a freed slot admits the next client."""
    relay = SubprotocolRelay(upstream.port, max_clients=3)
    threads = threading.active_count()

    async def scenario() -> tuple[list[str], list[str], int]:
        hold: list[Any] = []
        try:
            first = [await _attempt(_url(relay), hold) for _ in range(3)]
            flood = await asyncio.gather(*(_attempt(_url(relay), hold) for _ in range(200)))
            during = threading.active_count()
            for ws in hold:
                await ws.send("ping")
                assert await ws.recv() == "ping"
        finally:
            for ws in hold:
                await ws.close()
        return first, list(flood), during

    try:
        first, flood, during = asyncio.run(scenario())
        assert first == ["open"] * 3
        assert "open" not in flood and flood.count("refused") + flood.count("closed") == 200
        assert relay.stats.refused + relay.stats.aborted == 200
        assert during == threads  # no thread per client, refused or admitted
        _wait_for(lambda: relay.stats.active == 0, "the sessions to end")
        assert relay.stats.sessions == 3
        with connect(_url(relay), subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                     open_timeout=30) as ws:
            assert _echoes(ws, "next")
    finally:
        relay.close()


def test_connections_stuck_in_the_handshake_are_bounded(
        upstream: Upstream, monkeypatch: pytest.MonkeyPatch) -> None:
    """TCP connections that never send a request hold a slot only up to max_clients +
    MAX_HANDSHAKES; the next ones are answered 503 at once and closed; closing the idle ones
    frees their slots."""
    monkeypatch.setattr(ws_relay, "MAX_HANDSHAKES", 4)
    relay = SubprotocolRelay(upstream.port, max_clients=2)
    idle = [socket.create_connection(("127.0.0.1", relay.port)) for _ in range(2 + 4 + 3)]
    try:
        _wait_for(lambda: relay.stats.aborted == 3, "the connections beyond the bound")
        for sock in idle[-3:]:
            sock.settimeout(30)
            answer = b""
            while chunk := sock.recv(4096):  # until the relay closes it
                answer += chunk
            assert answer.startswith(b"HTTP/1.1 503 ") and b"max_clients" in answer
        for sock in idle:
            sock.close()
        _wait_for(lambda: relay._connections == 0, "the idle connections to be released")
        with connect(_url(relay), subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                     open_timeout=30) as ws:
            assert _echoes(ws, "through")
        assert relay.stats.sessions == 1
    finally:
        for sock in idle:
            sock.close()
        relay.close()


def test_an_unreachable_server_ends_the_session_cleanly() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        dead_port = probe.getsockname()[1]  # nothing listens once closed
    relay = SubprotocolRelay(dead_port)
    try:
        with connect(_url(relay), subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                     open_timeout=30) as ws, pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=30)
        assert closed.value.rcvd is not None and closed.value.rcvd.code == 1011
        _wait_for(lambda: relay.stats.active == 0, "the session to end")
    finally:
        relay.close()
    relay.close()  # idempotent
