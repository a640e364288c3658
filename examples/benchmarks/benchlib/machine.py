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
    """The CPU's model name with its family and model numbers ("AMD EPYC (family 25, model
    17)": a virtual machine's name alone can be as vague as that): /proc/cpuinfo's, else
    ``lscpu``'s, else ``platform.processor()``, else "unknown"."""
    fields = {}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                fields.setdefault(key.strip().lower(), value.strip())
                if not line.strip():
                    break  # the first processor's block
    except OSError:
        pass
    if "model name" not in fields:
        try:
            out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=10).stdout
        except (OSError, subprocess.SubprocessError):
            out = ""
        for line in out.splitlines():
            key, _, value = line.partition(":")
            if key.strip().lower() in ("cpu family", "model", "model name"):
                fields.setdefault(key.strip().lower(), value.strip())
    name = fields.get("model name") or platform.processor() or "unknown"
    if fields.get("cpu family") and fields.get("model"):
        name += f" (family {fields['cpu family']}, model {fields['model']})"
    return name


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
