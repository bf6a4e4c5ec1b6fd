"""What ``simcalib advise`` prints: the text of an advice.json (a scenario's,
:func:`advice_lines`, or recorded pose files', :func:`recorded_advice_lines`).

Every proposed stop is a motion **from the previous stop** (the first from the reference:
the recorded run's last pose), and the lines say so; joint targets are absolute."""

from __future__ import annotations

import math

__all__ = ["advice_lines", "recorded_advice_lines", "BASELINES"]

#: (console tag, advice.json key, name) of the verification's random baselines
BASELINES = (("random", "random", "random (jog ranges)"),
             ("jog", "random_joint", "joint-jog"),
             ("wide", "random_wide", "random from the advice's candidates"))

#: the line before the stops: what their angles and moves are relative to
RELATIVE = ("each stop is a motion from the previous stop (stop 1: from the reference, the "
            "{ref}); angles and moves are relative to it{joints}")


def _n(v):
    return "inf/n/a" if v is None else f"{v:.3f}"


def _std_row(label, s) -> str:
    vals = [s.get(a) for a in ("wx_deg", "wy_deg", "wz_deg")]
    tr = [s.get(a) for a in ("vx_m", "vy_m", "vz_m")]
    f = lambda v, m=1.0: "    inf" if v is None else f"{v * m:7.3f}"   # noqa: E731
    return f"{label:<10}" + " ".join(f(v) for v in vals) + "  " + " ".join(
        f(v, 100) for v in tr)


def _std_rows(out: dict) -> list:
    lines = ["predicted 1-sigma   wx      wy      wz [deg]   vx      vy      vz [cm]"
             "   (inf: undetermined)",
             _std_row("before", out["predicted_std_before"])]
    return lines + [_std_row(f"+ stop {m['step']}", m["predicted_std_after"])
                    for m in out["motions"]]


def _axis_text(rotvec) -> str:
    """``about the vertical`` for a rotation vector along world z, else its unit axis."""
    n = math.hypot(*rotvec)
    if n == 0:
        return ""
    if math.hypot(rotvec[0], rotvec[1]) <= 1e-6 * n:
        return f"{math.copysign(n, rotvec[2]):+.1f} deg about the vertical"
    return f"{n:.1f} deg about [{', '.join(f'{x / n:.2f}' for x in rotvec)}]"


def _stop_line(m: dict, platform: str) -> str:
    """One advised stop: the target's and each camera's motion from the previous stop."""
    tm = m.get("target_motion") or {}
    who = "flange" if platform == "arm" else "cart"
    move = ", ".join(f"{100 * x:+.1f}" for x in tm.get("translation_world_m", ()))
    turn = _axis_text(tm.get("rotvec_world_deg", (0.0, 0.0, 0.0)))
    target = (f"{who} {'turns ' + turn + ', ' if turn else ''}moves [{move}] cm (world axes)"
              if tm else "")
    cams = ", ".join(f"{c} {v['angle_deg']:.1f} deg / "
                     f"{100 * math.hypot(*v['translation_m']):.1f} cm"
                     for c, v in m["camera_motions"].items())
    joints = m.get("joint_targets_rad")
    at = (" -> joints [deg] " + " ".join(f"{math.degrees(v):.1f}" for v in joints.values())
          if joints else f" -> cart at {m['cart_pose']}" if "cart_pose" in m else "")
    return (f"stop {m['step']} (from {m.get('from', 'the previous stop')}): {target}; "
            f"cameras {cams};{at}")


def _notes(out: dict) -> list:
    lines = [out["message"]] if out.get("message") else []
    lines += [f"cannot help: {c['statement']}. Fix: {c['fix']}" for c in out["cannot_help"]]
    if (out.get("limited_by") or {}).get("statement"):
        lines.append(f"after the stops, {out['limited_by']['statement']}")
    eg = out.get("expected_gain") or {}
    if eg:
        lines.append(f"expected (predicted largest 1-sigma, no simulation): these stops "
                     f"{_n(eg['advised_max_std_deg'])} deg / {_n(eg['advised_max_std_cm'])} "
                     f"cm; {eg['stops']} random stops of the same candidates (median of "
                     f"{eg['chains']}) {_n(eg['random_max_std_deg_median'])} deg / "
                     f"{_n(eg['random_max_std_cm_median'])} cm")
    fl = out.get("choice_floor") or {}
    if fl:
        lines.append(
            f"model floor (expected RMS error, no simulation): the best choice of "
            f"{fl['stops']} of these candidates found {_n(fl['floor_expected_deg'])} deg / "
            f"{_n(fl['floor_expected_cm'])} cm; these stops {_n(fl['advised_expected_deg'])}"
            f" / {_n(fl['advised_expected_cm'])}; {fl['stops']} random stops "
            f"{_n(fl['random_expected_deg'])} / {_n(fl['random_expected_cm'])} (floor / "
            f"random: rotation {_n(fl['ratio_floor_rotation'])}, translation "
            f"{_n(fl['ratio_floor_translation'])})")
    return lines + [f"advice took {out['timing_s']['total']:.1f} s"]


def advice_lines(out: dict) -> list[str]:
    """The console text of a scenario's advice.json ``out``."""
    lines = [f"advice for {out['scenario']} ({out['platform']}, {out['recorded_motions']} "
             f"recorded motions; {out['candidates']['feasible']} of "
             f"{out['candidates']['drawn']} candidates feasible)"]
    lines += _std_rows(out)
    if out["motions"]:
        joints = "; joint targets are absolute" if out["platform"] == "arm" else ""
        lines.append(RELATIVE.format(ref="recorded run's last pose", joints=joints))
    lines += [_stop_line(m, out["platform"]) for m in out["motions"]]
    lines += _notes(out)
    if out.get("verification"):
        lines += _verification_lines(out["verification"])
    return lines


def _result_row(label, r) -> str:
    if not r.get("success"):
        return f"{label:<12} FAILED: {r.get('error')}"
    return (f"{label:<12}{r['rotation_error_deg']:>10.3f}{r['translation_error_cm']:>12.3f}"
            f"{_n(r.get('max_std_deg')):>13}{_n(r.get('max_std_cm')):>14}")


def _verification_lines(ver: dict) -> list:
    lines = ["verification (dqopt; actual error vs truth, predicted largest 1-sigma):",
             f"{'':<12}{'rot [deg]':>10}{'trans [cm]':>12}{'σ rot [deg]':>13}"
             f"{'σ trans [cm]':>14}",
             _result_row("baseline", ver["baseline"]), _result_row("advised", ver["advised"])]
    lines += [_result_row(f"advised s{r['seed']}", r) for r in ver.get("advised_seeds", [])]
    for tag, key, _ in BASELINES:
        lines += [_result_row(f"{tag} s{r['seed']}", r) for r in ver.get(key, [])]
        med = ver.get(f"{key}_median") or {}
        if med:
            lines.append(f"{tag + ' med':<12}{_n(med['rotation_error_deg']):>10}"
                         f"{_n(med['translation_error_cm']):>12}{_n(med['max_std_deg']):>13}"
                         f"{_n(med['max_std_cm']):>14}")
    for _, key, name in BASELINES:
        rt = ver.get(f"ratio_advised_to_{key}_median") or {}
        if rt:
            lines.append(f"advised median / {name} median: rotation "
                         f"{_n(rt['rotation_error_deg'])}, translation "
                         f"{_n(rt['translation_error_cm'])}")
    return lines + _hindsight_lines(ver.get("hindsight") or {}, ver)


def _hindsight_lines(hs: dict, ver: dict) -> list:
    if not hs:
        return []
    rt = ver.get("ratio_hindsight_to_random_median") or {}
    lines = [_result_row("hindsight", hs),
             f"hindsight (stops picked knowing the true X: a bound, not advice) / random "
             f"median: rotation {_n(rt.get('rotation_error_deg'))}, translation "
             f"{_n(rt.get('translation_error_cm'))}"]
    rk = hs.get("ranking") or {}
    if rk:
        lines.append(f"prediction vs actual over {rk['chains']} random chains of the "
                     f"candidates: rank correlation rotation {_n(rk['spearman_rotation'])}, "
                     f"translation {_n(rk['spearman_translation'])}; best-predicted tenth's "
                     f"actual error / all: {_n(rk['best_tenth_over_all_rotation'])}, "
                     f"{_n(rk['best_tenth_over_all_translation'])}")
    return lines


def _axis(v) -> list:
    n = math.hypot(*v["rotvec_deg"])
    return [x / n for x in v["rotvec_deg"]] if n > 0 else [0.0, 0.0, 0.0]


def recorded_advice_lines(out: dict) -> list[str]:
    """The console text of advice.json for recorded pose files."""
    lines = [f"advice for your pose files ({out['platform']}, {out['recorded_motions']} "
             f"recorded motions, {out['candidates']['drawn']} candidates)"]
    lines += _std_rows(out)
    if out["motions"]:
        lines.append(RELATIVE.format(ref="last recorded pose of sensor a", joints=""))
    for m in out["motions"]:
        desc = ", ".join(f"sensor {c}: {v['angle_deg']:.1f} deg about "
                         f"[{', '.join(f'{x:.2f}' for x in _axis(v))}] / "
                         f"{100 * math.hypot(*v['translation_m']):.1f} cm"
                         for c, v in m["sensor_motions"].items())
        lines.append(f"stop {m['step']} (from {m.get('from', 'the previous stop')}): {desc}")
    lines.append(f"not checked: {out['not_checked']}")
    return lines + _notes(out)
