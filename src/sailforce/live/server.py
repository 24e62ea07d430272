"""The live page: an aiohttp server with a WebSocket of updates and token-guarded commands.

Routes:

- ``GET /``: the page (``static/index.html``) with this server's token in it;
- ``GET /static/...``: its script and style, from the installed package (no CDN: the page works offline);
- ``GET /ws``: the WebSocket.  The server sends ``hello`` (the arm, the
  cells' capacities, the statuses) and then an ``update`` whenever rows have
  come, at most every :data:`UPDATE_PERIOD_S`: the newest row, the plotted
  points the page has not had, the counts per status, the input rate, the
  recording.  A page receives commands' results as ``result`` messages.
  The client may send commands (``{"type": "command", "token": ..., "name":
  ..., ...}``); anything else, or anything malformed, is logged and ignored;
- ``GET /api/state``: the newest row and counts, as JSON, for scripts;
- ``POST /api/tare``, ``/api/save-calibration``, ``/api/record``: the
  commands, for scripts (``X-Sail-Token`` header).

State-changing requests need the token, compared in constant time; they
take no file name from the client (recordings and calibrations are named by
the server, in the recording folder).  WebSocket handshakes from another
origin than the page's are refused, so another site open in the same browser
cannot read the stream.
"""

from __future__ import annotations

import asyncio
import hmac
import json
import logging
import os
import secrets
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from ..calibration.estimator import STATUS_NAMES
from ..calibration.tare import Tare
from ..errors import SailError
from .pipeline import LivePipeline
from .recorder import Recorder, fresh_file
from .state import HISTORY_S, LiveState

log = logging.getLogger(__name__)

#: Updates go out at most this often [s]: 50 Hz, above the 30 Hz a display needs, and half a period of delay at most.
UPDATE_PERIOD_S = 0.02

#: With no new rows, an update still goes out this often [s] (the recording's clock, the end of a replay).
IDLE_PERIOD_S = 0.5

#: A tare averages this many samples unless asked otherwise (half a second at 1 kHz).
DEFAULT_TARE_SAMPLES = 500

#: A tare may average at most this many samples.
MAX_TARE_SAMPLES = 1_000_000

#: The HTTP header that carries the token of a script's command.
TOKEN_HEADER = "X-Sail-Token"

COMMANDS = ("tare", "save-calibration", "record")


class CommandError(SailError):
    """A command the server cannot carry out; its message goes back to the page."""


@dataclass
class LiveServer:
    """The page's server for one pipeline; see the module docstring."""

    pipeline: LivePipeline
    record_dir: Path
    record_format: str = "csv"
    calibration_path: Path | None = None
    token: str = field(default_factory=lambda: secrets.token_urlsafe(24))

    def __post_init__(self) -> None:
        self.state = LiveState()
        self.pipeline.listen(self.state)
        self.recorder: Recorder | None = None
        self.last_tare: Tare | None = None
        self.saved: list[Path] = []
        self._clients: dict[web.WebSocketResponse, int] = {}
        self._tasks: set[asyncio.Task] = set()
        self._wake: asyncio.Event | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._static = resources.files("sailforce.live") / "static"

    # -- the app --------------------------------------------------------------------------------
    def app(self) -> web.Application:
        app = web.Application()
        app.router.add_get("/", self._index)
        app.router.add_get("/static/{name}", self._static_file)
        app.router.add_get("/favicon.ico", self._favicon)
        app.router.add_get("/ws", self._websocket)
        app.router.add_get("/api/state", self._state)
        for name in COMMANDS:
            app.router.add_post(f"/api/{name}", self._command_request)
        app.on_startup.append(self._start)
        app.on_cleanup.append(self._cleanup)
        return app

    async def _start(self, app: web.Application) -> None:
        self._loop = asyncio.get_running_loop()
        self._wake = asyncio.Event()
        self.state.notify = self._notify
        self._broadcaster = asyncio.create_task(self._broadcast())

    async def _cleanup(self, app: web.Application) -> None:
        self._broadcaster.cancel()
        for ws in list(self._clients):
            await ws.close()

    def _notify(self) -> None:
        if self._loop is not None and self._wake is not None and not self._wake.is_set():
            self._loop.call_soon_threadsafe(self._wake.set)

    # -- pages ----------------------------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.Response:
        page = (self._static / "index.html").read_text(encoding="utf-8").replace("{{TOKEN}}", self.token)
        return web.Response(text=page, content_type="text/html", headers={"Cache-Control": "no-store"})

    async def _static_file(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        kinds = {".js": "text/javascript", ".css": "text/css", ".svg": "image/svg+xml"}
        kind = kinds.get(Path(name).suffix)
        resource = self._static / name
        if kind is None or "/" in name or name.startswith(".") or not resource.is_file():
            raise web.HTTPNotFound()
        return web.Response(body=resource.read_bytes(), content_type=kind)

    async def _favicon(self, request: web.Request) -> web.Response:
        return web.Response(status=204)

    async def _state(self, request: web.Request) -> web.Response:
        return web.json_response(self._update(-1)[0], dumps=_dumps)

    # -- the WebSocket --------------------------------------------------------------------------
    async def _websocket(self, request: web.Request) -> web.WebSocketResponse:
        origin = request.headers.get("Origin")
        if origin is not None and urlsplit(origin).netloc != request.host:
            log.warning("refused a WebSocket from origin %s (the page is served as %s)", origin, request.host)
            raise web.HTTPForbidden(text="cross-origin WebSocket refused")
        ws = web.WebSocketResponse(heartbeat=10.0)
        await ws.prepare(request)
        await ws.send_str(_dumps(self._hello()))
        self._clients[ws] = -1
        log.info("a page connected from %s (%d open)", request.remote, len(self._clients))
        self._notify()
        try:
            async for message in ws:
                if message.type == WSMsgType.TEXT:
                    await self._client_message(ws, message.data, request.remote)
                elif message.type == WSMsgType.BINARY:
                    log.warning("ignored a binary WebSocket message from %s", request.remote)
        finally:
            self._clients.pop(ws, None)
        return ws

    async def _client_message(self, ws: web.WebSocketResponse, text: str, peer: str | None) -> None:
        """A command from the page; anything malformed is logged and ignored."""
        try:
            message = json.loads(text)
            if not isinstance(message, dict) or message.get("type") != "command":
                raise ValueError("not a command")
            name = message.get("name")
            if name not in COMMANDS:
                raise ValueError(f"no command {name!r}")
        except (ValueError, TypeError) as exc:
            log.warning("ignored a malformed WebSocket message from %s (%s): %.200r", peer, exc, text)
            return
        if not self._token_ok(message.get("token")):
            log.warning("refused the command %r from %s: no valid token", name, peer)
            await ws.send_str(_dumps({"type": "result", "name": name, "ok": False, "error": "refused: no valid token"}))
            return
        task = asyncio.create_task(self._reply(ws, name, message))  # a tare waits for its samples: keep reading meanwhile
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _reply(self, ws: web.WebSocketResponse, name: str, message: dict) -> None:
        result = await self._run(name, message)
        if not ws.closed:
            await ws.send_str(_dumps({"type": "result", "name": name} | result))

    async def _broadcast(self) -> None:
        assert self._wake is not None
        while True:
            try:
                await asyncio.wait_for(self._wake.wait(), IDLE_PERIOD_S)
            except TimeoutError:
                pass
            self._wake.clear()
            for ws, since in list(self._clients.items()):
                message, last = self._update(since)
                try:
                    await ws.send_str(_dumps(message))
                    self._clients[ws] = last
                except (ConnectionError, RuntimeError):
                    self._clients.pop(ws, None)
            await asyncio.sleep(UPDATE_PERIOD_S)

    def _hello(self) -> dict:
        cal = self.pipeline.calibration
        return {"type": "hello", "arm": {"l1": cal.arm.l1, "l2": cal.arm.l2, "l3": cal.arm.l3, "l4": cal.arm.l4},
                "capacity": list(cal.capacity), "offsets": list(cal.offsets), "load_unit": cal.load_unit,
                "statuses": list(STATUS_NAMES), "history_s": HISTORY_S, "source": self.pipeline.source,
                "calibration": self.calibration_path.name if self.calibration_path else None,
                "dynamics": cal.dynamics is not None, "record_format": self.record_format}  # fmt: skip

    def _update(self, since: int) -> tuple[dict, int]:
        cal = self.pipeline.calibration
        sample, points, last, counts, rate = self.state.snapshot(cal, since)
        error = self.pipeline.error
        message = {"type": "update", "sample": sample, "points": points, "counts": counts, "rate_hz": rate,
                   "rows": self.pipeline.rows, "offsets": list(cal.offsets),
                   "recording": self.recorder.info() if self.recorder is not None else None,
                   "ended": self.pipeline.ended.is_set(), "error": None if error is None else str(error),
                   "sent": time.time()}  # fmt: skip
        return message, last

    # -- commands -------------------------------------------------------------------------------
    def _token_ok(self, token: object) -> bool:
        return isinstance(token, str) and hmac.compare_digest(token.encode(), self.token.encode())

    async def _command_request(self, request: web.Request) -> web.Response:
        name = request.path.rsplit("/", 1)[1]
        if not self._token_ok(request.headers.get(TOKEN_HEADER)):
            log.warning("refused the command %r from %s: no valid token", name, request.remote)
            return web.json_response({"ok": False, "error": f"refused: the {TOKEN_HEADER} header must carry the page's token"},
                                     status=403)  # fmt: skip
        try:
            body = await request.json() if request.can_read_body else {}
            if not isinstance(body, dict):
                raise ValueError("not a JSON object")
        except ValueError as exc:
            return web.json_response({"ok": False, "error": f"the body is not a JSON object ({exc})"}, status=400)
        result = await self._run(name, body)
        return web.json_response(result, status=200 if result["ok"] else 409, dumps=_dumps)

    async def _run(self, name: str, args: dict) -> dict:
        try:
            if name == "tare":
                result = await self._tare(args)
            elif name == "save-calibration":
                result = self._save_calibration()
            else:
                result = self._record(args)
        except (CommandError, SailError, OSError) as exc:
            log.warning("command %s failed: %s", name, exc)
            return {"ok": False, "error": str(exc)}
        log.info("command %s: %s", name, _dumps(result))
        return {"ok": True} | result

    async def _tare(self, args: dict) -> dict:
        samples = args.get("samples", DEFAULT_TARE_SAMPLES)
        if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= MAX_TARE_SAMPLES:
            raise CommandError(f"a tare averages 1 to {MAX_TARE_SAMPLES:,} samples, not {samples!r}")
        result: Tare = await asyncio.wrap_future(self.pipeline.tare(samples))
        self.last_tare = result
        unit = self.pipeline.calibration.load_unit
        return {"offsets": list(result.offsets), "previous": list(result.previous), "spread": list(result.spread),
                "samples": result.samples, "warnings": result.warnings(unit), "unit": unit}  # fmt: skip

    def _save_calibration(self) -> dict:
        cal = self.pipeline.calibration
        stem = (self.calibration_path.stem if self.calibration_path else "calibration") + "-tare-" + time.strftime("%Y%m%d-%H%M%S")
        path, handle = fresh_file(self.record_dir, stem, ".json")
        os.close(handle)  # the name is ours; save() puts the complete file in its place
        try:
            cal.save(path)
        except BaseException:
            path.unlink(missing_ok=True)
            raise
        self.saved.append(path)
        return {"file": path.name, "offsets": list(cal.offsets)}

    def _record(self, args: dict) -> dict:
        on = args.get("on")
        if not isinstance(on, bool):
            raise CommandError('record takes {"on": true} or {"on": false}')
        output = self.pipeline.output
        if on:
            if self.recorder is not None:
                return {"recording": self.recorder.info()}
            if output.header is None:
                raise CommandError("nothing to record yet: the stream has not sent its header")
            recorder = Recorder(self.record_dir, output.header, self.record_format)
            with output.lock:
                output.recorder = self.recorder = recorder
            return {"recording": recorder.info()}
        return {"stopped": self.stop_recording()}

    def stop_recording(self) -> str | None:
        """Stop the recording, if one runs; the name of its file."""
        recorder, output = self.recorder, self.pipeline.output
        if recorder is None:
            return None
        with output.lock:
            output.recorder = self.recorder = None
        return recorder.stop().name


def _dumps(value: object) -> str:
    return json.dumps(value, allow_nan=False, separators=(",", ":"))


async def serve(server: LiveServer, host: str, port: int, on_ready) -> None:
    """Serve until cancelled (Ctrl-C); ``on_ready(url)`` once the socket listens."""
    runner = web.AppRunner(server.app(), access_log=None)
    await runner.setup()
    try:
        site = web.TCPSite(runner, host, port)
        try:
            await site.start()
        except OSError as exc:
            raise SailError(f"cannot serve on {host}:{port} ({exc.strerror or exc}); is another `sail live` running? "
                            "Give another --port (0 picks a free one)") from None  # fmt: skip
        bound = runner.addresses[0]
        shown = f"[{bound[0]}]" if ":" in str(bound[0]) else bound[0]
        on_ready(f"http://{shown}:{bound[1]}/")
        while True:
            await asyncio.sleep(3600)
    finally:
        await runner.cleanup()
