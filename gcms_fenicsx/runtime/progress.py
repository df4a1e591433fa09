"""Progress lines for stages that take more than a few seconds: timestamped, on stderr, rank 0."""
from __future__ import annotations

import sys
import time
from typing import Callable

Progress = Callable[[str], None]


def quiet(message: str) -> None:
    """A Progress that says nothing."""


def progress_printer(rank: int = 0) -> Progress:
    """Print ``[  12.3 s] message`` to stderr, on rank 0 only."""
    start = time.perf_counter()

    def report(message: str) -> None:
        if rank == 0:
            print(f"[{time.perf_counter() - start:7.1f} s] {message}", file=sys.stderr, flush=True)

    return report
