"""The ``warp-st`` subcommands, one module each; :mod:`warp_st.commands.cli` parses and dispatches."""
