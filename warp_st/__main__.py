"""``python -m warp_st``: the ``warp-st`` command line."""
from warp_st.commands.cli import main

raise SystemExit(main())
