"""Serving the view: the address, the token, and uvicorn in a thread (``rig run --view``) or in
the foreground (``rig view``).

It binds 127.0.0.1 unless told otherwise. Any address that is not a loopback one gets a token
(``secrets.token_urlsafe``, 192 bits) printed with the address at the start; every request
without it is refused (``rig.view.app.Guard``). The socket is bound here, before uvicorn starts,
so a port in use or an address the machine does not have is one clear line, not a traceback in
another thread. uvicorn touches no logging configuration of the process (``log_config=None``)
and no signal handler when it runs in a thread.
"""

from __future__ import annotations

import ipaddress
import secrets
import socket
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from drivers.errors import ConfigError
from rig.view.scope import Scope
from rig.view.store import Store

__all__ = ["DEFAULT_PORT", "ViewServer", "is_loopback", "parse_address"]

DEFAULT_PORT = 8050
LIMIT_CONCURRENCY = 64  #: connections and tasks at once; more: 503


def is_loopback(host: str) -> bool:
    """``host`` names this machine's loopback only ("localhost", 127.0.0.0/8, ::1).

    Parameters
    ----------
    host : str
        A host name or address.

    Returns
    -------
    bool
        Loopback only.
    """
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def parse_address(text: str, where: str) -> tuple[str, int]:
    """``[HOST:]PORT`` or ``HOST`` as (host, port); ConfigError naming ``where`` otherwise.

    Parameters
    ----------
    text : str
        ``[HOST:]PORT`` or ``HOST``.
    where : str
        The option, named in errors.

    Returns
    -------
    tuple[str, int]
        (host, port).

    Raises
    ------
    ConfigError
        If the port is not 0..65535.
    """
    host, port_text = "127.0.0.1", str(DEFAULT_PORT)
    if text.isdigit():
        port_text = text
    elif text.startswith("[") and "]" in text:  # [::1]:8050
        host, _, rest = text[1:].partition("]")
        port_text = rest[1:] if rest.startswith(":") else port_text
    elif text.count(":") == 1:
        host, port_text = text.split(":")
    elif text:
        host = text
    if not port_text.isdigit() or not 0 <= int(port_text) <= 65535:
        raise ConfigError(f"{where}: {text!r}: the port must be 0..65535 ([HOST:]PORT, e.g. 127.0.0.1:8050)")
    return host or "127.0.0.1", int(port_text)


class ViewServer:
    """The view over ``folders`` (and the live ``scope``, if any) on ``host``:``port`` (0: a free
    port); ``url`` says where, with the token where one is needed.

    Parameters
    ----------
    folders : list[Path]
        The folders served.
    scope : Scope | None
        The live run's (None: none).
    host, port
        The address (port 0: a free one).
    where : str
        The option, named in errors.
    """

    def __init__(self, folders: list[Path], scope: Scope | None, host: str, port: int, where: str) -> None:
        import uvicorn

        from rig.view.app import make_app

        self.scope = scope
        self.token = None if is_loopback(host) else secrets.token_urlsafe(24)
        self.sock = _bind(host, port, where)
        bound = self.sock.getsockname()
        shown = f"[{bound[0]}]" if ":" in bound[0] else bound[0]
        self.url = f"http://{shown}:{bound[1]}/" + (f"?token={self.token}" if self.token else "")
        info = {"folders": [str(f) for f in folders], "token_required": self.token is not None}
        app = make_app(Store(folders), scope, token=self.token, info=info)
        config = uvicorn.Config(
            app,
            log_config=None,
            log_level="warning",
            access_log=False,
            lifespan="off",
            ws="websockets-sansio",
            ws_max_size=4096,
            ws_ping_interval=20.0,
            ws_ping_timeout=20.0,
            limit_concurrency=LIMIT_CONCURRENCY,
            timeout_keep_alive=5,
            h11_max_incomplete_event_size=16 * 1024,
            server_header=False,
        )
        self.server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    def serve(self) -> None:
        """Serve in this thread until Ctrl-C (uvicorn's own handling of SIGINT and SIGTERM)."""
        self.server.run(sockets=[self.sock])

    def start(self) -> None:
        """Serve from a thread of its own (a daemon: it never holds the process)."""
        self._thread = threading.Thread(
            target=self.server.run, kwargs={"sockets": [self.sock]}, name="rig-view", daemon=True
        )
        self._thread.start()

    def finish(self, summary: Mapping[str, Any], grace: float = 2.0) -> None:
        """The run's ``summary`` to every browser (they have ``grace`` s to take it), then stop.

        Parameters
        ----------
        summary : Mapping[str, Any]
            The run's summary.
        grace : float, optional
            [s] for browsers to take it.
        """
        if self.scope is not None:
            self.scope.finish(summary)
            until = time.monotonic() + grace
            while self.scope.watchers and time.monotonic() < until:  # each browser's task sends it
                time.sleep(0.02)
        self.close(grace)

    def close(self, timeout: float = 2.0) -> None:
        """Stop serving and close the socket.

        Parameters
        ----------
        timeout : float, optional
            [s] to wait for the thread.
        """
        self.server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout)
        self.sock.close()


def _bind(host: str, port: int, where: str) -> socket.socket:
    """A listening TCP socket on ``host``:``port``; ConfigError saying why not."""
    try:
        infos = socket.getaddrinfo(host.strip("[]"), port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise ConfigError(f"{where}: {host!r} is not an address of this machine: {exc.strerror}") from None
    family, _, _, _, address = infos[0]
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(128)
    except OSError as exc:
        sock.close()
        raise ConfigError(f"{where}: cannot listen on {host}:{port}: {exc.strerror}") from None
    sock.set_inheritable(True)
    return sock
