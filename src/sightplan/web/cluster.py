"""The server's dask cluster (``sightplan serve --cluster``): one client for the server's life.

Evaluations and optimisations cast their frames on the workers (:func:`~sightplan.distributed.evaluate_distributed`);
a model's preparation runs there as one task (:func:`~sightplan.distributed.prepare_model`), which reads the stored
file and writes the scene cache in the data folder, so every worker needs that folder at the same path. The job
threads stay in the server: they write the progress, and stop (cancelling their tasks) when a job is cancelled or
the server stops.
"""

from __future__ import annotations

import os
import threading
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING

from ..distributed import PROGRESS_TOPIC, connect

if TYPE_CHECKING:
    from distributed import Client


class ServerCluster:
    """A client for ``address`` (``tcp://host:8786``, or ``local:N`` for N worker processes started here and stopped
    by :meth:`close`); raises :class:`~sightplan.errors.SightplanError` in one line when the scheduler cannot be
    reached."""

    def __init__(self, address: str) -> None:
        self.address = address
        self._stack = ExitStack()
        self.client: Client = connect(address, self._stack)
        self._progress: dict[str, float] = {}
        self._lock = threading.Lock()
        try:
            self.client.subscribe_topic(PROGRESS_TOPIC, self._on_progress)
        except BaseException:
            self._stack.close()
            raise

    def _on_progress(self, event) -> None:
        _, (key, share) = event
        with self._lock:
            self._progress[str(key)] = float(share)

    def progress_of(self, key: str) -> float | None:
        """The share done that task ``key`` last reported (None before its first report)."""
        with self._lock:
            return self._progress.get(str(key))

    def forget(self, key: str) -> None:
        with self._lock:
            self._progress.pop(str(key), None)

    def workers(self) -> int:
        """The workers connected now."""
        return len(self.client.nthreads())

    def workers_without(self, folder: Path) -> list[str]:
        """The addresses of the connected workers that do not see ``folder``."""
        seen = self.client.run(os.path.isdir, str(folder))
        return sorted(addr for addr, ok in seen.items() if not ok)

    def close(self) -> None:
        """Close the client (the cluster's tasks for this server are released), and a ``local:N`` cluster."""
        self._stack.close()
