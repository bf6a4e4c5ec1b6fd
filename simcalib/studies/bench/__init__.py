"""Benchmarks: solver timings and throughput (``solvers``), visual pose accuracy per
path, effect and target (``vision``, ``boards``).
"""
