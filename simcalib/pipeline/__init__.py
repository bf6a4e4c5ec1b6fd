"""The simulated run: the scenario schema, its feasibility checks and the stages
(world -> pose streams -> motions -> solvers -> evaluation -> reports).
"""
