"""One advice session as ``simcalib advise`` runs it, outputs written: for a scenario
(:func:`scenario_session`: the recorded run, the advice, its verification and floor when
asked, DIR/advice.json and DIR/advice.rrd) and for recorded pose files
(:func:`files_session`: calibrate the files, advise, write)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

__all__ = ["scenario_session", "files_session"]


def _write(out: dict, out_dir: Path, record=None) -> dict:
    """Write ``out`` to DIR/advice.json and, with ``record(path) -> path``, the recording
    DIR/advice.rrd (its path then in ``out["recording"]``)."""
    from simcalib.config.files import output_folder
    output_folder(out_dir)
    path = out_dir / "advice.json"
    path.write_text(json.dumps(out, indent=1, allow_nan=False))
    if record is not None:
        out["recording"] = str(record(out_dir / "advice.rrd"))
        path.write_text(json.dumps(out, indent=1, allow_nan=False))
    return out


def scenario_session(cfg, out_dir, *, k: int = 5, n_candidates: int = 1000,
                     force: bool = True, systematic: bool = True, verify: bool = False,
                     seeds: int = 5, stop_frames: int = 1, hindsight: bool = False,
                     floor: bool = False, recording: bool = True, **ranges) -> dict:
    """Advice for the scenario ``cfg`` (a ScenarioConfig) with its outputs in ``out_dir``:
    the advice.json dict (:func:`advice_json.advice_dict`). ``ranges``:
    ``max_rotation_deg``, ``max_translation_m``, ``min_markers`` of the candidates."""
    from simcalib.studies.advise.advice_json import advice_dict
    from simcalib.studies.advise.advisor import advise, baseline
    from simcalib.studies.advise.bounds import choice_floor
    from simcalib.studies.advise.verification import verify as verify_advice
    base = baseline(cfg)
    adv = advise(base, k, seed=cfg.seed, n_candidates=n_candidates,
                 when_determined="advise" if force else "stop", systematic=systematic,
                 **ranges)
    ver = verify_advice(base, adv, seeds=tuple(range(seeds)), frames_per_stop=stop_frames,
                        hindsight=hindsight) if verify else None
    out = advice_dict(base, adv, ver, choice_floor(base, adv) if floor else None)

    def record(path):
        from simcalib.report.rerun.advice import record_advice
        return record_advice(path, base, adv, out)
    return _write(out, Path(out_dir), record if recording else None)


def files_session(copts, platform: str, *, k: int = 5, n_candidates: int = 1000,
                  force: bool = True, recording: bool = True, **ranges) -> dict:
    """Advice for the pose files of ``copts`` (calibrate's options; their ``output`` the
    folder written) on ``platform`` (``free`` / ``cart``): the files calibrated as
    ``calibrate`` does, the next ``k`` stops of sensor a from its last pose; the
    advice.json dict (:func:`recorded.recorded_advice_dict`). ValueError when the recorded
    motion does not fit the platform."""
    from simcalib.pipeline.calibrate import calibrate
    from simcalib.solvers.kernels.mode import prepare_kernels
    from simcalib.studies.advise.recorded import advise_recorded, recorded_advice_dict
    with prepare_kernels().context():
        r, assessment = calibrate(copts)
    mask = np.asarray(r.robust.inlier_mask, dtype=bool)
    adv = advise_recorded(r.C[mask], r.H[mask], r.X, r.synced.T_a[-1], k, platform=platform,
                          rng=np.random.default_rng([copts.seed, 13]), alpha=copts.alpha,
                          n_candidates=n_candidates,
                          when_determined="advise" if force else "stop",
                          passes=r.motions.passes, **ranges)
    out = recorded_advice_dict(adv, {"a": str(copts.a), "b": str(copts.b) if copts.b else None,
                                     "calibration": assessment.verdict,
                                     "conventions": r.summary.get("conventions"),
                                     "inlier_motions": int(mask.sum())})

    def record(path):
        from simcalib.report.rerun.advice import record_recorded_advice
        return record_recorded_advice(path, r.synced.T_a, adv, out)
    return _write(out, Path(copts.output), record if recording else None)
