"""Progress where the output is not a terminal (a CI log, ``nohup``): every stage named, plain lines, and never more
than 2 s without one, even through a stage that says nothing for longer."""

from __future__ import annotations

import io
import sys
import time

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
    with StageDisplay(console, {"tessellating": "tessellating products"}, heartbeat_s=0.1) as display:
        display("tessellating", 3, 10, "last done: IfcWall 'W1'")
        time.sleep(0.35)
        display("tessellating", 10, 10)
    text = [line for _, line in out.lines]
    assert text[0] == "tessellating products: 3/10 — last done: IfcWall 'W1'"
    beats = [line for line in text[1:-1] if line.startswith("tessellating products: 3/10 — last done: IfcWall 'W1' (")]
    assert len(beats) >= 2 and text[-1].startswith("tessellating products: 10/10 (")


def test_the_evaluate_command_writes_a_line_at_least_every_two_seconds(tmp_path, monkeypatch):
    """A cold load and an evaluation with features, the features made 2.2 s slow: the progress, not on a terminal,
    has a line at least every 2 s of the test's clock, from the command's start to its end, and names every stage;
    standard output holds none of it."""
    from sightplan.cli.base import err_console

    evaluation = sys.modules["sightplan.evaluate"]
    real = evaluation.sample_features

    def slow(*args, **kwargs):
        time.sleep(2.2)
        return real(*args, **kwargs)

    monkeypatch.setattr(evaluation, "sample_features", slow)
    out = Clocked()
    monkeypatch.setattr(err_console, "file", out)  # progress goes to standard error
    model = two_boxes(tmp_path / "boxes.glb")
    start = time.monotonic()
    res = run_cli("evaluate", str(model), "--no-cache", "--ring-frames", "3", "--scale", "0.05", "--no-picture",
                  "--out", str(tmp_path / "out"), cwd=tmp_path)
    end = time.monotonic()
    assert res.returncode == 0, res.stderr
    assert "casting frames" not in res.stdout and "VC" in res.stdout
    stamps = [start] + [t for t, _ in out.lines] + [end]
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    text = "\n".join(line for _, line in out.lines)
    assert max(gaps) <= 2.0, (max(gaps), text)
    for stage in ("reading", "finding tie pairs", "simulated features", "building the engine", "casting frames: 3/3"):
        assert stage in text, text
    assert "simulated features: 0/0" not in text and "\x1b[" not in text  # plain words, no bar or colour codes
