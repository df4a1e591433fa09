"""What this machine has for a run: the memory it can allocate now. Pure Python."""
from __future__ import annotations

import os


def available_memory_bytes() -> float:
    """MemAvailable of /proc/meminfo (what can be allocated without swapping), else the
    physical memory."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
