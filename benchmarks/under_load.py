"""Run a command while other processes keep every core busy: ``python benchmarks/under_load.py [--workers N] --
COMMAND...``. The suite must pass on a loaded machine too (a CI runner shared with other jobs, a laptop compiling);
this is how that is shown. Each worker is a process that spins on arithmetic, at normal priority, for as long as
the command runs. Prints the command's wall time, the load's, and exits with the command's status."""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import subprocess
import sys
import time


def spin(stop) -> None:
    x = 0
    while not stop.is_set():
        for i in range(100_000):
            x = (x * 31 + i) % 1_000_003


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2 * (os.cpu_count() or 1),
                        help="busy processes (default: twice the cores)")
    parser.add_argument("command", nargs=argparse.REMAINDER, help="the command, after --")
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give the command to run after --")
    stop = mp.Event()
    workers = [mp.Process(target=spin, args=(stop,), daemon=True) for _ in range(args.workers)]
    for w in workers:
        w.start()
    start = time.monotonic()
    try:
        status = subprocess.call(command)
    finally:
        stop.set()
        for w in workers:
            w.join(5)
    wall = time.monotonic() - start
    print(f"under_load: {' '.join(command)} exited {status} after {wall:.0f} s wall, with {args.workers} busy "
          f"processes on {os.cpu_count()} cores", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
