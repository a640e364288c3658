"""Content hashes of stage files: the identity a sequence, a farm worker and ``--resume`` check."""
from __future__ import annotations

from pathlib import Path

__all__ = ["file_hash"]


def file_hash(path: Path) -> str:
    """sha256 of the file's bytes (the stage's root layer), as ``sha256:HEX``."""
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return f"sha256:{digest.hexdigest()}"

