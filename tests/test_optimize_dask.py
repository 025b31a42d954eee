"""The optimiser's candidates cast on a dask cluster: the same plan as a local run, the per-frame cache read here
(only its misses go to the cluster, whose frames are stored), a clear error for an unreachable scheduler; and the
budget's whole numbers."""

from __future__ import annotations

import socket

import numpy as np
import pytest
import trimesh

from optimize_support import CAM, box_building  # noqa: E402
from sightplan.distributed import evaluate_distributed
from sightplan.errors import PlanError, SightplanError
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.scene import Scene
from sightplan.observations.table import Observations
from sightplan.optimize import Budget, OptimizeSettings, Targets, optimize
from sightplan.plan.checks.feasibility import FlightSettings
from sightplan.plan.ring import ring_plan

FLIGHT = FlightSettings(safety_distance_m=10.0)
SCALE = 0.25


@pytest.fixture(scope="module")
def box() -> Scene:
    return box_building()


@pytest.fixture(scope="module")
def local(box):
    """The plan optimised here, without a cache."""
    return optimize(box, CAM, Targets(k=2), flight=FLIGHT, settings=OptimizeSettings(scale=SCALE, cache_dir=False))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _same_plan(a, b) -> None:
    assert len(a.plan) == len(b.plan) and len(a.plan.missions) == len(b.plan.missions)
    assert np.array_equal(a.plan.C_world, b.plan.C_world)
    assert np.array_equal(a.plan.R_world_camera, b.plan.R_world_camera)
    assert np.array_equal(a.met, b.met) and a.plan.parameters["candidates"] == b.plan.parameters["candidates"]


# ---------------------------------------------------------------------------------------------------- the budget
@pytest.mark.parametrize("bad", [{"frames": 2.5}, {"frames": True}, {"frames": False}, {"frames": 0},
                                 {"frames": -3}, {"frames": float("inf")}, {"frames": "3"}, {"batteries": 1.5},
                                 {"batteries": True}, {"batteries": np.bool_(True)}, {"minutes": True},
                                 {"minutes": 0}, {"minutes": float("nan")}, {"minutes": float("inf")},
                                 {"minutes": "2"}])
def test_a_budget_is_whole_frames_and_batteries_and_a_real_number_of_minutes(bad):
    name = next(iter(bad))
    with pytest.raises(PlanError, match=f"budget's {name} must be"):
        Budget(**bad)


def test_a_whole_valued_float_is_taken_as_its_whole_number():
    b = Budget(frames=3.0, minutes=np.float64(2.5), batteries=np.int64(2))
    assert (b.frames, b.minutes, b.batteries) == (3, 2.5, 2)
    assert type(b.frames) is int and type(b.batteries) is int and type(b.minutes) is float
    assert Budget(minutes=2).minutes == 2


def test_the_command_line_refuses_a_budget_of_no_frames_before_loading_anything(tmp_path):
    from typer.testing import CliRunner

    from sightplan.cli.main import app

    for value in ("0", "-2"):
        r = CliRunner().invoke(app, ["optimize", str(tmp_path / "absent.obj"), "--budget-frames", value,
                                     "-o", str(tmp_path / "plan.json")], env={"COLUMNS": "200"})
        assert r.exit_code == 2 and f"frames must be a whole number ≥ 1, got {value}" in r.output, r.output
        assert "absent.obj" not in r.output and not (tmp_path / "plan.json").exists()


# ---------------------------------------------------------------------------------------------------- the cluster
try:
    import distributed
except ImportError:  # the cluster extra is not installed
    distributed = None

needs_dask = pytest.mark.skipif(distributed is None, reason="needs the cluster extra (dask.distributed)")


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as lc, \
            distributed.Client(lc) as c:
        yield c


def _cast_tasks(stream) -> int:
    return sum(t["key"].startswith("observe_frames") if isinstance(t["key"], str) else
               str(t["key"][0]).startswith("observe_frames") for t in stream.data)


@needs_dask
def test_cached_frames_are_read_here_and_only_the_others_cast_on_the_cluster(box, client, tmp_path):
    """The even frames of a ring are cached first; the whole ring then casts only the odd ones on the cluster, in
    their places, and the table is the local evaluation's bit for bit; a third run casts nothing."""
    plan = ring_plan(box, CAM, n_frames=10, distance_m=12.0)
    settings = EvaluationSettings(scale=SCALE)
    here = evaluate(box, plan, settings, cache_dir=False)
    cache = tmp_path / "cache"
    even = evaluate_distributed(box, plan.subset(np.arange(0, 10, 2)), settings, cluster=client, cache_dir=cache)
    assert even.timings["frames_cast"] == 5 and even.cache_hits == 0
    seen: list[tuple[int, int]] = []
    with distributed.get_task_stream(client) as stream:
        ev = evaluate_distributed(box, plan, settings, cluster=client, batch_frames=2, cache_dir=cache,
                                  progress=lambda i, n: seen.append((i, n)))
    assert ev.cache_hits == 5 and ev.timings["frames_cast"] == 5 and ev.timings["batches"] == 3
    assert _cast_tasks(stream) == 3 and seen[0] == (5, 10) and seen[-1] == (10, 10)
    for name in Observations._ARRAYS:
        assert np.array_equal(getattr(here.observations, name), getattr(ev.observations, name)), name
    assert ev.observations.meta == here.observations.meta and ev.metrics.plan == here.metrics.plan
    with distributed.get_task_stream(client) as stream:
        again = evaluate_distributed(box, plan, settings, cluster=client, cache_dir=cache)
    assert again.cache_hits == 10 and again.timings["frames_cast"] == 0 and _cast_tasks(stream) == 0
    assert again.metrics.plan == here.metrics.plan


@needs_dask
def test_the_optimiser_on_a_cluster_makes_the_local_plan_and_a_second_run_casts_nothing(box, client, local, tmp_path):
    settings = OptimizeSettings(scale=SCALE, cache_dir=tmp_path / "cache", cluster=client, batch_frames=16)
    with distributed.get_task_stream(client) as stream:
        first = optimize(box, CAM, Targets(k=2), flight=FLIGHT, settings=settings)
    pool = first.plan.parameters["candidates"]
    assert _cast_tasks(stream) >= -(-pool // 16) > 1  # the candidates went to the cluster, 16 a task
    _same_plan(first, local)
    assert first.n_met == 5 and first.report.ok
    stages: list[str] = []
    with distributed.get_task_stream(client) as stream:
        second = optimize(box, CAM, Targets(k=2), Budget(frames=6), flight=FLIGHT, settings=settings,
                          progress=lambda stage, i, n: stages.append(stage))
    assert _cast_tasks(stream) == 0  # every candidate from the cache
    assert "casting candidates" in stages and len(second.plan) <= 6
    assert client.status == "running"  # a client passed in stays open


@needs_dask
def test_an_unreachable_scheduler_is_one_clear_error(box):
    address = f"tcp://127.0.0.1:{_free_port()}"
    settings = OptimizeSettings(scale=SCALE, cache_dir=False, cluster=address)
    with pytest.raises(SightplanError, match=f"cannot reach the dask scheduler at {address}"):
        optimize(box, CAM, Targets(k=2), flight=FLIGHT, settings=settings)


@needs_dask
@pytest.mark.bench  # make bench; the web server optimises on a local cluster in make test
def test_the_command_line_optimises_on_a_local_cluster(local, tmp_path):
    """`sightplan optimize --cluster local:1` writes the plan the library makes here."""
    from typer.testing import CliRunner

    from sightplan.cli.main import app
    from sightplan.plan.format import read_plan

    mesh = trimesh.creation.box((8, 8, 8))
    mesh.apply_translation((4, 4, 4))
    model = tmp_path / "box.obj"
    mesh.export(model)
    plans = []
    for name, extra in (("here", []), ("cluster", ["--cluster", "local:1", "--batch-frames", "32"])):
        out = tmp_path / f"{name}.json"
        r = CliRunner().invoke(app, ["optimize", str(model), "--k", "2", "--no-compare", "--no-cache", "--scale",
                                     "0.05", "--budget-frames", "8", "-o", str(out), *extra], env={"COLUMNS": "200"})
        assert r.exit_code == 0, r.output
        assert "targets met: 1 of 1 elements" in r.output
        plans.append(read_plan(out))
    assert len(plans[0]) == len(plans[1]) <= 8
    assert np.array_equal(plans[0].C_world, plans[1].C_world)
    r = CliRunner().invoke(app, ["optimize", str(model), "--cluster", "local:1", "--batch-frames", "0",
                                 "-o", str(tmp_path / "x.json")], env={"COLUMNS": "200"})
    assert r.exit_code == 2 and "--batch-frames" in r.output
