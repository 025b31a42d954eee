"""What the browser tests of the web page share: Debian's Chromium through Playwright (headless, WebGL on SwiftShader),
``sightplan serve`` in a subprocess on a free loopback port with a small JSON client, opening the page, and
screenshots under ``$SIGHTPLAN_TEST_ARTIFACTS`` (default ``test-artifacts/browser/``)."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from web_support import free_port

CHROMIUM = Path("/usr/bin/chromium")
REPO = Path(__file__).resolve().parents[1]
ARTIFACTS = Path(os.environ.get("SIGHTPLAN_TEST_ARTIFACTS") or REPO / "test-artifacts" / "browser")
# WebGL in headless Chromium without a GPU: ANGLE on SwiftShader (software Vulkan)
GL_ARGS = ["--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"]
VIEWPORT = {"width": 1600, "height": 1000}


def missing(reason: str):
    """In CI a missing browser is a failure, not a skip."""
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI must run the browser tests)")
    pytest.skip(reason)


@contextmanager
def launch_browser() -> Iterator:
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        missing("playwright is not installed (pip install -e '.[dev]')")
    if not CHROMIUM.exists():
        missing("Debian's chromium is not installed (`make setup` installs it as root)")
    args = GL_ARGS + (["--no-sandbox"] if hasattr(os, "geteuid") and os.geteuid() == 0 else [])
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=args)
        try:
            yield b
        finally:
            b.close()




class Server:
    """``sightplan serve`` in a subprocess, with a JSON client for the checks (``token``: sent as a bearer token)."""

    def __init__(self, data: Path, extra_args: tuple[str, ...] = ()) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.output: list[str] = []
        self.token: str | None = None
        self.proc = subprocess.Popen([sys.executable, "-m", "sightplan", "serve", "--port", str(self.port), "--data",
                                      str(data), *extra_args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        self.reader = threading.Thread(target=lambda: self.output.extend(self.proc.stdout), daemon=True)  # type: ignore[arg-type]
        self.reader.start()
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and self.proc.poll() is None:
            try:
                self.get("/api/info")
                return
            except OSError:
                time.sleep(0.2)
        self.stop()
        raise AssertionError("the server did not start:\n" + "".join(self.output))

    def request(self, method: str, path: str, body: dict | None = None, raw: bytes | None = None,
                headers: dict | None = None):
        data = raw if raw is not None else (json.dumps(body).encode() if body is not None else None)
        auth = {"Authorization": f"Bearer {self.token}"} if self.token else {}
        req = urllib.request.Request(self.url + path, data=data, method=method,
                                     headers={"Content-Type": "application/json", **auth, **(headers or {})})
        with urllib.request.urlopen(req, timeout=120) as r:
            content = r.read()
            return json.loads(content) if content else None

    def get(self, path: str):
        return self.request("GET", path)

    def status(self, path: str) -> int:
        """The HTTP status of a GET (errors included)."""
        try:
            with urllib.request.urlopen(self.url + path, timeout=60) as r:
                return r.status
        except urllib.error.HTTPError as err:
            return err.code

    def wait_job(self, job_id: int, timeout_s: float = 120.0) -> dict:
        deadline = time.monotonic() + timeout_s
        while True:
            job = self.get(f"/api/jobs/{job_id}")
            if job["status"] in ("done", "failed"):
                return job
            assert time.monotonic() < deadline, f"job {job_id} is still {job['status']}"
            time.sleep(0.2)

    def upload(self, path: str, name: str, content: bytes, fields: dict | None = None):
        boundary = "sightplanboundary"
        parts = [f"--{boundary}\r\nContent-Disposition: form-data; name=\"{k}\"\r\n\r\n{v}\r\n".encode()
                 for k, v in (fields or {}).items()]
        parts.append(f"--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"{name}\"\r\n"
                     "Content-Type: application/octet-stream\r\n\r\n".encode() + content + b"\r\n")
        body = b"".join(parts) + f"--{boundary}--\r\n".encode()
        return self.request("POST", path, raw=body, headers={"Content-Type": f"multipart/form-data; boundary={boundary}"})

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.reader.join(timeout=5)


# the page's progress bar, watched from outside the page's code: every value it shows
WATCH_PROGRESS = """
window.__progress = [];
document.addEventListener('DOMContentLoaded', () => {
  const bar = document.getElementById('eval-progress');
  new MutationObserver(() => {
    if (!bar.hidden) window.__progress.push(Number(bar.getAttribute('aria-valuenow')));
  }).observe(bar, { attributes: true, attributeFilter: ['aria-valuenow', 'hidden'] });
});
"""


def open_page(browser, server, init_script: str | None = None, wait_ready: bool = True, viewport: dict | None = None):
    """A fresh browser context on the page (``viewport``: default VIEWPORT): (context, page, problems), problems being
    page errors and console errors (other than failed loads answered 404)."""
    # the tests' own probes (wait_for_function with an expression) are evaluated as strings, which the page's
    # Content-Security-Policy forbids; test_page_runs_under_its_content_security_policy opens it without bypass
    ctx = browser.new_context(viewport=viewport or VIEWPORT, accept_downloads=True, bypass_csp=True)
    ctx.add_init_script(WATCH_PROGRESS)
    if init_script:
        ctx.add_init_script(init_script)
    page = ctx.new_page()
    problems: list[str] = []
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error"
            and "404" not in m.text else None)
    page.goto(server.url + "/")
    if wait_ready:
        page.wait_for_function("document.body?.dataset.state === 'ready'", timeout=30_000)
    return ctx, page, problems


def element_on_screen(page, elements: list[int]) -> dict | None:
    """The first of ``elements`` a click in the 3D view reaches: ``{"e", "x", "y"}`` (client pixels), or None."""
    return page.evaluate("""(elements) => {
        for (const e of elements) {
          const p = window.sightplanTest.view.elementScreenPoint(e);
          if (p) return { e, ...p };
        }
        return null; }""", elements)


def shot(page, artifacts: Path, name: str) -> np.ndarray:
    """A screenshot saved as ``name``.png, as an (H, W, 3) int array."""
    from PIL import Image

    png = page.screenshot(path=str(artifacts / f"{name}.png"))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def view_pixels(page, rgb: np.ndarray) -> np.ndarray:
    """The 3D view's part of a screenshot, without its toolbars."""
    box = page.locator("#canvas-box").bounding_box()
    return rgb[int(box["y"]) + 60:int(box["y"] + box["height"]) - 40, int(box["x"]):int(box["x"] + box["width"]) - 200]
