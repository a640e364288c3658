"""Acceleration structures over the 4D database: BVH build and the wide node layout."""
