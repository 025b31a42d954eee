"""Evaluation on a dask cluster: bit-identical to the local pipeline, clear errors, the CLI path."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from sightplan import distributed as sp_distributed  # noqa: E402
from sightplan.camera.catalogue import get_camera  # noqa: E402
from sightplan.distributed import evaluate_distributed  # noqa: E402
from sightplan.errors import SightplanError  # noqa: E402
from sightplan.evaluate import EvaluationSettings, evaluate  # noqa: E402
from sightplan.model.load import load_model  # noqa: E402
from sightplan.observations.table import Observations  # noqa: E402
from sightplan.plan.ring import ring_plan  # noqa: E402

SETTINGS = EvaluationSettings(scale=0.1)


@pytest.fixture(scope="module")
def client():
    lc = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = distributed.Client(lc)
    try:
        yield c
    finally:
        c.close()
        try:
            lc.close(timeout=60)
        except TimeoutError:  # on a busy machine a worker outlives its nanny's few seconds of grace and is killed
            pass


@pytest.fixture(scope="module")
def duplex():
    scene, _ = load_model("sample")
    return scene, ring_plan(scene, get_camera("p4p"), n_frames=12)


@pytest.fixture(scope="module")
def local(duplex):
    scene, plan = duplex
    return evaluate(scene, plan, SETTINGS, cache_dir=False)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.bench  # make bench; the web server's cluster tests cast on a local cluster in make test
def test_batches_on_two_workers_equal_local(client, duplex, local):
    scene, plan = duplex
    seen: list[tuple[int, int]] = []
    ev = evaluate_distributed(scene, plan, SETTINGS, cluster=client, batch_frames=5,
                              progress=lambda i, n: seen.append((i, n)))
    a, b = local.observations, ev.observations
    assert b.n_frames == a.n_frames == 12 and b.n_features == a.n_features
    for name in Observations._ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and np.array_equal(x, y), name
    assert b.meta == a.meta
    assert ev.metrics.plan == local.metrics.plan
    for name in ("VR", "visible", "observed", "pixels_total", "frames_observed"):
        assert np.array_equal(getattr(ev.metrics.elements, name), getattr(local.metrics.elements, name)), name
    for name in ("R", "O"):
        assert np.array_equal(getattr(ev.metrics.elements, name), getattr(local.metrics.elements, name), equal_nan=True)
    assert ev.engine == local.engine and ev.n_features == local.n_features
    assert ev.timings["batches"] == 3 and ev.timings["workers"] == 2 and ev.timings["frames"] == 12
    assert sorted(seen) == seen and seen[-1] == (12, 12) and len(seen) == 3
    assert client.status == "running"  # a client passed in stays open


def test_engine_built_once_per_worker(client, duplex, local):
    scene, plan = duplex
    ev = evaluate_distributed(scene, plan, SETTINGS, cluster=client, batch_frames=2)
    assert ev.metrics.plan == local.metrics.plan
    cached = client.run(lambda: len(sp_distributed._engines))
    assert set(cached.values()) <= {1}


def test_gl_engine_on_two_workers_equals_local(client, duplex):
    """The OpenGL engine in worker processes (llvmpipe in CI): each worker makes its own context,
    and its fixed-point sums merge bit for bit with a local run."""
    from sightplan.engines import gl

    if not gl.available():
        pytest.skip(gl.probe()["error"])
    scene, plan = duplex
    settings = EvaluationSettings(engine="gl", scale=0.05)
    here = evaluate(scene, plan, settings, cache_dir=False)
    there = evaluate_distributed(scene, plan, settings, cluster=client, batch_frames=4)
    assert there.engine == here.engine == "gl"
    for name in Observations._ARRAYS:
        assert np.array_equal(getattr(here.observations, name), getattr(there.observations, name)), name
    assert there.metrics.plan == here.metrics.plan


def test_unreachable_scheduler_is_a_clear_error(duplex):
    scene, plan = duplex
    address = f"tcp://127.0.0.1:{_free_port()}"
    with pytest.raises(SightplanError, match="127.0.0.1"):  # after CONNECT_TIMEOUT_S, not a hang
        evaluate_distributed(scene, plan.subset(np.arange(2)), SETTINGS, cluster=address)


def test_bad_arguments(client, duplex):
    scene, plan = duplex
    with pytest.raises(SightplanError, match="per batch"):
        evaluate_distributed(scene, plan, SETTINGS, cluster=client, batch_frames=0)
    with pytest.raises(SightplanError, match="no frames"):
        evaluate_distributed(scene, plan.subset(np.zeros(0, int)), SETTINGS, cluster=client)
    with pytest.raises(SightplanError, match="local:N"):
        evaluate_distributed(scene, plan, SETTINGS, cluster="local:zero")


@pytest.mark.bench  # the command line on a local cluster (20 s); test_batches_on_two_workers_equal_local stays in make test
def test_cli_cluster_matches_local(tmp_path: Path):
    env = {**os.environ, "COLUMNS": "120"}
    reports = []
    for name, extra in (("local", []), ("cluster", ["--cluster", "local:2", "--batch-frames", "4"])):
        out = tmp_path / name
        res = subprocess.run([sys.executable, "-m", "sightplan", "evaluate", "sample", "--ring-frames", "6", "--scale", "0.05",
                              "--no-picture", "--no-cache", "--out", str(out), *extra],
                             capture_output=True, text=True, env=env, timeout=300)
        assert res.returncode == 0, res.stderr + res.stdout
        reports.append(json.loads((out / "report.json").read_text()))
    assert reports[1]["metrics"] == reports[0]["metrics"]
    assert reports[1]["timings"]["batches"] == 2
