"""One frame: the renderer, the NumPy-to-Warp crossing, camera parameters, the memory budget."""
