"""Progress of a command's stages: live bars on a terminal, plain lines anywhere else (a CI log, ``nohup``).

Progress goes to standard error, so standard output holds only what the command prints (its tables, its JSON).
Every stage is named. Where it is not a terminal, a quick command writes nothing; once :data:`HEARTBEAT_S` passes
without a line, a line says which stage runs, how far it is (with its note: the product tessellated last, an ETA)
and for how long, and so on at least every :data:`HEARTBEAT_S` seconds, even while a stage itself says nothing
(one long product, a kernel running); a stage that was shown gets a last line when it ends.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

HEARTBEAT_S = 1.0  # the longest silence where the output is not a terminal (well under the 2 s a reader waits)


class StageDisplay:
    """A ``progress(stage, done, total, note='')`` callback for a command's stages; use it as a context manager.

    ``names`` maps a stage's key to the words shown (the key itself otherwise). ``total`` 0 means a stage without
    a count. ``note``: a few words shown after the count.
    """

    def __init__(self, console: Console, names: Mapping[str, str] | None = None, *, transient: bool = True,
                 heartbeat_s: float = HEARTBEAT_S) -> None:
        self.console = progress_console(console)
        self.names = dict(names or {})
        self.plain = not self.console.is_terminal
        self.heartbeat_s = heartbeat_s
        self._transient = transient
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar: Progress | None = None
        self._tasks: dict[str, int] = {}
        self._current: tuple[str, int, int, str] | None = None
        self._started = self._last_line = time.monotonic()
        self._shown = False  # whether the current stage has had a line

    def __enter__(self) -> StageDisplay:
        if self.plain:
            self._thread = threading.Thread(target=self._beat, name="sightplan-heartbeat", daemon=True)
            self._thread.start()
        else:
            self._bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                 TextColumn("{task.fields[note]}"), TimeElapsedColumn(), console=self.console,
                                 transient=self._transient)
            self._bar.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self._bar is not None:
            self._bar.__exit__(None, None, None)

    def name(self, stage: str) -> str:
        return self.names.get(stage, stage)

    def __call__(self, stage: str, done: int, total: int, note: str = "") -> None:
        now = time.monotonic()
        with self._lock:
            if self._bar is not None:
                if stage not in self._tasks:
                    self._tasks[stage] = self._bar.add_task(self.name(stage), total=total or None, note=note)
                self._bar.update(self._tasks[stage], completed=done, total=total or None, note=note)
                return
            if self._current is None or self._current[0] != stage:
                self._started, self._shown = now, False
            was_done = self._current is not None and self._current[0] == stage and self._current[2] > 0 and \
                self._current[1] >= self._current[2]
            self._current = (stage, done, total, note)
            if self._shown and total > 0 and done >= total and not was_done:
                self._line(now)  # a stage that was shown ends with a line of its own

    def _line(self, now: float) -> None:
        """The current stage's line (the lock is held)."""
        assert self._current is not None
        stage, done, total, note = self._current
        count = f" {done:,}/{total:,}" if total > 0 else ""
        tail = (f" — {note}" if count else f" {note}") if note else ""
        self.console.print(f"{self.name(stage)}:{count}{tail} ({now - self._started:.0f} s)", highlight=False,
                           markup=False, soft_wrap=True)
        self._last_line, self._shown = now, True

    def _beat(self) -> None:
        while not self._stop.wait(min(0.25, self.heartbeat_s / 4)):
            now = time.monotonic()
            with self._lock:
                if self._current is None or now - self._last_line < self.heartbeat_s:
                    continue
                stage, done, total, _ = self._current
                if total > 0 and done >= total:  # between stages: what runs has no name of its own
                    self.console.print(f"after {self.name(stage)}: working ({now - self._started:.0f} s)",
                                       highlight=False, markup=False, soft_wrap=True)
                    self._last_line = now
                else:
                    self._line(now)


def progress_console(console: Console) -> Console:
    """Where progress goes: standard error when ``console`` writes to standard output, else ``console`` itself."""
    from .base import err_console

    return err_console if console.file is sys.stdout else console


@contextmanager
def step(console: Console, text: str) -> Iterator[None]:
    """One step without a count ("drawing the overview"): a spinner on a terminal, else a line and heartbeats."""
    console = progress_console(console)
    if console.is_terminal:
        with console.status(text):
            yield
        return
    with StageDisplay(console) as display:
        display(text, 0, 0)
        yield
