"""The package version, written into every EXR header and printed by ``warp-st --version``."""
__version__ = "0.10.5"
