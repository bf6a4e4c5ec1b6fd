"""Hand-eye solvers: the dual-quaternion methods of Dekel et al. (CVPR 2020) and classics.

``available()`` lists the registered method names; ``get(name)`` returns their metadata.
"""

from simcalib.solvers.registry import available, get, infos, register

__all__ = ["available", "get", "infos", "register"]
