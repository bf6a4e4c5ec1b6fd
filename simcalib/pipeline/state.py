"""The state of a run: what the stages fill in (:class:`RunState`), what a run returns
(:class:`RunResult`, one :class:`SolverResult` per estimate), and the run's random
generators (:data:`RNG_STREAMS`: one child of ``np.random.SeedSequence(seed)`` per stream,
always spawned in the same order, so a stage's draws do not depend on what other stages
drew). Plain data: the stages are :mod:`simcalib.pipeline.stages`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simcalib.pipeline.scenario import ScenarioConfig
from simcalib.streams import CAMERAS

if TYPE_CHECKING:  # types of the state only; the stages import lazily
    from simcalib.estimation.pairing import MotionPairs
    from simcalib.sources import GroundTruth
    from simcalib.streams import PoseStream

__all__ = ["CAMERAS", "RNG_STREAMS", "RunRngs", "RunInterrupted", "RunResult", "RunState", "SolverResult",
           "run_rngs"]

#: The random streams that existed when seeds were first fixed: child ``i`` of
#: ``SeedSequence(seed)`` is ``RNG_STREAMS[i]``. This tuple is history, not a registry: it
#: fixes every seed's draws of these streams, so it is never reordered or extended. Any
#: other name (a new stage's, or a new pose source's ``SourceInfo.rng_stream``) gets a
#: stream derived from its name (:func:`run_rngs`), so a new source edits no list.
RNG_STREAMS = ("world", "noise", "vision", "synthetic", "pairing", "solvers", "prior",
               "robot", "encoders", "outliers")
#: first word of the spawn key of a stream named after :data:`RNG_STREAMS` ("name")
_NAMED_STREAM = 0x6E616D65


@dataclass(frozen=True)
class SolverResult:
    """One solver's estimate (``label`` is the method, ``<method>+prior`` with a prior).

    A failed solver (``success`` False, an exception, or a non-finite X) has ``X=None``,
    no errors, and ``error`` the reason: it is never reported as an estimate."""
    label: str
    method: str
    alpha: float | None
    prior: dict | None
    X: np.ndarray | None
    rotation_error_deg: float | None
    translation_error_m: float | None
    translation_error_determined_m: float | None
    cost: float | None
    runtime_s: float | None
    success: bool
    degenerate: bool | None
    undetermined: tuple[str, ...] = ()
    undetermined_directions: tuple[dict, ...] = ()
    undetermined_translation_axes: np.ndarray | None = None   # flagged, not fixed by a prior
    singular_values: np.ndarray | None = None
    message: str = ""
    error: str | None = None
    sweep: tuple[dict, ...] = ()
    # uncertainty of the headline estimate and how its alpha was chosen
    covariance: np.ndarray | None = None      # 6x6 (wx,wy,wz,vx,vy,vz) rad/m; inf: undetermined
    std_deg: tuple[float, ...] | None = None  # 1-sigma rotation about x, y, z (frame a)
    std_m: tuple[float, ...] | None = None    # 1-sigma translation along x, y, z (frame a)
    sigma_rotation_deg: float | None = None   # predicted RMS of the rotation error
    sigma_translation_m: float | None = None  # predicted RMS of the translation error
    verdict: str = "FAILED"                   # determined / poorly determined / undetermined
    verdict_directions: tuple[str, ...] = ()  # each flagged direction in words with sigma
    alpha_choice: dict | None = None          # {"alpha", "how", ...}: never the ground truth
    oracle: dict | None = None                # alpha of the config list best vs the TRUTH
    convergence: tuple[dict, ...] = ()        # error and predicted sigma vs motions used
    covariance_calibration: np.ndarray | None = None   # part of covariance from the cameras'
    #                                                  calibration uncertainty (6x6), or None
    uncertainty_model: dict | None = None     # how the covariance was computed (method,


@dataclass(frozen=True)
class RunResult:
    """Everything a run produced, as plain data (see docs/results-schema.md)."""
    config: ScenarioConfig
    output_dir: Path
    camera_names: tuple[str, ...]
    X_true: np.ndarray | None
    frames: dict
    pairing: dict
    pose_errors: dict
    solvers: tuple[SolverResult, ...]
    timing_s: dict
    completed_stages: tuple[str, ...]
    interrupted: bool = False
    results_path: Path | None = None
    recording_path: Path | None = None
    error: dict | None = None
    sensing: dict = field(default_factory=dict)
    #: ``"compiled"`` (numba) or ``"interpreted"`` (first run on an installation: the
    #: kernels' Python functions; see :func:`simcalib.solvers.kernels.jit.interpreted`)
    solver_kernels: str = "compiled"

    @property
    def status(self) -> str:
        """``"complete"``, ``"interrupted"`` (Ctrl-C) or ``"failed"`` (``error`` says why)."""
        return ("interrupted" if self.interrupted else "failed" if self.error is not None
                else "complete")

    def solver(self, label: str) -> SolverResult:
        for s in self.solvers:
            if s.label == label:
                return s
        raise KeyError(f"no solver result {label!r}; have {[s.label for s in self.solvers]}")


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`run`; ``.result`` holds the partial :class:`RunResult`."""

    def __init__(self, result: RunResult):
        self.result = result
        done = ", ".join(result.completed_stages) or "none"
        super().__init__(f"interrupted; finished stages: {done}; partial results and a "
                         f"readable recording in {result.output_dir}")

    def __str__(self):
        return self.args[0]


# ------------------------------------------------------------------------------ state
@dataclass
class RunState:
    """The typed state the stages fill in order (each stage reads what earlier ones wrote).

    ``truth`` (world): :class:`~simcalib.sources.GroundTruth`; ``camera_sources``,
    ``measured``, ``source_logs``, ``motions_from_source``, ``frames`` (streams);
    ``pairs``, ``pairing`` (pairs); ``solvers`` (solvers); ``pose_errors`` (evaluation);
    ``summary`` (reports). ``error``: ``{"type", "message", "stage"}`` of a failed run."""
    cfg: ScenarioConfig
    out: Path
    rngs: dict
    t_start: float = 0.0
    solver_kernels: str = "compiled"   # or "interpreted" (the first run on an installation)
    kernel_loader: object = None       # thread loading the compiled kernels from the cache
    timing: dict = field(default_factory=dict)
    done: list = field(default_factory=list)
    truth: GroundTruth | None = None
    camera_sources: dict[str, str] = field(default_factory=dict)   # camera -> source name
    measured: dict[str, PoseStream] = field(default_factory=dict)  # camera -> its stream
    source_logs: dict[str, object] = field(default_factory=dict)   # source -> its log
    source_pose_errors: dict = field(default_factory=dict)         # camera -> PoseErrors
    motions_from_source: MotionPairs | None = None
    pairing_mode: str = ""
    frames: dict = field(default_factory=dict)
    pairs: MotionPairs | None = None
    pairing: dict = field(default_factory=dict)
    pose_errors: dict = field(default_factory=dict)                # camera -> PoseErrors
    solvers: list[SolverResult] = field(default_factory=list)
    summary: str = ""
    error: dict | None = None
    stage: str | None = None    # the stage running, or whose results are being recorded
    sensing: dict = field(default_factory=dict)   # stream_sources, robot, clocks, outliers
    pose_bias: object = None    # uncertainty.PoseBias: calibration uncertainty of the cameras
    pose_error_basis: tuple | None = None   # (Ba, Bb): systematic pose errors per datapoint
    pose_simulation: object = None   # the headline's pose_noise.SimulatedError, shared

    @property
    def X_true(self):
        return None if self.truth is None else self.truth.X_true

    @property
    def gt(self) -> dict:
        return {} if self.truth is None else dict(self.truth.streams)

    def result(self, interrupted=False, results_path=None, recording_path=None) -> RunResult:
        return RunResult(config=self.cfg, output_dir=self.out, camera_names=CAMERAS,
                         X_true=self.X_true, frames=dict(self.frames),
                         pairing=dict(self.pairing), pose_errors=dict(self.pose_errors),
                         solvers=tuple(self.solvers), timing_s=dict(self.timing),
                         completed_stages=tuple(self.done), interrupted=interrupted,
                         results_path=results_path, recording_path=recording_path,
                         error=self.error, sensing=dict(self.sensing),
                         solver_kernels=self.solver_kernels)


class RunRngs(dict):
    """The run's generators by stream name: the :data:`RNG_STREAMS` by position, any
    other name on first use from ``SeedSequence(seed, spawn_key=("name", crc32(name)))``
    (independent of the positional ones and of each other, the same in every process)."""

    def __init__(self, seed: int):
        children = np.random.SeedSequence(seed).spawn(len(RNG_STREAMS))
        super().__init__((name, np.random.default_rng(s))
                         for name, s in zip(RNG_STREAMS, children))
        self.seed = int(seed)

    def __missing__(self, name: str) -> np.random.Generator:
        if not isinstance(name, str) or not name:
            raise KeyError(name)
        import zlib
        key = (_NAMED_STREAM, zlib.crc32(name.encode("utf-8")))
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=key))
        self[name] = rng
        return rng


def run_rngs(seed: int) -> RunRngs:
    """One generator per stream name (:class:`RunRngs`), children of ``seed``."""
    return RunRngs(seed)
