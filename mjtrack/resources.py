"""What the machine has: memory available now, for the work estimates made before a run.

No mjtrack import: every layer may use it.
"""

from __future__ import annotations


def available_memory() -> float | None:
    """MemAvailable of ``/proc/meminfo`` [bytes], or None where there is none (not Linux)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def gigabytes(n_bytes: float) -> str:
    """``n_bytes`` as a short text in GB (``2.4 GB``)."""
    return f"{n_bytes / 1e9:.3g} GB"
