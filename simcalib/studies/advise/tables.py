"""Regenerate docs/advice.md: ``python -m simcalib.studies.advise.tables --out docs/advice.md``.

For each scenario: the recorded run (baseline), K advised stops, and K random feasible
stops for several seeds, executed in the simulator (render, detect, solve with dqopt)."""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from simcalib.studies.advise.outcomes import median_summary
from simcalib.studies.advise.tables_text import (BOUND_HEAD, FLOOR_HEAD, HEAD, RANK_HEAD,
                                                 actual_section, frames_section,
                                                 sigma_section)

CASES = (("scara", ()), ("linear", ("world.platform=arm",)),
         ("rotation", ("world.platform=arm",)), ("3d", ()),
         ("planar", ()))

def _span(vals, unit="") -> str:
    """``"a-b<unit>"`` over finite values (2 significant digits), or ``"n/a"``."""
    v = [x for x in vals if x is not None and np.isfinite(x)]
    if not v:
        return "n/a"
    return f"{min(v):.2g}-{max(v):.2g}{unit}"


def _fmt(v, d=3):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "inf"
    return f"{v:.{d}g}"


class Case(NamedTuple):
    """One rig of a scenario (:func:`run_case`)."""
    cfg: object
    base: object
    adv: object
    ver: object
    t_adv: float
    ver_frames: object
    floor: dict


def run_case(name, overrides, k, seeds, n_cand, stop_frames=1, rig=0) -> Case:
    """The :class:`Case` of the scenario run with ``seed=rig`` (its own recorded run and
    rig: marker map survey, calibrations, DH deviation): its advice, verification,
    ``ver_frames`` the verification with ``stop_frames`` frames averaged at each stop
    (advised and random only; None for 1) and ``floor`` (:func:`simcalib.studies.advise.bounds.
    choice_floor`: what any choice of the candidates can expect by the model)."""
    from simcalib.studies.advise.advisor import advise, baseline
    from simcalib.studies.advise.verification import verify
    from simcalib.studies.advise.bounds import choice_floor
    from simcalib.pipeline.scenario import load_config
    ov = list(overrides) + [f"seed={int(rig)}", "recording.enabled=false", "progress=false"]
    cfg = load_config(name, ov)
    base = baseline(cfg)
    t0 = time.perf_counter()
    adv = advise(base, k, seed=cfg.seed, n_candidates=n_cand,
                 when_determined="advise")
    t_adv = time.perf_counter() - t0
    ver = verify(base, adv, seeds=seeds, hindsight=True)
    ver_f = None if stop_frames <= 1 else verify(
        base, adv, seeds=seeds, joint_baseline=False, wide_baseline=False,
        frames_per_stop=stop_frames)
    return Case(cfg, base, adv, ver, t_adv, ver_f, choice_floor(base, adv))


def _median_ratio(med, ratio) -> str:
    """Two table cells: a baseline's median errors and the advised / baseline ratios."""
    if not med:
        return "n/a | n/a | "
    return (f"{_fmt(med.get('rotation_error_deg'))} / {_fmt(med.get('translation_error_cm'))} | "
            f"{_fmt(ratio.get('rotation_error_deg'), 2)} / "
            f"{_fmt(ratio.get('translation_error_cm'), 2)} | ")


def pool(vers):
    """The verifications of several rigs (scenario seeds) pooled: every (rig, seed) result
    of the advised stops and of each baseline in one list, medians and ratios over those
    (:func:`simcalib.studies.advise.outcomes.median_summary`); ``baseline``: median over the
    rigs of the recorded runs' errors; ``per_rig_ratio``: each rig's own ratio;
    ``verdicts``: of every advised solve; ``motion_size``: the first rig's."""
    from types import SimpleNamespace

    def pooled(attr):
        return [r for v in vers for r in getattr(v, attr)]
    adv_all = pooled("advised_seeds")
    adv_med, _ = median_summary({}, adv_all)
    out = {"advised_median": adv_med, "advised_all": adv_all,
           "baseline": median_summary({}, [v.baseline for v in vers])[0],
           "per_rig_ratio": [v.ratio for v in vers], "motion_size": vers[0].motion_size,
           "ratio_interval": ratio_interval(vers),
           "verdicts": [r.get("verdict") for r in adv_all]}
    hind = [v.hindsight for v in vers if v.hindsight]
    out["hindsight_median"] = median_summary({}, hind)[0] if hind else {}
    out["ratio_hindsight"] = median_summary(out["hindsight_median"], pooled("random"))[1] \
        if hind else {}
    for attr, mk, rk in (("random", "random_median", "ratio"),
                         ("random_joint", "random_joint_median", "ratio_joint"),
                         ("random_wide", "random_wide_median", "ratio_wide")):
        rs = pooled(attr)
        out[mk], out[rk] = median_summary(adv_med, rs) if rs else ({}, {})
    return SimpleNamespace(**out)


def ratio_interval(vers, attr: str = "random", *, n_boot: int = 2000, level: float = 0.9,
                   seed: int = 0) -> dict:
    """How far the pooled ratio advised / baseline ``attr`` of :func:`pool` is known: its
    ``level`` percentile interval over ``n_boot`` bootstrap resamples of the rigs (each
    rig's advised and baseline results drawn together, with replacement; draws from
    ``numpy.random.default_rng(seed)``). ``{"rotation_error_deg": (lo, hi),
    "translation_error_cm": (lo, hi)}`` (None where no resample gives a ratio); ``{}``
    with fewer than 2 rigs."""
    if isinstance(n_boot, bool) or not isinstance(n_boot, int) or n_boot < 1:
        raise ValueError(f"n_boot must be an integer >= 1; received {n_boot!r}")
    if not 0 < level < 1:
        raise ValueError(f"level must be in (0, 1); received {level!r}")
    keys = ("rotation_error_deg", "translation_error_cm")
    if len(vers) < 2:
        return {}
    rng = np.random.default_rng(seed)
    draws: dict = {k: [] for k in keys}
    for _ in range(n_boot):
        pick = rng.integers(0, len(vers), len(vers))
        adv_med, _ = median_summary({}, [r for i in pick for r in vers[i].advised_seeds])
        _, ratio = median_summary(adv_med, [r for i in pick for r in getattr(vers[i], attr)])
        for k in keys:
            if ratio.get(k) is not None and math.isfinite(ratio[k]):
                draws[k].append(ratio[k])
    q = ((1.0 - level) / 2.0, (1.0 + level) / 2.0)
    return {k: (tuple(float(x) for x in np.quantile(v, q)) if v else None)
            for k, v in draws.items()}


def _interval(iv) -> str:
    """A :func:`ratio_interval` as ``lo-hi / lo-hi`` (rotation / translation)."""
    return " / ".join("n/a" if not iv or iv.get(k) is None else
                      f"{_fmt(iv[k][0], 2)}-{_fmt(iv[k][1], 2)}"
                      for k in ("rotation_error_deg", "translation_error_cm"))


def _verdicts(ver) -> str:
    """``"determined (15/15)"``: the most common verdict of the advised solves and how many
    of them reached ``determined``."""
    v = [x for x in ver.verdicts if x]
    if not v:
        return "n/a"
    top = max(sorted(set(v)), key=v.count)       # ties: the first in sorted order
    return f"{top} ({v.count('determined')}/{len(v)} determined)"


def _pair(m, digits: int = 3) -> str:
    """``"rotation / translation"`` cell of an errors (or ratios) dict; ``n/a`` when empty."""
    if not m:
        return "n/a"
    return (f"{_fmt(m.get('rotation_error_deg'), digits)} / "
            f"{_fmt(m.get('translation_error_cm'), digits)}")


def _frames_row(label, ver, ver_f) -> str:
    """A row of the frames-averaged table: advised and random medians with 1 and with
    several frames per stop, and the ratio with several."""
    return (f"| {label} | {_pair(ver.advised_median)} | {_pair(ver_f.advised_median)} | "
            f"{_pair(ver.random_median)} | {_pair(ver_f.random_median)} | "
            f"{_pair(ver_f.ratio, 2)} |")


def _bound_row(label, ver) -> str:
    """A row of the hindsight-bound table."""
    am, med = ver.advised_median, ver.random_median
    exp = [am.get(k) / med[k] if am.get(k) is not None and med.get(k) else None
           for k in ("max_std_deg", "max_std_cm")]
    return (f"| {label} | {_pair(am)} | {_pair(ver.hindsight_median)} | {_pair(med)} | "
            f"{_pair(ver.ratio, 2)} | {_pair(ver.ratio_hindsight, 2)} | "
            f"{_fmt(exp[0], 2)} / {_fmt(exp[1], 2)} |")


def _ranking_row(label, advs, vers, pooled) -> str:
    """A row of the ranking table: medians over the rigs of the planner's expected ratio
    (:func:`simcalib.studies.advise.advisor.expected_gain`) and of the hindsight's
    ``ranking``; the pooled actual ratio against random stops of the candidates."""
    from simcalib.studies.advise.advisor import expected_gain

    def med(vals):
        v = [x for x in vals if x is not None]
        return float(np.median(v)) if v else None
    eg = [expected_gain(a) for a in advs]
    rk = [(v.hindsight or {}).get("ranking") or {} for v in vers]
    cell = {k: med([d.get(k) for d in rk]) for k in (
        "spearman_rotation", "spearman_translation", "best_tenth_over_all_rotation",
        "best_tenth_over_all_translation")}
    exp_r = med([e.get("expected_ratio_rotation") for e in eg])
    exp_t = med([e.get("expected_ratio_translation") for e in eg])
    return (f"| {label} | {_fmt(exp_r, 2)} / {_fmt(exp_t, 2)} | {_pair(pooled.ratio_wide, 2)} | "
            f"{_fmt(cell['spearman_rotation'], 2)} / {_fmt(cell['spearman_translation'], 2)} | "
            f"{_fmt(cell['best_tenth_over_all_rotation'], 2)} / "
            f"{_fmt(cell['best_tenth_over_all_translation'], 2)} |")


#: the numbers of :func:`simcalib.studies.advise.bounds.choice_floor` the floor table gives
#: medians of
FLOOR_MEDIANS = tuple(f"{w}_expected_{u}" for w in ("advised", "floor", "random")
                      for u in ("deg", "cm")) + tuple(
    f"ratio_{w}_{b}" for w in ("advised", "floor") for b in ("rotation", "translation"))


def floor_summary(floors) -> dict:
    """Medians over the rigs of :func:`simcalib.studies.advise.bounds.choice_floor`'s numbers
    (``{}`` when no rig has one), each rig's floor ratios (``per_rig``) and the largest
    search spread (largest / smallest start result) over the rigs."""
    fl = [f for f in floors if f]
    if not fl:
        return {}
    out = {k: _median_or_none([f[k] for f in fl]) for k in FLOOR_MEDIANS}
    out["per_rig"] = [(f["ratio_floor_rotation"], f["ratio_floor_translation"]) for f in fl]
    out["spread"] = tuple(max(max(f[k]) / min(f[k]) for f in fl)
                          for k in ("floor_per_start_deg", "floor_per_start_cm"))
    out["rigs"] = len(fl)
    return out


def _median_or_none(vals):
    """The median, or None when any value is None (a block some rig leaves undetermined)."""
    return None if any(v is None for v in vals) else float(np.median(vals))


def _floor_row(label, floor, ver) -> str:
    """A row of the floor table (``floor``: :func:`floor_summary`)."""
    if not floor:
        return (f"| {label} | n/a | n/a | n/a | n/a | n/a | n/a | n/a | {_pair(ver.ratio, 2)} "
                f"| n/a | n/a |")
    f = floor
    return (f"| {label} | {_fmt(f['advised_expected_deg'])} / {_fmt(f['advised_expected_cm'])} | "
            f"{_fmt(f['floor_expected_deg'])} / {_fmt(f['floor_expected_cm'])} | "
            f"{_fmt(f['random_expected_deg'])} / {_fmt(f['random_expected_cm'])} | "
            f"{_fmt(f['ratio_advised_rotation'], 2)} / "
            f"{_fmt(f['ratio_advised_translation'], 2)} | "
            f"{_fmt(f['ratio_floor_rotation'], 2)} / {_fmt(f['ratio_floor_translation'], 2)} | "
            + " ".join(f"{_fmt(r, 2)}/{_fmt(t, 2)}" for r, t in f["per_rig"])
            + f" | {f['spread'][0]:.3f} / {f['spread'][1]:.3f} | {_pair(ver.ratio, 2)} | "
            f"{_actual_over_model(ver.advised_median, f, 'advised')} | "
            f"{_actual_over_model(ver.random_median, f, 'random')} |")


def _actual_over_model(med, floor, which: str) -> str:
    """``"rotation / translation"``: pooled median actual error over the model's expected
    error of the ``which`` (advised, random) stops; n/a where either is missing."""
    cells = []
    for err, exp in (("rotation_error_deg", f"{which}_expected_deg"),
                     ("translation_error_cm", f"{which}_expected_cm")):
        a, e = (med or {}).get(err), floor.get(exp)
        cells.append(_fmt(a / e, 2) if a is not None and e else "n/a")
    return " / ".join(cells)


def _floor_target(floor, lim) -> str:
    """The floor's clause of a target line: whether any choice is expected to reach it."""
    if not floor:
        return ""
    r, t = floor["ratio_floor_rotation"], floor["ratio_floor_translation"]
    above = [b for b, v in (("rotation", r), ("translation", t)) if v is None or v > lim]
    reach = (f"no choice of these candidates is expected to reach the target on "
             f"{' and '.join(above)}" if above else
             "the best choice of these candidates is expected to reach the target")
    return (f"; the model's floor for any choice of these candidates (median over "
            f"{floor['rigs']} rigs) rotation {_fmt(r, 2)}, translation {_fmt(t, 2)}: "
            f"{reach}")


def _targets(checks) -> str:
    out = []
    for label, name, rt, ver, t_adv, rtj, rtw, floor, cannot in checks:
        r, t = rt["rotation_error_deg"], rt["translation_error_cm"]
        rj, tj = rtj.get("rotation_error_deg"), rtj.get("translation_error_cm")
        rw, tw = rtw.get("rotation_error_deg"), rtw.get("translation_error_cm")
        if name in ("scara", "linear", "rotation"):
            lim = 0.3
        elif name == "3d":
            lim = 1.1
        else:
            continue
        ok = [x is not None and x <= lim for x in (r, t, rj, tj)]
        jtxt = ("" if rj is None and tj is None else
                f"; against the joint-jog baseline rotation {_fmt(rj, 2)} "
                f"({'met' if ok[2] else 'NOT met'}), translation {_fmt(tj, 2)} "
                f"({'met' if ok[3] else 'NOT met'})")
        wtxt = ("" if rw is None and tw is None else
                f"; against random stops from the advice's own candidates rotation "
                f"{_fmt(rw, 2)} ({'met' if rw is not None and rw <= lim else 'NOT met'}), "
                f"translation {_fmt(tw, 2)} "
                f"({'met' if tw is not None and tw <= lim else 'NOT met'})")
        verdict = _verdicts(ver)
        tol_ok = bool(ver.verdicts) and all(v == "determined" for v in ver.verdicts)
        within = ("all directions within tolerance in every solve" if tol_ok else
                  "the direction no motion of this platform determines stays beyond the "
                  "tolerance: see the statements" if cannot else
                  "NOT within tolerance in every solve")
        iv = getattr(ver, "ratio_interval", {}) or {}
        ivtxt = f" (90 % interval over rigs {_interval(iv)})" if iv else ""
        out.append(f"- {label}: ratio rotation {_fmt(r, 2)} ({'met' if ok[0] else 'NOT met'}), "
                   f"translation {_fmt(t, 2)} ({'met' if ok[1] else 'NOT met'}) against "
                   f"<= {lim} (candidate-set baseline){ivtxt}{jtxt}{wtxt}; advised verdict "
                   f"{verdict} ({within})"
                   f"; advice {t_adv:.1f} s (<= 30 s: {'met' if t_adv <= 30 else 'NOT met'})"
                   + _floor_target(floor, lim))
    return "\n".join(out)


def main(argv=None) -> int:
    a = _parse_args(argv)
    os.environ.setdefault("MUJOCO_GL", "egl")
    t0 = time.perf_counter()
    tab = {key: [] for key in ("rows", "sig_rows", "notes", "checks", "size_rows",
                               "frame_rows", "bound_rows", "rank_rows", "floor_rows")}
    prose = {"advised": [], "random": [], "planner": [], "base3d": "n/a"}
    for name, ov in CASES:
        runs = [run_case(name, ov, a.k, tuple(range(a.seeds)), a.candidates, a.stop_frames,
                         rig) for rig in range(a.rigs)]
        _add_scenario(tab, prose, name, ov, runs)
        print(tab["rows"][-1], flush=True)
    text = _head(a, prose, time.perf_counter() - t0) + _sections(a, tab)
    Path(a.out).write_text(text)
    print(f"wrote {a.out}")
    return 0


def _parse_args(argv):
    """The command line of :func:`main`."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default="docs/advice.md")
    ap.add_argument("--k", type=int, default=5)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--candidates", type=int, default=1000)
    ap.add_argument("--stop-frames", type=int, default=10,
                    help="frames averaged at each stop in the second verification")
    ap.add_argument("--rigs", type=int, default=5,
                    help="scenario seeds 0..rigs-1: each its own recorded run and rig")
    return ap.parse_args(argv)


def _add_scenario(tab, prose, name, ov, runs) -> None:
    """Append a scenario's rows (its :func:`run_case` of every rig) to ``tab`` and ``prose``."""
    base, adv = runs[0].base, runs[0].adv        # the planner's numbers: rig 0
    t_adv = max(r.t_adv for r in runs)
    ver = pool([r.ver for r in runs])
    ver_f = pool([r.ver_frames for r in runs]) if runs[0].ver_frames is not None else None
    label = name + "".join(f" {o}" for o in ov)
    tab["rows"].append(_actual_row(label, base, adv, ver, t_adv))
    if ver_f is not None:
        tab["frame_rows"].append(_frames_row(label, ver, ver_f))
    tab["bound_rows"].append(_bound_row(label, ver))
    tab["rank_rows"].append(_ranking_row(label, [r.adv for r in runs], [r.ver for r in runs],
                                         ver))
    floor = floor_summary([r.floor for r in runs])
    tab["floor_rows"].append(_floor_row(label, floor, ver))
    tab["size_rows"].append(_size_row(label, ver.motion_size))
    plan_deg, plan_cm = _planned_max_std(adv)
    tab["sig_rows"].append(_sigma_row(label, ver, adv, plan_deg, plan_cm))
    tab["notes"] += _statements(label, adv)
    tab["checks"].append((label, name, ver.ratio, ver, t_adv, ver.ratio_joint,
                          ver.ratio_wide, floor, bool(adv.cannot_help)))
    _add_prose(prose, name, ov, runs, ver, plan_deg, plan_cm)


def _actual_row(label, base, adv, ver, t_adv) -> str:
    """A row of the actual-errors table."""
    b, med, rt = ver.baseline, ver.random_median, ver.ratio
    verdict = _verdicts(ver)
    medj, rtj = ver.random_joint_median, ver.ratio_joint
    am = ver.advised_median
    cand = adv.candidates
    return (
        f"| {label} | {base.C.shape[0]} | {cand.feasible.sum()}/{cand.n} | "
        f"{adv.chosen.size} | {_fmt(b.get('rotation_error_deg'))} / "
        f"{_fmt(b.get('translation_error_cm'))} | {_fmt(am.get('rotation_error_deg'))} / "
        f"{_fmt(am.get('translation_error_cm'))} | {_fmt(med['rotation_error_deg'])} / "
        f"{_fmt(med['translation_error_cm'])} | {_fmt(rt['rotation_error_deg'], 2)} / "
        f"{_fmt(rt['translation_error_cm'], 2)} | {_interval(ver.ratio_interval)} | "
        + _median_ratio(medj, rtj) + _median_ratio(ver.random_wide_median, ver.ratio_wide)
        + " ".join(f"{_fmt(x.get('rotation_error_deg'), 2)}/"
                   f"{_fmt(x.get('translation_error_cm'), 2)}" for x in ver.per_rig_ratio)
        + f" | {verdict} | {t_adv:.1f} |")


def _size_row(label, ms) -> str:
    """A row of the motion-size table (``ms``: the pooled ``motion_size``)."""
    return (
        f"| {label} | " + " | ".join(
            f"{_fmt((ms.get(w) or {}).get('rotation_deg'), 2)} / "
            f"{_fmt((ms.get(w) or {}).get('translation_cm'), 2)}"
            for w in ("advised", "random", "random_joint", "random_wide")) + " |")


def _planned_max_std(adv) -> tuple[float, float]:
    """The planner's largest 1-sigma (deg, cm) after the advised stops, apart from the axes
    no motion of the platform determines (``cannot_help``)."""
    from simcalib.studies.advise.information import largest_std
    from simcalib.studies.advise.systematic import cannot_help_axes
    plan = adv.std_after[-1] if adv.std_after.size else adv.std_before
    deg, cm = largest_std(plan, cannot_help_axes(adv.cannot_help))
    return float(deg), float(cm)


def _sigma_row(label, ver, adv, plan_deg, plan_cm) -> str:
    """A row of the predicted-1-sigma table."""
    b, am, med = ver.baseline, ver.advised_median, ver.random_median
    return (
        f"| {label} | {_fmt(b.get('max_std_deg'))} / {_fmt(b.get('max_std_cm'))} | "
        f"{_fmt(am.get('max_std_deg'))} / {_fmt(am.get('max_std_cm'))} | "
        f"{_fmt(med['max_std_deg'])} / {_fmt(med['max_std_cm'])} | "
        f"{_fmt(plan_deg)} / {_fmt(plan_cm)} | {adv.systematic_parameters} | "
        + " ".join(_fmt(x, 2) for x in adv.max_std_tol) + " |")


def _statements(label, adv) -> list:
    """The statements of a scenario's advice: what it cannot help, its message, its limit."""
    notes = []
    for h in adv.cannot_help:
        notes.append(f"- {label}: {h['statement']}. Fix: {h['fix']}.")
    if adv.message:
        notes.append(f"- {label}: {adv.message}.")
    if adv.limited_by.get("statement"):
        notes.append(f"- {label}: after the advised stops, {adv.limited_by['statement']}.")
    return notes


def _add_prose(prose, name, ov, runs, ver, plan_deg, plan_cm) -> None:
    """Add a scenario's numbers the text of :data:`HEAD` quotes to ``prose``."""
    am, med = ver.advised_median, ver.random_median
    if name == "3d" and not ov:
        b0 = runs[0].ver.baseline
        prose["base3d"] = (f"{_fmt(b0.get('rotation_error_deg'))} deg / "
                           f"{_fmt(b0.get('translation_error_cm'))} cm")
    if name in ("scara", "linear", "rotation"):
        for e, sd in (("rotation_error_deg", plan_deg), ("translation_error_cm", plan_cm)):
            if am.get(e) is not None and math.isfinite(sd) and sd > 0:
                prose["planner"].append(am[e] / sd)
        for key, v in (("advised", am), ("random", med)):
            for e, sd in (("rotation_error_deg", "max_std_deg"),
                          ("translation_error_cm", "max_std_cm")):
                if v.get(e) is not None and v.get(sd):
                    prose[key].append(v[e] / v[sd])


def _head(a, prose, seconds: float) -> str:
    """:data:`HEAD` with the command, its duration and the numbers of ``prose``."""
    return HEAD.format(command=f"python -m simcalib.studies.advise.tables --out {a.out} --k {a.k} "
                               f"--seeds {a.seeds} --candidates {a.candidates} "
                               f"--stop-frames {a.stop_frames} --rigs {a.rigs}",
                       seconds=seconds, k=a.k, n_seeds=a.seeds,
                       n_rigs=a.rigs,
                       n_cand=a.candidates, base3d=prose["base3d"],
                       over_advised=_span(prose["advised"], "x"),
                       over_random=_span(prose["random"], "x"),
                       over_planner=_span(prose["planner"], "x"))


def _sections(a, tab) -> str:
    """The tables, targets and statements of docs/advice.md after :data:`HEAD`."""
    text = actual_section(tab["rows"]) + sigma_section(tab["sig_rows"])
    text += BOUND_HEAD + "\n".join(tab["bound_rows"]) + "\n"
    text += RANK_HEAD + "\n".join(tab["rank_rows"]) + "\n"
    text += FLOOR_HEAD + "\n".join(tab["floor_rows"]) + "\n"
    text += ("\n### Size of the added stop-to-stop motions of camera a (median rotation deg / "
             "translation cm)\n\n| scenario | advised | random | joint-jog random | random "
             "from the advice's candidates |\n|---|---|---|---|---|\n"
             + "\n".join(tab["size_rows"]) + "\n")
    if tab["frame_rows"]:
        text += frames_section(a.stop_frames, tab["frame_rows"])
    text += ("\n### Targets, checked on the rows above\n\n"
             + _targets(tab["checks"]) + "\n")
    notes = tab["notes"]
    text += "\n### Statements\n\n" + ("\n".join(notes) if notes else "(none)") + "\n"
    return text


if __name__ == "__main__":
    raise SystemExit(main())
