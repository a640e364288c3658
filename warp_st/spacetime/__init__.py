"""From a Scene to 4D geometry: visibility windows, temporal extrusion, adaptive tessellation."""
