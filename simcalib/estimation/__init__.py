"""The one estimation path from two pose streams to X, its uncertainty and its verdict:

sampling (how the streams were stamped) -> reading and clock offset -> synchronised poses
-> motions -> outliers -> solve -> uncertainty, its consistency check, verdict.

:func:`simcalib.calibrate_streams.calibrate_streams` runs it; the modules here are its
stages: :mod:`~simcalib.estimation.sampling`, :mod:`~simcalib.estimation.motions`,
:mod:`~simcalib.estimation.consistency`, :mod:`~simcalib.estimation.verdict`.
"""
