"""The one estimation path from two pose streams to X, its uncertainty and its verdict —
what ``simcalib calibrate`` runs on recorded files and ``simcalib run`` on its simulated
streams (``estimation.*``):

* :mod:`~simcalib.estimation.stamp_units` — the stamps' unit where both streams tell it
  (relative ms / us / ns) and :mod:`~simcalib.estimation.units` — the lengths' unit;
* :mod:`~simcalib.estimation.sampling` — how the streams were stamped (paired by stamp, or
  two clocks);
* :mod:`~simcalib.estimation.readings` — which reading of the files (inverse poses,
  quaternion order) makes them consistent;
* :mod:`~simcalib.estimation.alignment` — the clock offset where the data tell it,
  interpolation, synchronised poses;
* :mod:`~simcalib.estimation.motions` — motion policies (stations, consecutive, keyframes)
  and :mod:`~simcalib.estimation.pairing` — the paper's D.1 pairing;
* :mod:`~simcalib.estimation.pose_errors` — the poses' own errors (residuals, X's
  sensitivity to each pose, white and correlated error models) and
  :mod:`~simcalib.estimation.consistency` — the reported covariance from them, checked by
  the recording's two halves (block jackknife with a prior; weighting check);
  :mod:`~simcalib.estimation.verdict` — the verdict;
* :mod:`~simcalib.estimation.path` — the stages in order (:func:`calibrate_streams`);
  :mod:`~simcalib.estimation.streams` — a run's streams through it, scored against the
  truth; :mod:`~simcalib.estimation.config` — the scenario section ``estimation.*``.
"""
