"""Pure Warp device code: intersection, traversal, shading and the render kernel."""
from warp_st.kernels.render_kernel import Kernels, get_kernels

__all__ = ["Kernels", "get_kernels"]
