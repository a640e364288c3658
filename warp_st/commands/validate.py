"""``warp-st validate``: load a stage and report what it contains."""
from __future__ import annotations

from pathlib import Path

from .common import UsageError
from .load import load


def add_arguments(parser) -> None:
    """The options of ``warp-st validate``."""
    parser.add_argument("scene", metavar="SCENE.usda")
    parser.add_argument("--no-references", action="store_true",
                        help="compose only the file's own layers: ignore references and payloads")


def run(args) -> int:
    scene_path = Path(args.scene)
    if not scene_path.is_file():
        raise UsageError(f"{scene_path}: no such file")
    scene = load(scene_path, args.no_references)
    print(f"ok: {len(scene.bodies)} bodies, {len(scene.cameras)} cameras, {len(scene.lights)} lights")
    return 0
