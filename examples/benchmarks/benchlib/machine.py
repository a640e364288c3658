"""What a benchmark reports about the machine it ran on, and medians of repeated timings."""
from __future__ import annotations

import datetime
import os
import platform
import statistics
import subprocess

import numpy as np


def summarize(values) -> dict:
    """{median, min, max, runs} of a list of timings."""
    values = list(values)
    return {"median": statistics.median(values), "min": min(values), "max": max(values), "runs": values}


def cpu_model() -> str:
    """The CPU's model name: /proc/cpuinfo's "model name", else ``lscpu``'s "Model name",
    else ``platform.processor()``, else "unknown"."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.SubprocessError):
        out = ""
    for line in out.splitlines():
        if line.strip().lower().startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def load_average() -> list[float]:
    """The 1, 5 and 15 minute load averages (NaN where the platform has none)."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return [float("nan")] * 3


def machine_info() -> dict:
    """CPU model, cores, versions, platform, load average and date (imports warp)."""
    import warp as wp

    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {
        "cpu": cpu_model(),
        "cpu_count": os.cpu_count(),
        "usable_cores": usable,
        "warp": wp.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "loadavg": load_average(),
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
    }
