"""Foundation: conventions, float64 kinematics, the host scene model, frame lists, limits.

Imports nothing else of warp_st; every other layer may import it.
"""
