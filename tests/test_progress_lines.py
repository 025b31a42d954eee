"""Progress where the output is not a terminal (a CI log, ``nohup``): every stage named, plain lines, and never more
than 2 s without one, even through a stage that says nothing for longer."""

from __future__ import annotations

import io
import sys
import time

import pytest
from rich.console import Console

from sightplan.cli.stages import StageDisplay
from test_caches_hold import two_boxes
from test_cli import run_cli


class Clocked(io.StringIO):
    """A non-terminal stream that notes when each line was written."""

    def __init__(self) -> None:
        super().__init__()
        self.lines: list[tuple[float, str]] = []

    def write(self, s: str) -> int:
        for line in s.splitlines():
            if line.strip():
                self.lines.append((time.monotonic(), line))
        return super().write(s)


def test_a_silent_stage_gets_heartbeats_that_name_it():
    out = Clocked()
    console = Console(file=out, width=200)
    with StageDisplay(console, {"tessellating": "tessellating products", "ties": "finding tie pairs"},
                      heartbeat_s=0.1) as display:
        display("reading", 0, 0, "quick.ifc")  # over before a heartbeat: no line
        display("tessellating", 3, 10, "after IfcWall 'W1'")
        time.sleep(0.35)
        display("tessellating", 10, 10)
        display("ties", 0, 0)
        time.sleep(0.15)
    text = [line for _, line in out.lines]
    assert not any(line.startswith("reading") for line in text)
    beats = [line for line in text if line.startswith("tessellating products: 3/10 — after IfcWall 'W1' (")]
    assert len(beats) >= 2 and "tessellating products: 10/10 (0 s)" in text
    assert text[-1] == "finding tie pairs: (0 s)"


def test_the_evaluate_command_writes_a_line_at_least_every_two_seconds(tmp_path, monkeypatch):
    """A cold load made 1.2 s slow and an evaluation with features made 2.2 s slow: the progress, not on a terminal,
    has a line at least every 2 s of the test's clock, from the command's start to its end, naming each slow stage;
    standard output holds none of it."""
    from sightplan.cli.base import err_console
    from sightplan.model import mesh

    evaluation = sys.modules["sightplan.evaluate"]
    real_features, real_load = evaluation.sample_features, mesh.load_mesh

    def slow_features(*args, **kwargs):
        time.sleep(2.2)
        return real_features(*args, **kwargs)

    def slow_load(*args, **kwargs):
        time.sleep(1.2)
        return real_load(*args, **kwargs)

    monkeypatch.setattr(evaluation, "sample_features", slow_features)
    monkeypatch.setattr(mesh, "load_mesh", slow_load)
    out = Clocked()
    monkeypatch.setattr(err_console, "file", out)  # progress goes to standard error
    model = two_boxes(tmp_path / "boxes.glb")
    start = time.monotonic()
    res = run_cli("evaluate", str(model), "--no-cache", "--ring-frames", "3", "--scale", "0.05", "--no-picture",
                  "--out", str(tmp_path / "out"), cwd=tmp_path)
    end = time.monotonic()
    assert res.returncode == 0, res.stderr
    assert "simulated features" not in res.stdout and "VC" in res.stdout
    stamps = [start] + [t for t, _ in out.lines] + [end]
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    text = "\n".join(line for _, line in out.lines)
    assert max(gaps) <= 2.0, (max(gaps), text)
    assert "reading: boxes.glb" in text and "simulated features: 0/1 (1 s)" in text, text
    assert "simulated features: 1/1 (2 s)" in text and "\x1b[" not in text  # plain words, no bar or colour codes


def _quiet_run(out: Clocked, *args: str, cwd) -> str:
    """``sightplan ARGS`` with its progress (standard error) in ``out``: the progress's text, after checking that it
    has a line at least every 2 s of the test's clock from its first line to its last, in plain words."""
    start = time.monotonic()
    res = run_cli(*args, cwd=cwd)
    end = time.monotonic()
    assert res.returncode == 0, res.stdout + res.stderr
    stamps = [t for t, _ in out.lines]
    text = "\n".join(line for _, line in out.lines)
    assert stamps and start <= stamps[0] and stamps[-1] <= end, text
    # from its first line to its last the command is in its stages, whose heartbeat is the promise tested; before
    # the first line (the command parsing its options, a cache read) and after the last (writing its files) it owes
    # nothing, and on a busy machine those can take seconds of the test's clock
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    worst = max(range(len(gaps)), key=gaps.__getitem__) if gaps else 0
    assert not gaps or gaps[worst] <= 2.0, f"{gaps[worst]:.2f} s after line {worst + 1} of {len(stamps)}:\n{text}"
    assert "\x1b[" not in text and text not in res.stdout
    return text


@pytest.fixture
def boxes_and_ring(tmp_path, monkeypatch):
    """The two boxes as a model, a ring of three small frames around them as plan.json, and the progress caught."""
    from sightplan.cli.base import err_console
    from sightplan.model.load import load_model
    from sightplan.plan.format import write_plan
    from sightplan.plan.ring import ring_plan
    from test_caches_hold import CAMERA

    model = two_boxes(tmp_path / "boxes.glb")
    scene, _ = load_model(model, cache=False)
    write_plan(ring_plan(scene, CAMERA, n_frames=3, distance_m=5.0), tmp_path / "plan.json")
    out = Clocked()
    monkeypatch.setattr(err_console, "file", out)
    return out


def _slowed(monkeypatch, module, name: str, seconds: float = 2.1) -> None:
    """``module.name`` made ``seconds`` slower, the first time it is called."""
    real, calls = getattr(module, name), []

    def slow(*args, **kwargs):
        if not calls:
            calls.append(1)
            time.sleep(seconds)
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, slow)


def test_the_render_command_writes_a_line_at_least_every_two_seconds(tmp_path, monkeypatch, boxes_and_ring):
    """Its first frame made 2.1 s slow: the rendering stage is named while it runs and when it ends."""
    from sightplan.loop import render

    _slowed(monkeypatch, render, "shade_frame")
    text = _quiet_run(boxes_and_ring, "render", "boxes.glb", "plan.json", "-o", "images", "--scale", "0.5",
                      "--no-cache", cwd=tmp_path)
    assert "rendering frames: 0/3 (1 s)" in text and "rendering frames: 3/3 (2 s)" in text, text


def test_the_progress_command_writes_a_line_at_least_every_two_seconds(tmp_path, monkeypatch, boxes_and_ring):
    """The first date's features made 2.1 s slow: the stage is named, with the date it is evaluated at."""
    _slowed(monkeypatch, sys.modules["sightplan.evaluate"], "sample_features")
    text = _quiet_run(boxes_and_ring, "progress", "boxes.glb", "plan.json", "--date", "2020-01-01", "--date",
                      "2020-02-01", "--scale", "0.5", "--no-cache", "--out", "p", cwd=tmp_path)
    assert "simulated features: 0/1 — at 2020-01-01 (1 of 2 dates) (1 s)" in text, text
    assert "simulated features: 1/1 — at 2020-01-01 (1 of 2 dates) (2 s)" in text, text


def test_the_validate_command_writes_a_line_at_least_every_two_seconds(tmp_path, monkeypatch, boxes_and_ring):
    """The reality's sampling for Ct made 2.1 s slow: that stage is named while it runs."""
    sys.modules["sightplan.validate.run"]  # noqa: B018  (loaded by the package)
    _slowed(monkeypatch, sys.modules["sightplan.validate.run"], "_recall")
    text = _quiet_run(boxes_and_ring, "validate", "boxes.glb", "plan.json", "boxes.glb", "-e", "0.05", "--scale",
                      "0.5", "--no-cache", "--out", "v", cwd=tmp_path)
    assert "sampling the model's surfaces (Ct): (1 s)" in text, text
