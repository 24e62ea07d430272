"""The live server under attack, on 127.0.0.1 only: tokens, foreign Host and Origin headers (DNS rebinding),
oversized and nested messages, floods, many clients, and a client that never reads.

Every request goes to a server on the loopback interface (aiohttp's test server binds 127.0.0.1); a "foreign"
host is only a Host or Origin header.  Every loop is bounded in count and time.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time

import pytest
from aiohttp import WSServerHandshakeError

from sailforce.live import server as live_server
from sailforce.live.pipeline import LivePipeline
from sailforce.live.server import MAX_CLIENTS, MAX_MESSAGE_BYTES, HostPolicy, LiveServer, is_loopback
from sailforce.live.sources import simulated_arm
from sailforce.robot import Robot

#: Every wait ends after this long [s].
WAIT_S = 20.0

#: A WebSocket handshake's headers, for raw GETs of /ws.
UPGRADE = {"Connection": "Upgrade", "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
           "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ=="}  # fmt: skip


def _serve(cal, tmp_path, check, hosts: HostPolicy | None = None):
    """``check(client, server)`` against a LiveServer of the simulated arm (an endless 1 kHz stream)."""
    from aiohttp.test_utils import TestClient, TestServer

    async def main():
        pipeline = LivePipeline(cal, simulated_arm(Robot(), rig=1), source="simulated arm")
        server = LiveServer(pipeline, record_dir=tmp_path / "rec", **({"hosts": hosts} if hosts else {}))
        pipeline.start()
        try:
            async with TestClient(TestServer(server.app(), host="127.0.0.1")) as client:
                await check(client, server)
        finally:
            pipeline.stop()

    asyncio.run(main())


async def _rows(server, at_least=1):
    deadline = time.monotonic() + WAIT_S
    while server.pipeline.rows < at_least and time.monotonic() < deadline:
        await asyncio.sleep(0.01)
    assert server.pipeline.rows >= at_least


def test_dns_rebinding_gets_neither_page_nor_token_nor_commands(cals, tmp_path):
    """A page served as http://evil.example:PORT/ (the name resolving to 127.0.0.1) got the token and could tare."""
    _, static, _ = cals

    async def check(client, server):
        await _rows(server)
        port = client.port
        evil = {"Host": f"evil.example:{port}"}
        page = await client.get("/", headers=evil)
        assert page.status == 421 and server.token not in await page.text()
        assert (await client.get("/api/state", headers=evil)).status == 421
        assert (await client.get("/static/live.js", headers=evil)).status == 421
        tare = await client.post("/api/tare", json={"samples": 10}, headers=evil | {"X-Sail-Token": server.token})
        assert tare.status == 421
        with pytest.raises(WSServerHandshakeError) as refused:
            await client.ws_connect("/ws", headers=evil | {"Origin": f"http://evil.example:{port}"})
        assert refused.value.status == 421
        rebound = await client.get("/", headers={"Host": f"localhost.evil.example:{port}"})
        assert rebound.status == 421
        assert server.pipeline.calibration.offsets == static.offsets and server.last_tare is None

    _serve(static, tmp_path, check)


def test_loopback_hosts_get_the_page_with_its_token(cals, tmp_path):
    _, static, _ = cals

    async def check(client, server):
        for host in (f"127.0.0.1:{client.port}", f"localhost:{client.port}", f"[::1]:{client.port}", "127.0.0.2", "LOCALHOST."):
            page = await client.get("/", headers={"Host": host})
            assert page.status == 200 and server.token in await page.text(), host

    _serve(static, tmp_path, check)


def test_host_policy_beyond_loopback():
    policy = HostPolicy("0.0.0.0", frozenset({"lab-pc.local"}))
    assert not policy.loopback_only
    for host in ("192.168.1.5:8050", "[fe80::1]:8050", "lab-pc.local:8050", "LAB-PC.local.", "localhost:1"):
        assert policy.accepts(host), host
    for host in ("evil.example:8050", "lab-pc.local.evil.example", "", None):
        assert not policy.accepts(host), host
    loopback = HostPolicy("127.0.0.1")
    assert loopback.loopback_only and not loopback.accepts("192.168.1.5:8050") and loopback.accepts("[::1]:80")
    assert is_loopback("::1") and is_loopback("127.3.4.5") and not is_loopback("10.0.0.1") and not is_loopback("localhost.evil")


def test_beyond_loopback_the_page_carries_no_token(cals, tmp_path):
    """Served on 0.0.0.0, a page opened as http://10.0.0.7:PORT/ must ask for the token, not carry it."""
    _, static, _ = cals

    async def check(client, server):
        page = await client.get("/", headers={"Host": f"10.0.0.7:{client.port}"})
        text = await page.text()
        assert page.status == 200 and server.token not in text and 'content=""' in text
        local = await client.get("/")
        assert server.token in await local.text()

    _serve(static, tmp_path, check, hosts=HostPolicy("0.0.0.0"))


def test_wrong_and_missing_tokens_change_nothing(cals, tmp_path):
    _, static, _ = cals

    async def check(client, server):
        await _rows(server)
        for name in live_server.COMMANDS:
            for headers in ({}, {"X-Sail-Token": ""}, {"X-Sail-Token": server.token + "x"}, {"X-Sail-Token": server.token.upper()}):
                response = await client.post(f"/api/{name}", json={"samples": 10, "on": True}, headers=headers)
                assert response.status == 403, (name, headers)
        ws = await client.ws_connect("/ws")
        for token in (None, "", 12345, [server.token], server.token[:-1]):
            await ws.send_str(json.dumps({"type": "command", "name": "tare", "samples": 10, "token": token}))
        refusals = 0
        deadline = time.monotonic() + WAIT_S
        while refusals < 5 and time.monotonic() < deadline:
            message = await ws.receive_json(timeout=WAIT_S)
            refusals += message["type"] == "result" and "no valid token" in message["error"]
        assert refusals == 5
        await ws.close()
        assert server.pipeline.calibration.offsets == static.offsets and not (tmp_path / "rec").exists()

    _serve(static, tmp_path, check)


def test_cross_origin_commands_and_websockets_are_refused(cals, tmp_path):
    _, static, _ = cals

    async def check(client, server):
        good = {"X-Sail-Token": server.token}
        for origin in ("http://evil.example", f"http://evil.example:{client.port}", f"https://127.0.0.1:{client.port}", "null"):
            response = await client.post("/api/record", json={"on": True}, headers=good | {"Origin": origin})
            assert response.status == 403, origin
            with pytest.raises(WSServerHandshakeError) as refused:
                await client.ws_connect("/ws", headers={"Origin": origin})
            assert refused.value.status == 403
        same = await client.ws_connect("/ws", headers={"Origin": f"http://127.0.0.1:{client.port}"})
        assert (await same.receive_json(timeout=WAIT_S))["type"] == "hello"
        await same.close()
        assert not (tmp_path / "rec").exists()

    _serve(static, tmp_path, check)


def test_oversized_nested_and_odd_requests_get_answers_not_500s(cals, tmp_path):
    """Deeply nested JSON (WebSocket and HTTP) and a very long static path gave tracebacks and 500 errors."""
    _, static, _ = cals

    async def check(client, server):
        good = {"X-Sail-Token": server.token}
        nested = "[" * 100_000 + "]" * 100_000
        big = await client.post("/api/tare", data=nested, headers=good)
        assert big.status == 413
        deep = "[" * 5_000 + "]" * 5_000  # under the size limit, over the parser's recursion limit
        assert (await client.post("/api/tare", data=deep, headers=good)).status == 400
        assert (await client.get("/static/" + "a" * 5_000 + ".js")).status == 404
        assert (await client.get("/static/" + "a" * 20_000 + ".js")).status == 400  # aiohttp's own limit: 8190 bytes
        assert (await client.get("/static/index.html")).status == 404  # the page has its own route; no other file type
        ws = await client.ws_connect("/ws")
        await ws.send_str(deep)
        await ws.send_str(json.dumps({"type": "command", "name": "record", "on": "maybe", "token": server.token}))
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline:
            message = await ws.receive_json(timeout=WAIT_S)
            if message["type"] == "result":
                assert "record takes" in message["error"]
                break
        else:
            pytest.fail("no answer after a nested message")
        await ws.send_str("x" * (MAX_MESSAGE_BYTES + 1))
        closing = await ws.receive(timeout=WAIT_S)
        while closing.type.name not in ("CLOSE", "CLOSED", "CLOSING"):
            closing = await ws.receive(timeout=WAIT_S)
        assert ws.closed or closing.data == 1009  # message too big
        assert (await client.get("/api/state")).status == 200  # the server goes on

    _serve(static, tmp_path, check)


def test_a_flood_is_logged_at_a_bounded_rate_and_the_server_still_answers(cals, tmp_path, caplog):
    _, static, _ = cals
    flood = 2_000

    async def check(client, server):
        ws = await client.ws_connect("/ws")
        started = time.monotonic()
        for i in range(flood):
            await ws.send_str(f"{{not json {i}")
        await ws.send_str(json.dumps({"type": "command", "name": "cancel-tare", "token": server.token}))
        deadline = started + WAIT_S
        while time.monotonic() < deadline:
            message = await ws.receive_json(timeout=WAIT_S)
            if message["type"] == "result":
                assert message["ok"] and message["cancelled"] is False
                break
        else:
            pytest.fail("no answer after the flood")
        await ws.close()

    with caplog.at_level(logging.WARNING, logger="sailforce.live.server"):
        _serve(static, tmp_path, check)
    malformed = [r for r in caplog.records if "malformed" in r.getMessage()]
    assert malformed and len(malformed) <= live_server.LOG_BURST  # some logged, and at most a burst of them


def test_many_clients_are_served_and_one_more_is_refused(cals, tmp_path):
    _, static, _ = cals

    async def check(client, server):
        await _rows(server)
        sockets = [await client.ws_connect("/ws") for _ in range(MAX_CLIENTS)]
        with pytest.raises(WSServerHandshakeError) as refused:
            await client.ws_connect("/ws")
        assert refused.value.status == 503
        for ws in sockets:
            kinds = set()
            while "update" not in kinds:
                kinds.add((await ws.receive_json(timeout=WAIT_S))["type"])
        for ws in sockets:
            await ws.close()
        again = await client.ws_connect("/ws")  # the closed ones freed their places
        assert (await again.receive_json(timeout=WAIT_S))["type"] == "hello"
        await again.close()

    _serve(static, tmp_path, check)


class _NeverReads:
    """A page whose socket has stopped draining: every send waits forever."""

    closed = False

    def __init__(self):
        self.sends = 0

    async def send_str(self, text):
        self.sends += 1
        await asyncio.Event().wait()

    async def close(self):
        self.closed = True


def test_a_client_that_never_reads_is_dropped_and_the_others_go_on(cals, tmp_path, monkeypatch):
    """The broadcast awaited each page in turn: one page that stopped reading froze every other page."""
    _, static, _ = cals
    monkeypatch.setattr(live_server, "SEND_TIMEOUT_S", 0.5)

    async def check(client, server):
        await _rows(server)
        stuck = _NeverReads()
        server._clients[stuck] = -1
        ws = await client.ws_connect("/ws")
        started, updates = time.monotonic(), 0
        while time.monotonic() - started < 2.0:
            updates += (await ws.receive_json(timeout=WAIT_S))["type"] == "update"
        assert stuck not in server._clients and stuck.sends >= 1
        assert updates >= 20  # 50 Hz at most, 2 s: the stuck page held the others up for one timeout at most
        await ws.close()

    _serve(static, tmp_path, check)


def test_the_real_command_refuses_a_rebound_host_and_logs_no_traceback(cals, tmp_path):
    """`sail live` itself (not the test server): a foreign Host, a 20 KB URL, a nested body; one-line logs only."""
    import http.client
    from urllib.parse import urlsplit

    from sailforce.live.browser import live_process

    d, _, _ = cals
    with live_process(["--calibration", d / "static.json", "--simulate", "--record-dir", tmp_path / "rec"]) as live:
        url = urlsplit(live.url)

        def get(path, host):
            connection = http.client.HTTPConnection(url.hostname, url.port, timeout=WAIT_S)
            connection.request("GET", path, headers={"Host": host})
            response = connection.getresponse()
            body = response.read().decode()
            connection.close()
            return response.status, body

        status, body = get("/", f"evil.example:{url.port}")
        assert status == 421 and 'name="sail-token"' not in body
        status, body = get("/", url.netloc)
        assert status == 200 and 'name="sail-token" content=""' not in body
        assert get("/static/" + "a" * 20_000, url.netloc)[0] == 400
        deadline = time.monotonic() + WAIT_S
        while "refused a request for Host" not in live.stderr and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.3)
        assert "refused a request for Host evil.example" in live.stderr
        assert "Traceback" not in live.stderr, live.stderr
