"""The view is safe by default (issue 38 item 3): loopback unless told, a token on any other address,
read-only (every route a GET; what a browser sends is dropped), and hostile requests (a path out of
the folder, an oversized query, another Host or Origin) get an error and no file's content."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from starlette.routing import Mount, Route, WebSocketRoute
from starlette.testclient import TestClient, WebSocketDenialResponse

from rig.view.app import COOKIE, MAX_QUERY, make_app
from rig.view.scope import Scope
from rig.view.server import is_loopback, parse_address
from rig.view.store import Store

SECRET = "s3cret-token"
LOCAL = {"host": "127.0.0.1:8050"}  #: TestClient's websockets name the host "testserver" otherwise


@pytest.fixture
def folder(tmp_path: pathlib.Path) -> pathlib.Path:
    run = tmp_path / "runs" / "a-run"
    run.mkdir(parents=True)
    (run / "samples.csv").write_text("t,reference,measurement,command\n0.0,1.0,0.5,2.0\n")
    (run / "summary.json").write_text('{"cycles": 1}')
    (tmp_path / "secret.txt").write_text("NOT FOR THE BROWSER")
    return tmp_path / "runs"


def _client(folder: pathlib.Path, token: str | None = None, host: str = "127.0.0.1:8050") -> TestClient:
    return TestClient(make_app(Store([folder]), Scope(), token=token), base_url=f"http://{host}")


@pytest.mark.parametrize(
    "path",
    [
        "/api/runs/0/%2E%2E",
        "/api/runs/0/..%2Fsecret.txt",
        "/api/runs/0/..%2F..%2Fsecret.txt/samples",
        "/api/runs/0/a-run/..%2F..%2Fsecret.txt",
        "/api/runs/1/a-run",
        "/api/runs/../a-run",
        "/static/../../secret.txt",
        "/static/%2E%2E/%2E%2E/secret.txt",
        "/api/studies/0/%2e%2e",
        "/api/runs/0/a-run%00/samples",
    ],
)
def test_no_path_leaves_the_folder(folder: pathlib.Path, path: str) -> None:
    response = _client(folder).get(path)
    assert response.status_code in (400, 404), (path, response.status_code)
    assert "NOT FOR THE BROWSER" not in response.text


def test_a_run_is_found_by_its_name(folder: pathlib.Path) -> None:
    assert _client(folder).get("/api/runs/0/a-run/samples").json()["rows"] == [[0.0, 1.0, 0.5, 2.0]]


def test_oversized_queries_and_paths(folder: pathlib.Path) -> None:
    client = _client(folder)
    assert client.get("/api/runs?x=" + "a" * (MAX_QUERY + 1)).status_code == 414
    assert client.get("/api/runs/0/" + "a" * (MAX_QUERY + 1)).status_code == 414
    assert client.get("/api/runs/0/a-run/samples?points=99999999999999999999").status_code == 400
    assert client.get("/api/runs/0/a-run/trace?limit=1000000").status_code in (400, 404)


def test_every_route_is_read_only(folder: pathlib.Path) -> None:
    app = make_app(Store([folder]), Scope())
    routes = app.app.routes  # type: ignore[attr-defined]
    for route in routes:
        if isinstance(route, Route):
            assert route.methods == {"GET", "HEAD"}, route.path
        else:
            assert isinstance(route, (WebSocketRoute, Mount)), route
    client = _client(folder)
    for path in ("/", "/api/runs", "/api/runs/0/a-run", "/api/runs/0/a-run/samples", "/api/info"):
        for method in ("POST", "PUT", "PATCH", "DELETE"):
            assert client.request(method, path).status_code == 405, (method, path)
    static = client.post("/static/view.js")
    assert static.status_code == 405


def test_the_live_socket_drops_what_the_browser_sends(folder: pathlib.Path) -> None:
    scope = Scope()
    scope.open({"title": "x", "columns": [], "charts": []})
    client = TestClient(make_app(Store([folder]), scope), base_url="http://127.0.0.1:8050")
    with client.websocket_connect("/ws/live", headers=LOCAL) as ws:
        assert ws.receive_json()["type"] == "hello"
        ws.send_text('{"command": "enable"}')
        ws.send_text("sdo write 0x6040 15")
        scope.finish({"cycles": 3, "safe_stop_reason": None})
        assert ws.receive_json() == {"type": "end", "summary": {"cycles": 3, "safe_stop_reason": None}}


def test_another_host_name_is_refused_on_loopback(folder: pathlib.Path) -> None:
    """A page elsewhere that rebinds its DNS name to 127.0.0.1 is refused."""
    assert _client(folder, host="evil.example:8050").get("/api/runs").status_code == 400
    assert _client(folder, host="localhost:8050").get("/api/runs").status_code == 200
    assert _client(folder, host="[::1]:8050").get("/api/runs").status_code == 200


def test_a_websocket_from_another_origin_is_refused(folder: pathlib.Path) -> None:
    client = _client(folder)
    with pytest.raises(WebSocketDenialResponse) as denied:
        with client.websocket_connect("/ws/live", headers={**LOCAL, "origin": "http://evil.example"}):
            pass
    assert denied.value.status_code == 403
    with client.websocket_connect("/ws/live", headers={**LOCAL, "origin": "http://127.0.0.1:8050"}) as ws:
        assert ws.receive_json()["type"] == "hello"


def test_the_token(folder: pathlib.Path) -> None:
    client = _client(folder, token=SECRET, host="192.0.2.10:8050")
    assert client.get("/api/runs").status_code == 401
    assert client.get("/api/runs?token=wrong").status_code == 401
    assert client.get("/", follow_redirects=False).status_code == 401
    assert client.get("/api/runs", headers={"authorization": f"Bearer {SECRET}"}).status_code == 200
    first = client.get(f"/?token={SECRET}", follow_redirects=False)
    assert first.status_code == 303 and COOKIE in first.headers["set-cookie"]
    assert "httponly" in first.headers["set-cookie"].lower()
    assert client.get("/api/runs").status_code == 200  # the cookie from now on
    with pytest.raises(WebSocketDenialResponse) as denied:
        with TestClient(make_app(Store([folder]), Scope(), token=SECRET)).websocket_connect("/ws/live"):
            pass
    assert denied.value.status_code == 401


def test_which_addresses_need_a_token() -> None:
    assert is_loopback("127.0.0.1") and is_loopback("127.0.0.2") and is_loopback("::1")
    assert is_loopback("localhost") and is_loopback("[::1]")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.5") and not is_loopback("rig-pc")
    assert parse_address("8060", "x") == ("127.0.0.1", 8060)
    assert parse_address("0.0.0.0:8060", "x") == ("0.0.0.0", 8060)
    assert parse_address("[::1]:8060", "x") == ("::1", 8060)
    from drivers.errors import ConfigError

    with pytest.raises(ConfigError, match="the port must be"):
        parse_address("host:99999", "rig run: --view")


def _view(*args: str) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "rig.cli", "view", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    return proc, proc.stdout.readline()


def test_rig_view_binds_loopback_and_prints_a_token_elsewhere(folder: pathlib.Path) -> None:
    import urllib.error
    import urllib.request

    proc, line = _view(str(folder), "--port", "0")
    try:
        assert line.startswith("rig view: http://127.0.0.1:") and "token" not in line
        url = line.split()[2]
        with urllib.request.urlopen(url + "api/info", timeout=10) as r:
            assert r.status == 200
    finally:
        proc.terminate()
        proc.communicate(timeout=10)
    proc, line = _view(str(folder), "--port", "0", "--host", "0.0.0.0")
    try:
        assert "?token=" in line
        url, token = line.split()[2].split("?token=")
        local = url.replace("0.0.0.0", "127.0.0.1")
        with pytest.raises(urllib.error.HTTPError) as info:
            urllib.request.urlopen(local + "api/runs", timeout=10)
        assert info.value.code == 401
        info.value.close()
        with urllib.request.urlopen(f"{local}api/runs?token={token}", timeout=10) as r:
            assert r.status == 200
    finally:
        proc.terminate()
        proc.communicate(timeout=10)


def test_rig_view_bad_arguments_are_one_line(folder: pathlib.Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "rig.cli", "view", str(folder / "nowhere")],
        check=False,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0 and "nowhere" in proc.stderr
    busy, line = _view(str(folder), "--port", "0")
    try:
        port = line.split()[2].rsplit(":", 1)[1].strip("/")  # listening: it says so once it does
        proc = subprocess.run(
            [sys.executable, "-m", "rig.cli", "view", str(folder), "--port", port],
            check=False,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert proc.returncode == 2 and "cannot listen" in proc.stderr and "Traceback" not in proc.stderr
    finally:
        busy.terminate()
        busy.communicate(timeout=10)
