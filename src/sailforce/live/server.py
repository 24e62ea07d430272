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
- ``POST /api/tare``, ``/api/save-calibration``, ``/api/record``, and with a
  guided calibration (:mod:`sailforce.live.guide`) ``/api/guide-skip`` and
  ``/api/guide-redo``: the commands, for scripts (``X-Sail-Token`` header).

Every request must name, in its ``Host`` header, a host the server
answers to (:class:`HostPolicy`): loopback names and addresses, and on a
non-loopback bind the bound address, IP literals and the names given with
``--allow-host``.  Anything else is refused before any route runs, so a page
of another site whose name is made to resolve to this machine (DNS
rebinding) gets neither the page, nor the token, nor the stream.
State-changing requests need the token, compared in constant time; they
take no file name from the client (recordings and calibrations are named by
the server, in the recording folder).  The page carries the token only when
it is requested over a loopback host: on any other it asks the user for it.
WebSocket handshakes and commands from another origin than the page's are
refused, so another site open in the same browser cannot read the stream.
Messages are bounded in size (:data:`MAX_MESSAGE_BYTES`), clients in number
(:data:`MAX_CLIENTS`), a client's pending commands too
(:data:`MAX_PENDING_COMMANDS`); a client that stops reading is dropped after
:data:`SEND_TIMEOUT_S`; refused and malformed messages are logged at most
:data:`LOG_BURST` times per :data:`LOG_PERIOD_S`.  See docs/guide/live.md's
threat model.
"""

from __future__ import annotations

import asyncio
import hmac
import ipaddress
import json
import logging
import os
import secrets
import socket
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from ..calibration.tare import Tare
from ..errors import CommandError, InputError, SailError, ToolError
from ..estimate.estimator import STATUS_NAMES
from .guide import Guide
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

COMMANDS = ("tare", "cancel-tare", "save-calibration", "record", "guide-skip", "guide-redo")

#: The largest WebSocket message or HTTP body the server reads [bytes]: a command is under 200.
MAX_MESSAGE_BYTES = 16 * 1024

#: Pages that may watch at once; one more is refused (503) rather than slowing the others.
MAX_CLIENTS = 32

#: Commands one page may have under way at once (a tare waits for its samples); more are refused.
MAX_PENDING_COMMANDS = 4

#: A page that has not taken an update within this long [s] has stopped reading: it is dropped.
SEND_TIMEOUT_S = 2.0

#: Refused or malformed messages are logged at most LOG_BURST times per LOG_PERIOD_S [s]; the rest are counted.
LOG_BURST, LOG_PERIOD_S = 10, 10.0

#: Names that reach only this machine.
LOOPBACK_NAMES = frozenset({"localhost", "localhost.localdomain", "ip6-localhost", "ip6-loopback"})



def _address(name: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address | None:
    try:
        return ipaddress.ip_address(name.strip("[]"))
    except ValueError:
        return None


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address, IPv6 with or without brackets) reaches only this machine."""
    address = _address(host)
    return host.lower().rstrip(".") in LOOPBACK_NAMES if address is None else address.is_loopback


@dataclass(frozen=True)
class HostPolicy:
    """Which ``Host`` headers the server answers, from the address it is bound to.

    Always the loopback names and addresses.  On a non-loopback bind also the
    bound address itself, any IP literal (a rebinding attack always sends a
    name, never an address), this machine's host name, and ``allowed``: the
    names given with ``--allow-host``.
    """

    bind: str
    allowed: frozenset[str] = frozenset()

    @property
    def loopback_only(self) -> bool:
        return is_loopback(self.bind)

    def accepts(self, host_header: str | None) -> bool:
        """Whether a request whose ``Host`` header is ``host_header`` (``name[:port]``) may be answered."""
        if not host_header:
            return False
        name = _host_name(host_header)
        if is_loopback(name):
            return True
        if self.loopback_only:
            return False
        if _address(name) is not None or name == self.bind.lower():
            return True
        return name in {n.lower().rstrip(".") for n in self.allowed} | {socket.gethostname().lower()}


def _shown(text: str | None, limit: int = 100) -> str:
    """A header's value for a log line: at most ``limit`` characters, anything unprintable escaped (no forged lines)."""
    text = "" if text is None else text[:limit]
    return text if text.isprintable() else text.encode("unicode_escape").decode("ascii")


def _host_name(netloc: str) -> str:
    """The host of ``name:port``, ``[v6]:port`` or a bare name, lower-case, without a trailing dot."""
    netloc = netloc.strip().lower()
    if netloc.startswith("["):
        return netloc.split("]", 1)[0] + "]"
    return netloc.rsplit(":", 1)[0].rstrip(".") if netloc.count(":") == 1 else netloc.rstrip(".")


class OneLineHttpErrors(logging.Filter):
    """aiohttp logs a malformed request (a 10 KB URL, a broken header) with a traceback: one line suffices."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.exc_info and record.exc_info[1] is not None:
            record.msg, record.args = "%s: %s", (record.getMessage(), str(record.exc_info[1]).splitlines()[0][:200])
            record.exc_info, record.exc_text = None, None
        return True


class _RateLimitedLog:
    """At most :data:`LOG_BURST` warnings per :data:`LOG_PERIOD_S`; says how many it held back."""

    def __init__(self) -> None:
        self._window_start, self._logged, self.suppressed = 0.0, 0, 0

    def warning(self, message: str, *args) -> None:
        now = time.monotonic()
        if now - self._window_start > LOG_PERIOD_S:
            if self.suppressed:
                log.warning("%d more refused or malformed messages were not logged", self.suppressed)
            self._window_start, self._logged, self.suppressed = now, 0, 0
        if self._logged < LOG_BURST:
            self._logged += 1
            log.warning(message, *args)
        else:
            self.suppressed += 1


@dataclass
class LiveServer:
    """The page's server for one pipeline; see the module docstring."""

    pipeline: LivePipeline
    record_dir: Path
    record_format: str = "csv"
    calibration_path: Path | None = None
    token: str = field(default_factory=lambda: secrets.token_urlsafe(24))
    hosts: HostPolicy = field(default_factory=lambda: HostPolicy("127.0.0.1"))
    guide: Guide | None = None  #: a guided calibration (``sail live --calibrate``), a listener of the pipeline

    def __post_init__(self) -> None:
        self.state = LiveState()
        self.pipeline.listen(self.state)
        self.recorder: Recorder | None = None
        self.last_tare: Tare | None = None
        self.saved: list[Path] = []
        self._clients: dict[web.WebSocketResponse, int] = {}
        self._pending: dict[web.WebSocketResponse, int] = {}
        self._tasks: set[asyncio.Task] = set()
        self._wake: asyncio.Event | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        static = resources.files("sailforce.live") / "static"
        self._static = {entry.name: entry for entry in static.iterdir() if entry.is_file()}
        self._refusals = _RateLimitedLog()

    # -- the app --------------------------------------------------------------------------------
    def app(self) -> web.Application:
        app = web.Application(client_max_size=MAX_MESSAGE_BYTES, middlewares=[self._check_host])
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

    @web.middleware
    async def _check_host(self, request: web.Request, handler) -> web.StreamResponse:
        """Answer only the Host names of :class:`HostPolicy`, and state changes only from this page's origin."""
        host = request.headers.get("Host")
        if not self.hosts.accepts(host):
            self._refusals.warning("refused a request for Host %s from %s (not a name this server answers to)",
                                   _shown(host), request.remote)  # fmt: skip
            return web.Response(status=421, text="this server does not answer to that Host name (DNS rebinding?)\n")
        origin = request.headers.get("Origin")
        if origin is not None and request.method != "GET" and not self._same_origin(origin, request):
            self._refusals.warning("refused a %s from origin %s (the page is served as %s)", request.method, _shown(origin),
                                   _shown(host))  # fmt: skip
            return web.json_response({"ok": False, "error": "cross-origin request refused"}, status=403)
        try:
            return await handler(request)
        except RecursionError:
            return web.json_response({"ok": False, "error": "the body is nested too deeply"}, status=400)

    def _same_origin(self, origin: str, request: web.Request) -> bool:
        parts = urlsplit(origin)
        return parts.scheme == "http" and parts.netloc == request.host and self.hosts.accepts(parts.netloc)

    def _notify(self) -> None:
        if self._loop is not None and self._wake is not None and not self._wake.is_set():
            try:
                self._loop.call_soon_threadsafe(self._wake.set)
            except RuntimeError:  # the loop has closed: the server is gone, the rows go on to other listeners
                self._loop = None

    # -- pages ----------------------------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.Response:
        """The page; it carries the token only over a loopback Host (elsewhere the page asks for it)."""
        token = self.token if is_loopback(_host_name(request.host)) else ""
        page = self._static["index.html"].read_text(encoding="utf-8").replace("{{TOKEN}}", token)
        return web.Response(text=page, content_type="text/html", headers={"Cache-Control": "no-store"})

    async def _static_file(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        kinds = {".js": "text/javascript", ".css": "text/css", ".svg": "image/svg+xml"}
        resource = self._static.get(name)  # only the package's own files, looked up by name: no path is opened
        kind = kinds.get(Path(name).suffix)
        if resource is None or kind is None:
            raise web.HTTPNotFound()
        return web.Response(body=resource.read_bytes(), content_type=kind)

    async def _favicon(self, request: web.Request) -> web.Response:
        return web.Response(status=204)

    async def _state(self, request: web.Request) -> web.Response:
        return web.json_response(self._update(-1)[0], dumps=_dumps)

    # -- the WebSocket --------------------------------------------------------------------------
    async def _websocket(self, request: web.Request) -> web.WebSocketResponse:
        origin = request.headers.get("Origin")
        if origin is not None and not self._same_origin(origin, request):
            self._refusals.warning("refused a WebSocket from origin %s (the page is served as %s)", _shown(origin),
                                   _shown(request.host))  # fmt: skip
            raise web.HTTPForbidden(text="cross-origin WebSocket refused")
        if len(self._clients) >= MAX_CLIENTS:
            self._refusals.warning("refused a page from %s: %d pages already watch", request.remote, MAX_CLIENTS)
            raise web.HTTPServiceUnavailable(text=f"{MAX_CLIENTS} pages already watch this server")
        ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=MAX_MESSAGE_BYTES)
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
                    self._refusals.warning("ignored a binary WebSocket message from %s", request.remote)
        finally:
            self._clients.pop(ws, None)
            self._pending.pop(ws, None)
        return ws

    async def _client_message(self, ws: web.WebSocketResponse, text: str, peer: str | None) -> None:
        """A command from the page; anything malformed is logged (at a bounded rate) and ignored."""
        try:
            message = json.loads(text)
            if not isinstance(message, dict) or message.get("type") != "command":
                raise InputError("not a command")
            name = message.get("name")
            if name not in COMMANDS:
                raise InputError(f"no command {name!r}")
        except (ValueError, TypeError, RecursionError) as exc:
            reason = "nested too deeply" if isinstance(exc, RecursionError) else exc
            self._refusals.warning("ignored a malformed WebSocket message from %s (%s): %.200r", peer, reason, text)
            return
        if not self._token_ok(message.get("token")):
            self._refusals.warning("refused the command %r from %s: no valid token", name, peer)
            await self._send(ws, {"type": "result", "name": name, "ok": False, "error": "refused: no valid token"})
            return
        if self._pending.get(ws, 0) >= MAX_PENDING_COMMANDS:
            await self._send(ws, {"type": "result", "name": name, "ok": False,
                                  "error": f"refused: {MAX_PENDING_COMMANDS} commands are still under way"})  # fmt: skip
            return
        self._pending[ws] = self._pending.get(ws, 0) + 1
        task = asyncio.create_task(self._reply(ws, name, message))  # a tare waits for its samples: keep reading meanwhile
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _reply(self, ws: web.WebSocketResponse, name: str, message: dict) -> None:
        try:
            result = await self._run(name, message)
        finally:
            if ws in self._pending:
                self._pending[ws] -= 1
        await self._send(ws, {"type": "result", "name": name} | result)

    async def _send(self, ws: web.WebSocketResponse, message: dict) -> bool:
        """Send to one page; a page gone, or not reading for :data:`SEND_TIMEOUT_S`, is dropped (False)."""
        if ws.closed:
            return False
        try:
            await asyncio.wait_for(ws.send_str(_dumps(message)), SEND_TIMEOUT_S)
            return True
        except (ConnectionError, RuntimeError, TimeoutError):
            self._clients.pop(ws, None)
            log.warning("dropped a page that stopped reading")
            asyncio.get_running_loop().create_task(ws.close())
            return False

    async def _broadcast(self) -> None:
        assert self._wake is not None
        while True:
            try:
                await asyncio.wait_for(self._wake.wait(), IDLE_PERIOD_S)
            except TimeoutError:
                pass
            self._wake.clear()
            clients = list(self._clients.items())
            updates = [self._update(since) for _, since in clients]
            sent = await asyncio.gather(*(self._send(ws, message) for (ws, _), (message, _) in zip(clients, updates)))
            for (ws, _), (_, last), ok in zip(clients, updates, sent):
                if ok and ws in self._clients:
                    self._clients[ws] = last
            await asyncio.sleep(UPDATE_PERIOD_S)

    def _hello(self) -> dict:
        cal = self.pipeline.calibration
        return {"type": "hello", "arm": {"l1": cal.arm.l1, "l2": cal.arm.l2, "l3": cal.arm.l3, "l4": cal.arm.l4},
                "capacity": list(cal.capacity), "offsets": list(cal.offsets), "load_unit": cal.load_unit,
                "statuses": list(STATUS_NAMES), "history_s": HISTORY_S, "source": self.pipeline.source,
                "calibration": self.calibration_path.name if self.calibration_path else None,
                "dynamics": cal.dynamics is not None, "record_format": self.record_format,
                "guide": None if self.guide is None else {"holds": len(self.guide.plan), "plan": self.guide.plan.source}}  # fmt: skip

    def _update(self, since: int) -> tuple[dict, int]:
        cal = self.pipeline.calibration
        sample, points, last, counts, rate = self.state.snapshot(cal, since)
        error = self.pipeline.error
        failed = self.pipeline.output.failed
        if failed is not None and failed is self.recorder:  # it stopped itself: the record button is free again
            self.recorder = None
        message = {"type": "update", "sample": sample, "points": points, "counts": counts, "rate_hz": rate,
                   "rows": self.pipeline.rows, "offsets": list(cal.offsets),
                   "recording": self.recorder.info() if self.recorder is not None else None,
                   "recording_failed": failed.info() if failed is not None else None,
                   "ended": self.pipeline.ended.is_set(), "error": None if error is None else str(error),
                   "sent": time.time()}  # fmt: skip
        if self.guide is not None:
            message["guide"] = self.guide.info()
        return message, last

    # -- commands -------------------------------------------------------------------------------
    def _token_ok(self, token: object) -> bool:
        return isinstance(token, str) and hmac.compare_digest(token.encode(), self.token.encode())

    async def _command_request(self, request: web.Request) -> web.Response:
        name = request.path.rsplit("/", 1)[1]
        if not self._token_ok(request.headers.get(TOKEN_HEADER)):
            self._refusals.warning("refused the command %r from %s: no valid token", name, request.remote)
            return web.json_response({"ok": False, "error": f"refused: the {TOKEN_HEADER} header must carry the page's token"},
                                     status=403)  # fmt: skip
        try:
            body = await request.json() if request.can_read_body else {}
            if not isinstance(body, dict):
                raise InputError("not a JSON object")
        except web.HTTPRequestEntityTooLarge:
            return web.json_response({"ok": False, "error": f"the body is over {MAX_MESSAGE_BYTES} bytes"}, status=413)
        except RecursionError:
            return web.json_response({"ok": False, "error": "the body is nested too deeply"}, status=400)
        except ValueError as exc:
            return web.json_response({"ok": False, "error": f"the body is not a JSON object ({exc})"}, status=400)
        result = await self._run(name, body)
        return web.json_response(result, status=200 if result["ok"] else 409, dumps=_dumps)

    async def _run(self, name: str, args: dict) -> dict:
        try:
            if name == "tare":
                result = await self._tare(args)
            elif name == "cancel-tare":
                result = {"cancelled": self.pipeline.cancel_tare()}
            elif name == "save-calibration":
                result = self._save_calibration()
            elif name in ("guide-skip", "guide-redo"):
                if self.guide is None:
                    raise CommandError("no guided calibration runs: start `sail live` with --calibrate PLAN.csv")
                result = self.guide.skip() if name == "guide-skip" else self.guide.redo()
            else:
                result = self._record(args)
        except (CommandError, SailError, OSError) as exc:
            log.warning("command %s failed: %s", name, exc)
            return {"ok": False, "error": str(exc)}
        except Exception as exc:  # a bug: the page still gets an answer, and the log says where
            log.exception("command %s failed unexpectedly", name)
            return {"ok": False, "error": f"internal error ({type(exc).__name__}: {exc}); please report it"}
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
    logging.getLogger("aiohttp.server").addFilter(OneLineHttpErrors())
    runner = web.AppRunner(server.app(), access_log=None)
    await runner.setup()
    try:
        site = web.TCPSite(runner, host, port)
        try:
            await site.start()
        except OSError as exc:
            raise ToolError(f"cannot serve on {host}:{port} ({exc.strerror or exc}); is another `sail live` running? "
                            "Give another --port (0 picks a free one)") from None  # fmt: skip
        bound = runner.addresses[0]
        shown = f"[{bound[0]}]" if ":" in str(bound[0]) else bound[0]
        on_ready(f"http://{shown}:{bound[1]}/")
        while True:
            await asyncio.sleep(3600)
    finally:
        await runner.cleanup()
