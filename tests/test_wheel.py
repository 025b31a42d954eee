"""The wheel on its own (in ``make test``; alone: ``pytest -m wheel`` or ``make wheel-check``): build it, install it
into a fresh virtual environment in an empty folder with no checkout beside it, start ``sightplan serve --sample``
from there, and open the page and ``/docs`` in Debian's chromium. The page must load its modules (three.js, MapLibre)
and draw the sample Duplex, and /docs list the operations, all from the wheel's own copy of the JavaScript.

The fresh environment reaches the other dependencies through a path file naming this environment's site-packages
(they are not what is checked, and installing them again would take minutes); sightplan itself comes only from the
wheel: an editable install's finder is not active there.
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import time
import urllib.request
from pathlib import Path

import pytest

from browser_support import free_port, launch_browser

REPO = Path(__file__).resolve().parents[1]


# the fresh environment's processes see only its own sightplan: no path to a checkout's sources
ALONE = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} | {"PYTHONUNBUFFERED": "1"}


def run(*cmd: str, **kw) -> str:
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=ALONE, **kw)
    return out.stdout


@pytest.mark.wheel
def test_the_wheel_alone_serves_the_page_and_the_docs(tmp_path):
    work = tmp_path
    run(sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(work / "dist"), str(REPO))
    (wheel,) = (work / "dist").glob("sightplan-*.whl")
    run(sys.executable, "-m", "venv", str(work / "venv"))
    python = work / "venv" / "bin" / "python"
    site = run(str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])").strip()
    Path(site, "deps-from-the-test-environment.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    run(str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel))
    empty = work / "elsewhere"
    empty.mkdir()
    where = run(str(python), "-c", "import sightplan, sightplan.assets as a; print(sightplan.__file__); "
                "print(a.vendor_root())", cwd=empty).split()
    assert where[0].startswith(str(work / "venv")), f"sightplan came from {where[0]}, not the wheel"
    assert where[1].startswith(str(work / "venv")) and where[1].endswith("web/vendor"), where[1]
    three = run(str(python), "-c", "from sightplan.report.html import find_three; print(find_three())", cwd=empty)
    assert three.strip().startswith(str(work / "venv")), three
    port = free_port()
    server = subprocess.Popen([str(work / "venv" / "bin" / "sightplan"), "serve", "--sample", "--port", str(port),
                               "--data", str(work / "data")], cwd=empty, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True, env=ALONE)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 180  # --sample makes the sample project first
        while True:
            try:
                urllib.request.urlopen(url + "/api/info", timeout=2)
                break
            except OSError:
                assert server.poll() is None and time.monotonic() < deadline, server.stdout.read()
                time.sleep(0.3)
        with launch_browser() as browser:
            page = browser.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("response", lambda r: errors.append(f"{r.status} {r.url}") if r.status >= 400 else None)
            page.goto(url)
            page.wait_for_selector("body[data-state=ready]", timeout=60_000)
            assert "could not be loaded" not in page.inner_text("body")
            page.wait_for_function("window.sightplanTest.view.modelTriangles() > 20000", timeout=120_000)  # the Duplex
            names = page.evaluate("import('maplibre-gl').then((m) => [typeof m.Map, m.getVersion()])")
            assert names[0] == "function", names
            page.goto(url + "/docs")
            page.wait_for_selector(".swagger-ui .info .title", timeout=60_000)
            assert "sightplan" in page.inner_text(".swagger-ui .info .title")
            page.wait_for_selector(".opblock-summary-path")
            assert page.locator(".opblock-summary-path").count() > 50  # the operations, listed
            assert not errors, errors
    finally:
        server.terminate()
        server.wait(timeout=20)
