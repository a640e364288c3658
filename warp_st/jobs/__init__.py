"""Many frames: render tasks, sequences and sweeps, the Dask farm."""
