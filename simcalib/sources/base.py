"""The pose-source protocol: what every source of camera poses takes and returns.

A source turns the run's ground truth (a simulated :class:`~simcalib.world.World` or a
synthetic problem, wrapped in :class:`GroundTruth`) into what a sensor would report:
timestamped :class:`~simcalib.streams.PoseStream` per camera, plus its own log. One file per
source under ``simcalib/sources/``; each registers itself (``registry.register``).

Adding a source (e.g. ``robot_fk``, a file importer): write ``simcalib/sources/<name>.py``
with a class that has ``info`` (:class:`SourceInfo`) and ``measure(...)`` and call
``register(<instance>)`` at import; the registry finds the file (it imports every module
of ``simcalib/sources/`` on its first lookup), no import list to edit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Protocol, runtime_checkable

import numpy as np

from simcalib.streams import CAMERAS

__all__ = ["CAMERAS", "GroundTruth", "SourceInfo", "SourceOutput", "PoseSource",
           "SourceHooks"]



@dataclass(frozen=True)
class GroundTruth:
    """The truth a run measures (output of the ``world`` stage).

    ``kind``: ``"sim"`` (MuJoCo world) or ``"synthetic"`` (paper appendix D.2 problem);
    ``X_true``: ``(4, 4)`` true ``T_a_b``; ``streams``: camera -> exact
    :class:`~simcalib.streams.PoseStream` (``source="ground_truth"``); ``world``: the
    :class:`simcalib.world.World` (``kind="sim"``, else ``None``); ``synthetic``: the
    :class:`simcalib.world.synthetic.SyntheticProblem` (``kind="synthetic"``, else ``None``);
    ``intrinsics``: camera -> :class:`~simcalib.streams.CameraIntrinsics` (empty without
    cameras); ``marker_field``: the known marker map or ``None``; ``rig_entropy``: rng
    stream name -> the number a source drew for the rig's fixed errors in the recorded run
    (e.g. ``"vision"``: the marker map's survey and the camera calibrations, see
    :func:`simcalib.sources.vision.stream.visual_streams`), set when more frames of the same rig are
    measured (the stops of ``simcalib advise``); empty: drawn from the source's generator.
    """
    kind: str
    X_true: np.ndarray
    streams: Mapping[str, object]
    world: object = None
    synthetic: object = None
    intrinsics: Mapping[str, object] = field(default_factory=dict)
    marker_field: object = None
    rig_entropy: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class SourceInfo:
    """Metadata of a registered source.

    ``name``: registry name (``source=<name>``); ``description``: one line;
    ``kinds``: the ``kind`` of ground truth it can measure (``"sim"``, ``"synthetic"``);
    ``rng_stream``: the name of the generator of the run's seed it draws from (any name:
    :func:`simcalib.pipeline.state.run_rngs` gives each name its own stream; a new
    source takes a new name);
    ``exact``: its poses are the ground truth (no TUM file / no separate trajectory);
    ``renders``: it renders images (slow; ``workers`` applies);
    ``needs_markers``: it measures against the marker field (no source for an outdoor
    platform); ``reads_joints``: it reads the arm's joint encoders (its log is the robot
    report's input, results.json ``sensing.robot``);
    ``synthetic_stand_in``: a synthetic scenario may name it (its noise is ``noise.*``);
    ``cameras``: the cameras it can measure (a stream that names it for another camera is
    a configuration error);
    ``config``: its own configuration section, a frozen dataclass: the scenario gets the
    section ``<name>.*`` (:mod:`simcalib.pipeline.scenario` adds it; the source reads
    ``getattr(cfg, name)``), or None;
    ``example``: a scenario and overrides that run it (``python -m simcalib run
    scenario=<example[0]> <example[1:]>``; the registry tests measure a small world of
    it); empty: ``planar source=<name>``.
    """
    name: str
    description: str
    kinds: tuple[str, ...] = ("sim",)
    rng_stream: str = "noise"
    exact: bool = False
    renders: bool = False
    needs_markers: bool = False
    reads_joints: bool = False
    synthetic_stand_in: bool = False
    cameras: tuple[str, ...] = CAMERAS
    config: type | None = None
    example: tuple[str, ...] = ()

    @property
    def run_example(self) -> tuple[str, tuple[str, ...]]:
        """``(scenario, overrides)`` that run this source (:attr:`example`)."""
        if self.example:
            return self.example[0], tuple(self.example[1:])
        return "planar", (f"source={self.name}",)


@dataclass(frozen=True)
class SourceOutput:
    """What a source measured.

    ``streams``: camera -> :class:`~simcalib.streams.PoseStream` (``T_world_cam`` at the
    camera's timestamps; dropped frames absent and counted) for every requested camera;
    sources that measure relative motions directly leave it empty and fill ``motions``.
    ``motions``: a :class:`simcalib.estimation.pairing.MotionPairs` already paired (the ``pairs``
    stage uses it instead of pairing ``streams``), else ``None``.
    ``pose_errors``: camera -> :class:`simcalib.evaluation.PoseErrors` when the source
    computed its errors itself (motions), else ``None`` (evaluation compares ``streams``
    with the ground truth). ``frames``: per-camera frame counts for results.json when the
    source has no streams (else derived from them). ``log``: the source's own record for
    the recording (``aruco``: :class:`simcalib.sources.vision.stream.VisualLog`), else ``None``.
    ``pairing_mode``: with ``motions``, how they were formed (results.json
    ``pairing.mode``).
    """
    streams: Mapping[str, object] = field(default_factory=dict)
    motions: object = None
    pose_errors: Mapping[str, object] | None = None
    frames: Mapping[str, object] | None = None
    log: object = None
    pairing_mode: str = ""


@runtime_checkable
class PoseSource(Protocol):
    """A pose source: ``info`` and ``measure``.

    ``measure(truth, cfg, rng, cameras) -> SourceOutput``: ``truth`` the
    :class:`GroundTruth`; ``cfg`` the run's :class:`simcalib.pipeline.scenario.ScenarioConfig` (a
    source reads only its own section, e.g. ``cfg.noise`` / ``cfg.vision``); ``rng`` the
    run's child generator named by ``info.rng_stream`` (the source splits it per camera
    with ``rng.spawn(len(CAMERAS))`` so a camera's draws do not depend on the others);
    ``cameras`` the subset of :data:`CAMERAS` it must measure (per-stream selection).
    """
    info: SourceInfo

    def measure(self, truth: GroundTruth, cfg, rng: np.random.Generator,
                cameras: tuple[str, ...]) -> SourceOutput: ...


class SourceHooks:
    """What the pipeline and the config's feasibility check ask a source, with the answers
    of a source that has none of these facts (every built-in source derives from it, a new
    one overrides what applies).

    * ``pose_margins(cfg) -> (m, deg)``: how far a measured relative motion may fall below
      the true one (the pre-filter prediction of :mod:`simcalib.pipeline.feasibility`).
    * ``error_basis(world, cfg, cam, T_world_cam, layout, qpos=None, visible=None)``:
      ``(F, 6, P)`` systematic pose errors in the columns of ``layout``
      (:func:`simcalib.pipeline.uncertainty_inputs.basis_layout`), or None.
    * ``datapoint_error_basis(st, world, cam, T_world_cam, frame_index, layout)``: the same
      at a run's measured datapoints (the source reads what its log recorded), or None.
    * ``calibration_bias(world, cfg, cameras) -> {cam: bias}``: the fixed pose bias its
      calibration inputs cause per camera (an object with ``covariance`` (6, 6) of the
      right-multiplied pose error and ``report()``, e.g.
      :class:`simcalib.sources.vision.error_model.CalibrationBias`), empty when it has none.
    * ``check_config(cfg)``: raise :class:`~simcalib.errors.ConfigError` when a simulated
      scenario that uses this source cannot work (checked with the scenario, before any
      work).
    """

    def pose_margins(self, cfg) -> tuple[float, float]:
        return 0.0, 0.0

    def check_config(self, cfg) -> None:
        return None

    @property
    def has_error_basis(self) -> bool:
        """The source models systematic pose errors (it overrides
        :meth:`datapoint_error_basis`)."""
        return type(self).datapoint_error_basis is not SourceHooks.datapoint_error_basis

    def error_basis(self, world, cfg, cam, T_world_cam, layout, qpos=None, visible=None):
        return None

    def datapoint_error_basis(self, st, world, cam, T_world_cam, frame_index, layout):
        return None

    def calibration_bias(self, world, cfg, cameras) -> dict:
        return {}
