"""The registered kinds (:data:`KINDS`): each kind's function, its one-line description,
whether the data determine the clock offset, what the calibration should do, and the
settings it reads.
"""

from __future__ import annotations

from simcalib.studies.experiments.recording_kinds.continuous import (
    _kind_clock_drift, _kind_clock_step, _kind_continuous, _kind_gaps, _kind_low_rate_camera,
    _kind_no_motion_b, _kind_offset, _kind_outliers, _kind_planar, _kind_translation,
    _kind_weak_rotation)
from simcalib.studies.experiments.recording_kinds.error_model import _kind_robot_error
from simcalib.studies.experiments.recording_kinds.readings import (
    _kind_inverted, _kind_scalar_first, _kind_scale, _kind_scale_stations, _kind_stamp_units)
from simcalib.studies.experiments.recording_kinds.stations import (
    _kind_bumped_camera, _kind_bursts, _kind_scara, _kind_stations, _kind_stations_short,
    _kind_stations_two_clocks, _kind_stop_and_go, _kind_stop_and_go_two_clocks,
    _kind_translation_bursts)
from simcalib.studies.experiments.recording_models import Kind

__all__ = ["KINDS"]


KINDS: dict[str, Kind] = {
    "stations": Kind(_kind_stations, "robot arm stopping at 10..40 stations, one pose per "
                     "station per stream (eye-in-hand); stamps: the station index in even "
                     "seeds, seconds apart in odd ones", False),
    "stations_short": Kind(_kind_stations_short, "the same with only 3..5 stations", False),
    "stations_two_clocks": Kind(_kind_stations_two_clocks, "stations (10..40) stamped by two "
                                "computers' clocks: b 0.5..10 s early or late, +-50 ms of "
                                "trigger jitter, no stamp shared", False, extra=("offset_s",)),
    "continuous": Kind(_kind_continuous, "smooth 6-DoF motion, a 100 Hz, b 30 Hz, stamp "
                       "jitter, dropped frames, offset exactly 0", True),
    "offset": Kind(_kind_offset, "continuous with a clock offset: +-0.2 s, tens of seconds "
                   "in seeds 2, 5, ...; 30..100 ppm drift in seeds 1, 4, ...", True,
                   extra=("offset_s", "drift_ppm")),
    "clock_drift": Kind(_kind_clock_drift, "continuous for 120 s, two free-running clocks "
                        "50..150 ppm apart (6..18 ms over the recording), offset +-0.2 s",
                        True, extra=("offset_s", "drift_ppm"), defaults={"duration_s": 120.0}),
    "outliers": Kind(_kind_outliers, "continuous with 5..20 % outlier poses in b and a 37 ms "
                     "offset", True, extra=("offset_s", "outlier_fraction")),
    "gaps": Kind(_kind_gaps, "continuous with one or two gaps of 1..3 s in one stream (b in "
                 "even seeds, a in odd ones), offset +-50 ms", True, extra=("offset_s",)),
    "robot_error": Kind(_kind_robot_error, "stations with systematic robot kinematic error "
                        "and distance-dependent camera error", False),
    "planar": Kind(_kind_planar, "vehicle driving in a plane (yaw only): X's vertical "
                   "translation undetermined; offset +-50 ms", True, "degenerate",
                   extra=("offset_s",)),
    "scara": Kind(_kind_scara, "4-DoF SCARA stations (vertical rotations, z on a grid)",
                  False, "degenerate"),
    "translation": Kind(_kind_translation, "a stage (3-D, even seeds) or a cart (in a plane, "
                        "odd seeds) that translates without rotating, offset +-50 ms: X's "
                        "translation undetermined", True, "degenerate", extra=("offset_s",)),
    "weak_rotation": Kind(_kind_weak_rotation, "a stage (3-D, even seeds) or a cart (in a "
                          "plane, odd seeds) translating ~0.1..0.3 m that turns by only 1..5 "
                          "deg in all, offset +-0.2 s", True, extra=("offset_s",)),
    "translation_bursts": Kind(_kind_translation_bursts, "a gantry stopping at 8..25 "
                               "stations without turning, a burst of 3..8 frames at each "
                               "(both streams): X's translation undetermined", False,
                               "degenerate"),
    "inverted": Kind(_kind_inverted, "continuous, file b written as T_sensor_world, offset "
                     "+-50 ms", True, extra=("offset_s",)),
    "scalar_first": Kind(_kind_scalar_first, "continuous, one file with the quaternion "
                         "scalar first (b in even seeds, a in odd ones), offset +-50 ms", True,
                         extra=("offset_s",)),
    "bursts": Kind(_kind_bursts, "robot arm stopping at 8..25 stations, a burst of 3..8 "
                   "frames at each (both streams), the camera's error mostly common to a "
                   "burst", False),
    "stop_and_go": Kind(_kind_stop_and_go, "a streamed at 100 Hz through 8..20 stops and the "
                        "moves between them, b (30 Hz) only while the hand stands still, "
                        "offset +-50 ms (it cannot show)", False,
                        extra=("offset_s", "rate_a_hz", "rate_b_hz", "drop_fraction",
                               "jitter_a_s", "jitter_b_s")),
    "stop_and_go_two_clocks": Kind(_kind_stop_and_go_two_clocks, "stop_and_go with b on "
                                   "another computer's clock: 5..40 s early or late, plus "
                                   "+-50 ms (found to the stop: ~0.2 s, within a stop nothing "
                                   "moves)", False,
                                   extra=("offset_s", "rate_a_hz", "rate_b_hz",
                                          "drop_fraction", "jitter_a_s", "jitter_b_s"),
                                   offset_tol_ms=500.0),
    "low_rate_camera": Kind(_kind_low_rate_camera, "continuous, a 5 Hz camera with 0.5 deg / "
                            "5 mm noise, 20 % of both streams' frames dropped, 60 s, offset "
                            "+-50 ms (found to ~6 ms)", True, extra=("offset_s",),
                            defaults={"rate_b_hz": 5.0, "sigma_rot_b_deg": 0.5,
                                      "sigma_trans_b_m": 0.005, "duration_s": 60.0,
                                      "drop_fraction": 0.2}, offset_tol_ms=20.0),
    "stamp_units": Kind(_kind_stamp_units, "continuous, offset +-0.2 s (30..100 ppm drift in "
                        "odd seeds), one or both files stamped from their first pose in ms, us "
                        "or ns, or one since the Unix epoch (by seed: a ms, b ms, both ms, a "
                        "us, b ns, both us, a Unix s, b Unix s)", True,
                        extra=("offset_s", "drift_ppm")),
    "scale": Kind(_kind_scale, "continuous, b's translations in another scale (x 0.3..0.91 "
                  "in even seeds, x 1.1..3 in odd ones, log-uniform: a monocular SLAM track, a "
                  "wrong target size), offset +-50 ms", True, extra=("offset_s",)),
    "scale_stations": Kind(_kind_scale_stations, "stations (10..40) with b's translations in "
                           "another scale (as scale)", False),
    "clock_step": Kind(_kind_clock_step, "continuous, offset +-0.2 s, b's clock stepping "
                       "forward once by 0.3..2 s (NTP, a logger restarted) 30..70 % of the "
                       "way through: the step told", True, extra=("offset_s",)),
    "bumped_camera": Kind(_kind_bumped_camera, "stations (27..40) with the camera moved on "
                          "its mount (2..6 deg, 10..30 mm) after 30..45 % of them: the "
                          "change told at its station, X the later stretch's", False),
    "no_motion_b": Kind(_kind_no_motion_b, "bad input: b does not move", True, "data_error"),
}
