"""``python -m warp_st``: the ``warp-st`` command line."""
from .cli import main

raise SystemExit(main())
