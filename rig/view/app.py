"""The view's web application (Starlette): the page, its assets, a JSON API and the live
websocket. Read-only: every route is a GET (anything else is 405), and nothing a browser sends
reaches the run; the websocket's incoming messages are read and dropped.

The guards, before any route (``Guard``, for HTTP and websockets alike):

- a path or query longer than ``MAX_QUERY`` bytes: 414;
- bound to a loopback address: a Host header that is not a loopback name is refused (400), so a
  web page elsewhere cannot reach the view through a DNS name rebound to 127.0.0.1;
- with a token (any other address): the token in ``?token=`` (then kept in a cookie for the
  page's own requests), the cookie, or ``Authorization: Bearer``; without it 401;
- a websocket whose Origin is not the page's own: refused (403);
- at most ``MAX_LIVE`` live websockets at once (others refused, 403), each dropped when a send
  waits more than ``SEND_TIMEOUT`` s; disk reads ``MAX_READS`` at a time, in worker threads.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import urllib.parse
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, PlainTextResponse, RedirectResponse, Response
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp, Receive, Send
from starlette.types import Scope as Scope_
from starlette.websockets import WebSocket, WebSocketDisconnect

from rig.view.feed import RATE
from rig.view.scope import Scope
from rig.view.store import Store, ViewError

__all__ = ["COOKIE", "MAX_LIVE", "MAX_QUERY", "SEND_TIMEOUT", "STATIC", "Guard", "make_app"]

STATIC = Path(__file__).resolve().parent / "static"
MAX_QUERY = 2048  #: [B] of a request's path, and of its query, at most
MAX_LIVE = 16  #: live websockets at once
MAX_READS = 2  #: disk reads at once (the others wait their turn)
SEND_TIMEOUT = 5.0  #: [s] a send to a browser may wait before it is dropped
COOKIE = "rig_view_token"
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1", "[::1]")


def _headers(scope: Scope_) -> dict[str, str]:
    return {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}


def _hostname(host: str) -> str:
    """The name part of a Host or Origin authority ("[::1]:8050" -> "[::1]", "a:1" -> "a")."""
    if host.startswith("["):
        return host[: host.find("]") + 1]
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


class Guard:
    """See the module docstring; ``token`` None: loopback only (the Host check).

    Parameters
    ----------
    app : ASGIApp
        The application guarded.
    token : str | None
        The access token (None: loopback only).
    """

    def __init__(self, app: ASGIApp, token: str | None) -> None:
        self.app = app
        self.token = token

    async def __call__(self, scope: Scope_, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        refused = self._refused(scope)
        if refused is None:
            await self.app(scope, receive, send)
            return
        status, text = refused
        if scope["type"] == "websocket":  # refused before the handshake: an HTTP status
            await send({"type": "websocket.http.response.start", "status": status, "headers": []})
            await send({"type": "websocket.http.response.body", "body": text.encode()})
            return
        await PlainTextResponse(text + "\n", status_code=status)(scope, receive, send)

    def _refused(self, scope: Scope_) -> tuple[int, str] | None:
        raw_path = scope.get("raw_path") or scope["path"].encode()
        query = scope.get("query_string", b"")
        if len(raw_path) > MAX_QUERY or len(query) > MAX_QUERY:
            return 414, f"rig view: the request's path or query is over {MAX_QUERY} bytes"
        headers = _headers(scope)
        host = headers.get("host", "")
        if self.token is None and _hostname(host).lower() not in LOOPBACK_NAMES:
            return 400, f"rig view: Host {host[:80]!r} is not this machine's loopback name"
        if self.token is not None and not self._has_token(headers, query):
            return 401, "rig view: give the token printed at the start (?token=...)"
        origin = headers.get("origin")
        if scope["type"] == "websocket" and origin is not None:
            if urllib.parse.urlsplit(origin).netloc.lower() != host.lower():
                return 403, f"rig view: a websocket from another origin ({origin[:80]!r})"
        return None

    def _has_token(self, headers: dict[str, str], query: bytes) -> bool:
        assert self.token is not None
        given = [v for k, v in urllib.parse.parse_qsl(query.decode("latin-1")) if k == "token"]
        auth = headers.get("authorization", "")
        if auth.lower().startswith("bearer "):
            given.append(auth[7:].strip())
        for part in headers.get("cookie", "").split(";"):
            name, _, value = part.strip().partition("=")
            if name == COOKIE:
                given.append(value)
        return any(hmac.compare_digest(g.encode(), self.token.encode()) for g in given)


def make_app(
    store: Store, scope: Scope | None, *, token: str | None = None, info: dict[str, Any] | None = None
) -> ASGIApp:
    """The application over ``store``, with the live ``scope`` (None: no live run).

    Parameters
    ----------
    store : Store
        The runs and studies.
    scope : Scope | None
        The live run's (None: none).
    token : str | None, optional
        The access token (None: loopback only).
    info : dict[str, Any] | None, optional
        What the page says of the server.

    Returns
    -------
    ASGIApp
        The application.
    """
    reads = asyncio.Semaphore(MAX_READS)

    def api(fn: Callable[..., Any], query: tuple[str, ...] = ()) -> Callable[[Request], Awaitable[Response]]:
        return _reader(reads, fn, query)

    def samples(root: str, name: str, points: str | None) -> dict[str, Any]:
        columns, rows = store.samples(root, name, points)
        return {"columns": columns, "rows": rows}

    async def api_info(request: Request) -> Response:
        return JSONResponse({"read_only": True, "live": scope is not None, **(info or {})})

    run = "/api/runs/{root}/{name}"
    routes = [
        Route("/", _index(token)),
        Route("/api/info", api_info),
        Route("/api/runs", api(store.runs)),
        Route(run, api(store.run)),
        Route(f"{run}/samples", api(samples, ("points",))),
        Route(f"{run}/trace", api(store.trace, ("cob", "offset", "limit"))),
        Route(f"{run}/identification", api(store.identification)),
        Route("/api/studies", api(store.studies)),
        Route("/api/studies/{root}/{name}", api(store.study)),
        WebSocketRoute("/ws/live", _live(scope)),
        Mount("/static", StaticFiles(directory=STATIC)),
    ]
    return Guard(Starlette(routes=routes), token)


def _reader(
    reads: asyncio.Semaphore, fn: Callable[..., Any], query: tuple[str, ...]
) -> Callable[[Request], Awaitable[Response]]:
    """An endpoint answering ``fn(*path parameters, *query parameters)`` as JSON, run in a thread
    (at most ``MAX_READS`` at once); a ViewError is its status and message."""

    async def endpoint(request: Request) -> Response:
        q = request.query_params
        args = [*request.path_params.values(), *(q.get(name) for name in query)]
        try:
            async with reads:
                result = await run_in_threadpool(fn, *args)
        except ViewError as exc:
            return JSONResponse({"error": str(exc)}, status_code=exc.status)
        return JSONResponse(result)

    return endpoint


def _index(token: str | None) -> Callable[[Request], Awaitable[Response]]:
    """The page; with a token in its query, a redirect setting it as a cookie (for the page's
    own requests)."""

    async def index(request: Request) -> Response:
        if token is not None and "token" in request.query_params:
            response: Response = RedirectResponse("/", status_code=303)
            response.set_cookie(COOKIE, token, httponly=True, samesite="strict")
            return response
        return FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})

    return index


def _live(scope: Scope | None) -> Callable[[WebSocket], Awaitable[None]]:
    """The live scope's websocket: at most ``MAX_LIVE`` watchers (the next refused with 403)."""
    live_clients = [0]

    async def live(ws: WebSocket) -> None:
        if scope is None or live_clients[0] >= MAX_LIVE:
            await ws.close(code=1013)  # before the handshake: refused with 403
            return
        live_clients[0] += 1
        scope.watchers += 1
        try:
            await ws.accept()
            await _stream(ws, scope)
        finally:
            live_clients[0] -= 1
            scope.watchers -= 1

    return live


async def _drain(ws: WebSocket) -> None:
    """Read and drop what the browser sends (nothing it sends is acted on) until it leaves."""
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return


async def _stream(ws: WebSocket, scope: Scope) -> None:
    """The scope's history, then its updates ``RATE`` times a second, then the summary."""
    drain = asyncio.ensure_future(_drain(ws))
    try:
        described = scope.meta is not None
        seq, hello = await run_in_threadpool(scope.hello)
        await asyncio.wait_for(ws.send_text(hello), SEND_TIMEOUT)
        while not drain.done():
            await asyncio.wait({drain}, timeout=0.5 / RATE)  # twice the feed's rate: no update waits long
            seq, message = scope.since(seq, meta=not described)  # a run that began after the hello
            described = described or (message is not None and scope.meta is not None)
            if message is not None:
                await asyncio.wait_for(ws.send_text(message), SEND_TIMEOUT)
            end = scope.end_message()
            if end is not None:
                await asyncio.wait_for(ws.send_text(end), SEND_TIMEOUT)
                await ws.close(code=1000)
                return
    except (WebSocketDisconnect, RuntimeError, OSError, TimeoutError, asyncio.TimeoutError):
        return  # the browser left, or would not take what was sent: dropped
    finally:
        drain.cancel()
