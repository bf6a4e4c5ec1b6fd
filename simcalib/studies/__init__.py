"""Studies over many runs: sweeps, the paper's and the data's experiments, motion advice
and the benchmarks.
"""
