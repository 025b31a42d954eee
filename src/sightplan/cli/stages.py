"""Progress of a command's stages: live bars on a terminal, plain lines anywhere else (a CI log, ``nohup``).

Progress goes to standard error, so standard output holds only what the command prints (its tables, its JSON).
Every stage is named. Where the output is not a terminal a line is written when a stage starts and ends, as it
advances (at most one a second), and, while a stage is silent (one long product, a kernel running), a heartbeat
line at least every :data:`HEARTBEAT_S` seconds that says what runs and for how long.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

HEARTBEAT_S = 1.0  # a silent stage gets a line this often (well under the 2 s a reader waits at most)
_MIN_LINE_S = 1.0  # an advancing stage writes at most a line this often


class StageDisplay:
    """A ``progress(stage, done, total, note='')`` callback for a command's stages; use it as a context manager.

    ``names`` maps a stage's key to the words shown (the key itself otherwise). ``total`` 0 means a stage without
    a count. ``note``: a few words shown after the count (the product tessellated last, an ETA).
    """

    def __init__(self, console: Console, names: Mapping[str, str] | None = None, *, transient: bool = True,
                 heartbeat_s: float = HEARTBEAT_S) -> None:
        self.console = progress_console(console)
        self.names = dict(names or {})
        self.plain = not console.is_terminal
        self.heartbeat_s = heartbeat_s
        self._transient = transient
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar: Progress | None = None
        self._tasks: dict[str, int] = {}
        self._current: tuple[str, int, int, str] | None = None
        self._started = self._last_line = time.monotonic()
        self._finished: set[str] = set()

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
            new = self._current is None or self._current[0] != stage
            if new:
                self._started = now
                self._finished.discard(stage)
            self._current = (stage, done, total, note)
            if self._bar is not None:
                if stage not in self._tasks:
                    self._tasks[stage] = self._bar.add_task(self.name(stage), total=total or None, note=note)
                self._bar.update(self._tasks[stage], completed=done, total=total or None, note=note)
                return
            finished = total > 0 and done >= total
            if finished and stage in self._finished:
                return
            if new or finished or now - self._last_line >= _MIN_LINE_S:
                if finished:
                    self._finished.add(stage)
                self._line(stage, done, total, note, now)

    def _line(self, stage: str, done: int, total: int, note: str, now: float, heartbeat: bool = False) -> None:
        """One plain line (the lock is held)."""
        count = f" {done:,}/{total:,}" if total > 0 else ""
        tail = (f" — {note}" if count else f" {note}") if note else ""
        running = f" ({now - self._started:.0f} s)" if heartbeat or (total > 0 and done >= total) else ""
        self.console.print(f"{self.name(stage)}:{count}{tail}{running}", highlight=False, markup=False,
                           soft_wrap=True)
        self._last_line = now

    def _beat(self) -> None:
        while not self._stop.wait(min(0.25, self.heartbeat_s / 4)):
            now = time.monotonic()
            with self._lock:
                if self._current is None or now - self._last_line < self.heartbeat_s:
                    continue
                stage, done, total, note = self._current
                if total > 0 and done >= total:  # between stages: what runs has no name of its own
                    self.console.print(f"after {self.name(stage)}: working ({now - self._started:.0f} s)",
                                       highlight=False, markup=False, soft_wrap=True)
                    self._last_line = now
                    continue
                self._line(stage, done, total, note, now, heartbeat=True)


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
