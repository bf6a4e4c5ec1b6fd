"""The reading of two pose files (simcalib/estimation/readings.py) where the rig only
translates: what the data can tell (an inverted stream, from translations in 3-D) and what
they cannot (in a plane; the quaternion order), and how clearly."""

from __future__ import annotations

import dataclasses

from simcalib.estimation.readings import detect_conventions
from simcalib.studies.experiments.recording_kinds import generate, true_streams


def _b_inverted(seed):
    rec = generate("translation", seed)
    a, b = true_streams(rec)
    return a, b.with_inverse(), rec.offset_s


def test_an_inverted_stream_of_a_stage_translating_in_3d_is_told_clearly():
    a, b, off = _b_inverted(0)                     # even seeds: 3-D
    rep = detect_conventions(a, b, offset=off)
    assert rep.invert_b and not rep.invert_a, rep.message
    # the inversion is told clearly (every reading of b as written fits > 3x worse); the
    # quaternion orders are not (no rotation): the files' own order is kept, and said so
    best = min(rep.scores.values())
    assert all(v > 3 * best for k, v in rep.scores.items() if "b: as written" in k)
    assert not rep.swap_scalar_a and not rep.swap_scalar_b and not rep.clear
    assert "closest to the files as written" in rep.message


def test_a_cart_translating_in_a_plane_cannot_tell_an_inverted_stream():
    """In a plane -t is t turned by 180 deg about the normal: both readings fit alike, so
    the reading is not clear (and the files are taken as written, said so)."""
    a, b, off = _b_inverted(1)                     # odd seeds: a plane
    rep = detect_conventions(a, b, offset=off)
    assert not rep.clear and rep.ratio < 1.5, rep.message
    assert "taken as written" in rep.message


def test_the_quaternion_order_is_not_told_without_rotation():
    rec = generate("translation", 0)
    a, b = true_streams(rec)
    a = dataclasses.replace(a, quat_order="xyzw")
    rep = detect_conventions(a, b, offset=rec.offset_s)
    assert not rep.clear and not rep.swap_scalar_a, rep.message
