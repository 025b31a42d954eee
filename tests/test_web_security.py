"""The server against cross-site request forgery, and the headers every response carries.

A page of another origin (another site, or another port of the same machine) cannot make a
change: browsers send ``Origin`` with every POST, PUT, PATCH and DELETE, also from a form or
a ``no-cors`` fetch, and the server compares it with its own. A change authenticated by the
session cookie must also carry the page's own header, which another origin cannot add.
Scripts with an API token need neither.
"""

from __future__ import annotations

import base64
import hashlib
import re
import time

import pytest
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from sightplan.cli.main import app as cli
from sightplan.web.app import REQUEST_HEADER, create_app
from sightplan.web.config import ServerConfig, ServerConfigError
from sightplan.web.routes.viewer import STATIC_DIR

HOST = "127.0.0.1:8803"
OWN = f"http://{HOST}"


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    data = tmp_path_factory.mktemp("csrf") / "data"
    result = CliRunner().invoke(cli, ["users", "add", "alice", "--data", str(data), "--password-stdin"],
                                input="alice-secret-1\n")
    assert result.exit_code == 0, result.output
    config = ServerConfig(data_dir=data, team=True, allowed_origins=("https://sightplan.example.com",))
    with TestClient(create_app(config), base_url=OWN) as c:
        r = c.post("/api/auth/login", json={"username": "alice", "password": "alice-secret-1"},
                   headers={"origin": OWN})
        assert r.status_code == 200, r.text
        yield c


def names(client) -> list[str]:
    return [p["name"] for p in client.get("/api/projects").json()]


def test_changes_from_other_origins_are_refused_with_the_cookie(server):
    before = names(server)
    for origin in ("http://127.0.0.1:8804", "http://evil.example", "null", "https://127.0.0.1:8803"):
        r = server.post("/api/projects", json={"name": "forged"}, headers={"origin": origin, REQUEST_HEADER: "1"})
        assert r.status_code == 403 and "another site" in r.json()["detail"], origin
    # without Origin, a Referer from another origin is refused as well
    r = server.post("/api/projects", json={"name": "forged"}, headers={"referer": "http://127.0.0.1:8804/attack.html"})
    assert r.status_code == 403
    # a body-less POST (a share link), a PATCH and a DELETE from another port: refused too
    for method in ("POST", "PATCH", "DELETE"):
        r = server.request(method, "/api/projects/1", headers={"origin": "http://127.0.0.1:8804"})
        assert r.status_code == 403, method
    assert names(server) == before


def test_cookie_changes_need_the_pages_header(server):
    r = server.post("/api/projects", json={"name": "x"})  # a cookie, no Origin, no Referer, no header
    assert r.status_code == 403 and REQUEST_HEADER in r.json()["detail"]
    r = server.post("/api/projects", json={"name": "from the page"}, headers={"origin": OWN, REQUEST_HEADER: "1"})
    assert r.status_code == 201, r.text
    r = server.post("/api/projects", json={"name": "same-origin referer"}, headers={"referer": OWN + "/"})
    assert r.status_code == 201, r.text
    r = server.post("/api/projects", json={"name": "behind the proxy"},
                    headers={"origin": "https://sightplan.example.com"})
    assert r.status_code == 201, r.text  # an allowed origin (--allowed-origin)
    assert {"from the page", "same-origin referer", "behind the proxy"} <= set(names(server))


def test_scripts_with_a_token_need_no_header(server):
    token = server.post("/api/auth/tokens", json={"name": "script"}, headers={REQUEST_HEADER: "1"}).json()["token"]
    script = TestClient(server.app, base_url=OWN)  # no cookie, no Origin: as curl or a Python script sends
    r = script.post("/api/projects", json={"name": "scripted"}, headers={"authorization": f"Bearer {token}"})
    assert r.status_code == 201, r.text
    # a token cannot be spent by another site's page either
    r = script.post("/api/projects", json={"name": "x"}, headers={"authorization": f"Bearer {token}",
                                                                  "origin": "http://evil.example"})
    assert r.status_code == 403


def test_reads_are_not_refused(server):
    assert server.get("/api/projects", headers={"origin": "http://evil.example"}).status_code == 200


def test_every_response_carries_the_security_headers(server):
    page = (STATIC_DIR / "index.html").read_text(encoding="utf-8")
    inline = re.findall(r"<script(?![^>]*\bsrc=)[^>]*>(.*?)</script>", page, flags=re.S)
    assert len(inline) == 1 and "importmap" in page  # the import map: the page's only inline script
    digest = base64.b64encode(hashlib.sha256(inline[0].encode()).digest()).decode()
    assert "onerror=" not in page and "style=" not in page  # no inline handler or style for the policy to block
    for url in ("/", "/api/projects", "/static/app.js", "/api/info"):
        r = server.get(url)
        assert r.status_code == 200, url
        csp = r.headers["content-security-policy"]
        assert f"script-src 'self' 'sha256-{digest}'" in csp and "frame-ancestors 'none'" in csp
        assert "unsafe-inline" not in csp and "unsafe-eval" not in csp
        assert r.headers["x-content-type-options"] == "nosniff"
        assert r.headers["x-frame-options"] == "DENY"
        assert r.headers["referrer-policy"] == "same-origin"


def test_api_docs_work_offline(server):
    r = server.get("/docs")
    assert r.status_code == 200 and "swagger-ui" in r.text
    assert not re.search(r"(src|href)=\"https?://", r.text)  # nothing from another host
    for asset in re.findall(r"(?:src|href)=\"(/[^\"]+)\"", r.text):
        assert server.get(asset).status_code == 200, asset
    assert server.get("/openapi.json").json()["info"]["title"] == "sightplan"
    assert server.get("/redoc").status_code == 404  # ReDoc would load from a CDN: not offered


def test_an_allowed_origin_must_be_a_scheme_and_a_host(tmp_path):
    with pytest.raises(ServerConfigError, match="scheme and a host"):
        ServerConfig(data_dir=tmp_path, allowed_origins=("sightplan.example.com/app",))


def bomb(path, unpacked_mb: int) -> bytes:
    """An .ifczip whose IFC (a valid header, then spaces) unpacks to ``unpacked_mb`` MB from a few kB."""
    import zipfile

    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("model.ifc", "w", force_zip64=True) as f:
            f.write(b"ISO-10303-21;\nHEADER;\n")
            block = b" " * (1 << 20)
            for _ in range(unpacked_mb):
                f.write(block)
            f.write(b"\nENDSEC;\nEND-ISO-10303-21;\n")
    return path.read_bytes()


def test_an_ifczip_bomb_is_refused_before_it_is_unpacked(tmp_path, monkeypatch):
    import tempfile

    from sightplan.errors import ModelError
    from sightplan.model.load import load_model

    data = bomb(tmp_path / "bomb.ifczip", 64)
    assert len(data) < 1 << 20  # 64 MB inside less than 1 MB
    monkeypatch.setenv("SIGHTPLAN_MAX_UNPACKED_MB", "16")
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    with pytest.raises(ModelError, match="over the limit of 16 MB"):
        load_model(tmp_path / "bomb.ifczip", cache=False)
    assert not any((tmp_path / "tmp").iterdir())  # nothing unpacked is left behind


def test_the_server_refuses_an_uploaded_bomb_and_keeps_nothing(tmp_path):
    from web_support import wait_job

    data = bomb(tmp_path / "bomb.ifczip", 24)  # over ten times a 2 MB upload limit
    config = ServerConfig(data_dir=tmp_path / "d", max_upload_bytes=2 * 1024 * 1024)
    with TestClient(create_app(config)) as c:
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        r = c.post(f"/api/projects/{pid}/models", files={"file": ("bomb.ifczip", data)})
        assert r.status_code == 202, r.text
        job = wait_job(c, r.json()["job"]["id"])
        assert job["status"] == "failed" and "over the limit of 20 MB" in job["error"], job
    assert not any((tmp_path / "d" / "tmp").iterdir())


def test_a_kmz_that_lies_about_its_size_is_a_422_not_a_500(tmp_path):
    from test_imports_flight import lying_zip

    data = lying_zip(tmp_path / "liar.kmz", "wpmz/waylines.wpml", 80).read_bytes()  # 80 MB declared as 1 kB
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d"))) as c:
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        r = c.post(f"/api/projects/{pid}/plans/upload", files={"file": ("liar.kmz", data)}, data={"camera": "m3e"})
        assert r.status_code == 422 and "the archive is broken" in r.json()["detail"], r.text
        assert c.get(f"/api/projects/{pid}/plans").json() == []


def test_runaway_template_requests_are_422_naming_the_parameter(server):
    pid = server.post("/api/projects", json={"name": "runaway"}, headers={REQUEST_HEADER: "1"}).json()["id"]
    with open(__import__("sightplan.model.load", fromlist=["x"]).sample_model_path(), "rb") as fh:
        r = server.post(f"/api/projects/{pid}/models", files={"file": ("duplex.ifc", fh)}, headers={REQUEST_HEADER: "1"})
    from web_support import wait_job

    assert wait_job(server, r.json()["job"]["id"])["status"] == "done"
    mid = r.json()["model"]["id"]
    for body, words in (({"template": "orbit", "radius_m": [20], "height_m": [6], "step_deg": 0.0001}, "step"),
                        ({"template": "facade", "overlap": 0.99, "safety_distance_m": 0.5}, "overlap"),
                        ({"template": "orbit", "radius_m": [20] * 30, "height_m": [6] * 30, "step_deg": 0.1}, "frames"),
                        # a lawn-mower at a tenth of a millimetre per pixel flies into the roof; with the safety
                        # distance lowered to match, it would make two million frames
                        ({"template": "lawnmower", "gsd_m_px": 1e-5}, "gsd_m_px"),
                        ({"template": "lawnmower", "gsd_m_px": 1e-5, "safety_distance_m": 0.01, "position_error": "none"},
                         "2,067,404 frames"),
                        ({"template": "bridge", "axis": [[-50, 0], [5000, 0]], "overlap": 0.95}, "frames"),
                        ({"template": "route", "points": [[0, 0, 1], [90000, 0, 1]], "step_m": 0.001}, "step_m")):
        started = time.monotonic()
        r = server.post(f"/api/projects/{pid}/plans", json={"model_id": mid, **body}, headers={REQUEST_HEADER: "1"})
        assert r.status_code == 422 and words in r.json()["detail"], (body, r.text)
        assert time.monotonic() - started < 5, body  # refused at once, before anything is built
