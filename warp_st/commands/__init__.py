"""The ``warp-st`` subcommands, one module each; :mod:`warp_st.cli` parses and dispatches."""
