"""The end-to-end run: world -> pose streams -> motion pairs -> solvers -> evaluation.

``simcalib.run(config) -> RunResult`` (plain data). Every random draw comes from a child of
``np.random.SeedSequence(config.seed)``; one child per stage, always spawned in the same
order, so a stage's draws do not depend on what other stages drew.

Outputs (run directory): ``config.yaml`` (resolved), ``results.json``, ``extrinsics.json``,
``tum/<camera>_<source>.tum``, ``recording.rrd``; a summary table on stdout.
A ``KeyboardInterrupt`` closes the recording (readable), writes results.json with
``status: "interrupted"`` and the finished stages, and raises :class:`RunInterrupted`;
any other exception writes results.json with ``status: "failed"`` and ``error`` (type,
message, stage) and propagates.

The run is the plain sequence :data:`STAGES` of functions ``_stage_<name>(RunState)``;
none of them branches on ``kind`` or ``source`` (the ground truth comes from
:func:`simcalib.sources.build_truth`, the measurements from the registered
:mod:`simcalib.sources`), and none of them writes the recording: after each stage,
:meth:`simcalib.report.rerun.run.RunRecorder.record_stage` logs what it produced.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simcalib.pipeline.scenario import ScenarioConfig
from simcalib.sources import get_source
from simcalib.evaluation import estimate_errors, pose_source_errors
from simcalib.geometry import (matrix_from_rotvec, rotation_error_rad,
                               transform_from_rotation_translation)
from simcalib.progress import progress, progress_line, stage_frames

if TYPE_CHECKING:  # types of the state only; the stages import lazily
    from simcalib.estimation.pairing import MotionPairs
    from simcalib.sources import GroundTruth
    from simcalib.streams import PoseStream

__all__ = ["RunResult", "RunState", "SolverResult", "RunInterrupted", "run", "STAGES",
           "RNG_STREAMS", "run_rngs", "state_through_pairs"]

STAGES = ("world", "streams", "pairs", "solvers", "evaluation", "reports")
CAMERAS = ("cam_a", "cam_b")
# order of the child generators spawned from the run's seed (never reorder: determinism)
RNG_STREAMS = ("world", "noise", "vision", "synthetic", "pairing", "solvers", "prior",
               "robot", "encoders", "outliers")


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
    #                                           pose-noise test, simulated bias)


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


def _output_dir(cfg: ScenarioConfig) -> Path:
    """The run directory, checked before any work (:func:`simcalib.report.outputs.
    check_output_dir`: not a file, no earlier results unless ``overwrite``); the default
    ``runs/<scenario>-<timestamp>`` gets a ``-2``, ``-3``... suffix when taken."""
    from simcalib.report.outputs import check_output_dir, earlier_results
    if cfg.output:
        return check_output_dir(cfg.output, cfg.overwrite)
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    base = Path("runs") / f"{cfg.scenario}-{stamp}"
    out, n = base, 1
    while out.exists() and (not out.is_dir() or earlier_results(out)):
        n += 1
        out = base.with_name(f"{base.name}-{n}")
    return out


def _stages():
    """The run: ``(name, function(state))`` in order (looked up at call time)."""
    return (("world", _stage_world), ("streams", _stage_streams), ("pairs", _stage_pairs),
            ("solvers", _stage_solvers), ("evaluation", _stage_evaluation),
            ("reports", _stage_reports))


def run_rngs(seed: int) -> dict:
    """One generator per stage (:data:`RNG_STREAMS`), children of ``SeedSequence(seed)``."""
    children = np.random.SeedSequence(seed).spawn(len(RNG_STREAMS))
    return {name: np.random.default_rng(s) for name, s in zip(RNG_STREAMS, children)}


def state_through_pairs(cfg, truth=None) -> "RunState":
    """The stages world, streams and pairs of a run of ``cfg`` (no output directory, no
    solvers, no recording): the same data a run solves. ``truth``: a world already built
    (e.g. one path for a Monte-Carlo over the measurement) used instead of the world stage."""
    st = RunState(cfg=cfg, out=None, rngs=run_rngs(cfg.seed))
    if truth is None:
        _stage_world(st)
    else:
        st.truth = truth
    _stage_streams(st)
    _stage_pairs(st)
    return st


def run(config, overrides=(), *, echo: bool = True) -> RunResult:
    """Run one scenario end to end and write its outputs; see the module docstring.

    ``config``: a :class:`ScenarioConfig` (``simcalib.load_config(...)``) or a scenario
    name / YAML path, resolved with ``overrides`` (``["seed=3", ...]``).
    ``echo`` prints the summary table to stdout.

    Stages are plain functions of a :class:`RunState`; after each one the recording (if
    enabled) is written from what it produced (:meth:`RunRecorder.record_stage`). An
    exception in a stage writes results.json with ``status: "failed"`` and the error, then
    propagates; Ctrl-C raises :class:`RunInterrupted` with the partial result.
    """
    if isinstance(config, (str, Path)):
        from simcalib.pipeline.scenario import load_config
        config = load_config(str(config), list(overrides))
    elif overrides:
        raise TypeError("overrides are only accepted with a scenario name; apply them with "
                        "simcalib.load_config(name, overrides)")
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig (simcalib.load_config(...)); "
                        f"received {type(config).__name__}")
    import yaml
    from simcalib.config.engine import to_dict
    from simcalib.report import results as reports
    cfg = config
    out = _output_dir(cfg)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.yaml").write_text(yaml.safe_dump(to_dict(cfg), sort_keys=False))
    t_start = time.perf_counter()
    st = RunState(cfg=cfg, out=out, rngs=run_rngs(cfg.seed), t_start=t_start)
    recorder = None
    # the worker hides rerun's import: a process that imported it already logs itself
    background = cfg.recording.background and "rerun" not in sys.modules
    worker = sys.modules.get("simcalib.report.rerun.worker")
    if worker is not None and not (cfg.recording.enabled and background):
        worker.cancel_prestarted_worker()   # one `simcalib run` started would only compete
    if cfg.recording.enabled:
        from simcalib.report.rerun.run import RunRecorder
        recorder = RunRecorder(out / "recording.rrd", cfg, background=background)
    rec_path = None if recorder is None else recorder.path
    kernels = _prepare_kernels(st)
    bar = progress(total=len(STAGES), enabled=cfg.progress, desc="stages",
                           unit="stage", position=0)
    where = None   # the stage running (or whose results are being recorded)
    try:
        for stage, fn in _stages():
            where = stage
            bar.set_description(stage)
            t0 = time.perf_counter()
            with kernels(), stage_frames(bar, stage, len(st.done),
                                                 enabled=cfg.progress):
                fn(st)
            st.timing[stage] = time.perf_counter() - t0
            st.done.append(stage)
            progress_line(f"{stage} done in {st.timing[stage]:.1f} s "
                                  f"({len(st.done)}/{len(STAGES)})", enabled=cfg.progress)
            st.timing["total"] = time.perf_counter() - t_start
            if recorder is not None:
                where = f"recording ({stage})"
                recorder.record_stage(stage, st)
            bar.update(1)
        if recorder is not None:
            recorder.close()
        bar.close()
        if echo:
            print(st.summary)
            print(f"wrote {out}/results.json, extrinsics.json, tum/, "
                  f"{'recording.rrd ' if recorder is not None else ''}"
                  f"in {st.timing['total']:.1f} s")
        return st.result(results_path=out / "results.json", recording_path=rec_path)
    except KeyboardInterrupt:
        bar.close()
        st.timing["total"] = time.perf_counter() - t_start
        partial = st.result(interrupted=True, recording_path=rec_path)
        try:
            if recorder is not None:
                recorder.close()
            rp = reports.write_json(out / "results.json", reports.results_dict(partial))
            partial = dataclasses.replace(partial, results_path=rp)
        except Exception:  # keep the interrupt as the reported cause
            pass
        raise RunInterrupted(partial) from None
    except BaseException as exc:
        bar.close()
        st.timing["total"] = time.perf_counter() - t_start
        st.error = {"type": type(exc).__name__, "message": str(exc), "stage": where}
        try:
            if recorder is not None:
                recorder.close()
            reports.write_json(out / "results.json",
                               reports.results_dict(st.result(recording_path=rec_path)))
        except Exception:  # noqa: BLE001 - the stage's exception is the one to report
            pass
        raise


def _prepare_kernels(st: RunState):
    """How this run's solves execute (:func:`simcalib.solvers.kernels.mode.prepare_kernels`,
    ``$SIMCALIB_KERNELS``); returns the context every stage runs in."""
    from simcalib.solvers.kernels.mode import prepare_kernels
    plan = prepare_kernels()
    st.solver_kernels = plan.mode
    st.kernel_loader = plan.loader
    return plan.context


# ----------------------------------------------------------------------------- stages
def _stage_world(st: RunState) -> None:
    from simcalib.sources import build_truth
    st.truth = build_truth(st.cfg, st.rngs)


def _stage_streams(st: RunState) -> None:
    """Each camera's pose source measures the truth (sources grouped so a source that
    serves both cameras runs once)."""
    from simcalib.sources import camera_sources
    kind = st.truth.kind
    st.camera_sources = camera_sources(st.cfg, kind)
    by_source: dict[str, list] = {}
    for cam, name in st.camera_sources.items():
        by_source.setdefault(name, []).append(cam)
    frames = {}
    for name, cams in by_source.items():
        src = get_source(name, kind)
        out = src.measure(st.truth, st.cfg, st.rngs[src.info.rng_stream], tuple(cams))
        st.source_logs[name] = out.log
        st.measured.update({cam: out.streams[cam] for cam in cams if cam in out.streams})
        st.source_pose_errors.update(dict(out.pose_errors or {}))
        if out.motions is not None:
            if len(by_source) > 1:
                raise ValueError(f"source {name!r} measures relative motions of both cameras; "
                                 f"it cannot be combined with other sources "
                                 f"({st.camera_sources})")
            st.motions_from_source = out.motions
            st.pairing_mode = out.pairing_mode
        frames |= dict(out.frames) if out.frames is not None else {}
    from simcalib.world.eyetohand import express_in_fixed_camera
    st.truth, st.measured = express_in_fixed_camera(st.truth, st.measured, st.cfg.world)
    _corrupt_streams(st)
    if not frames:
        frames = {"rendered": max(int(s.n_frames) for s in st.measured.values())}
        for cam in CAMERAS:
            s = st.measured[cam]
            frames[cam] = {"frames": int(s.n_frames), "used": int(s.n_used),
                           "dropped": int(s.n_dropped),
                           "drop_reasons": {str(k): int(v) for k, v in
                                            dict(s.drop_reasons).items()}}
    st.frames = frames


def _corrupt_streams(st: RunState) -> None:
    """After the sources measured: injected outliers (``outliers.*``, labelled) and the
    record of each stream's source, the robot error and the clocks (results.json)."""
    from simcalib.sources.corruption import clock_report, inject_outliers
    from simcalib.world.robot_error import robot_report
    cfg, truth = st.cfg, st.truth
    st.sensing["stream_sources"] = dict(st.camera_sources)
    if truth.world is not None:
        robot_log = next((log for name, log in st.source_logs.items()
                          if get_source(name).info.reads_joints), None)
        st.sensing["robot"] = robot_report(truth.world, cfg, robot_log)
        st.sensing["clocks"] = clock_report(truth.world)
    if cfg.outliers.active and not st.measured:
        raise ValueError("outliers.* needs pose streams; a source of relative motions "
                         f"({', '.join(sorted(set(st.camera_sources.values())))}) has none")
    field = truth.marker_field      # a board target has no marker map (no marker to flip)
    if field is not None and len(getattr(field, "ids", ())) == 0:
        field = None
    st.measured, st.sensing["outliers"] = inject_outliers(
        st.measured, cfg.outliers, st.rngs["outliers"], field)


def _stage_pairs(st: RunState) -> None:
    from simcalib.estimation.streams import motions_from_streams
    from simcalib.sources.corruption import outlier_pairs
    cfg = st.cfg
    if st.motions_from_source is not None:
        st.pairs = st.motions_from_source
        st.pairing = dict(st.pairs.counts) | {"mode": st.pairing_mode}
        return
    st.pairs, st.pairing, report = motions_from_streams(st.measured, cfg, st.rngs["pairing"],
                                                        st.sensing)
    if report is not None:
        st.sensing["estimation"] = report
    if st.sensing.get("outliers", {}).get("enabled"):
        st.sensing["outliers"]["pairs"] = outlier_pairs(st.pairs, st.sensing["outliers"])


def _verdict(sol) -> dict:
    """The headline verdict fields of a :class:`SolverResult` from ``sol.uncertainty``
    (simcalib.solvers.diagnostics.uncertainty): degenerate, the directions in words, the
    flagged translation axes not fixed by a prior (undetermined or poorly determined:
    projected out of ``translation_error_determined_m``),
    covariance, std, predicted RMS errors."""
    u = sol.uncertainty
    if u is None:
        return {"degenerate": None, "verdict": "unknown", "undetermined": (
            "uncertainty unavailable (the residuals of X are not finite)",)}
    from simcalib.report.directions import direction_record
    words, dirs, axes = [], [], []
    for d in u.directions:
        words.append(d.summary())
        dirs.append(direction_record(d))   # its state and sigma decided once, with it
        if d.kind == "translation" and not d.determined_by_prior:
            axes.append(np.asarray(d.translation_dir_a, dtype=np.float64))
    cov = np.asarray(u.covariance, dtype=np.float64)
    std = np.asarray(u.std, dtype=np.float64)
    return {"degenerate": bool(u.degenerate), "verdict": u.verdict,
            "undetermined": tuple(words), "undetermined_directions": tuple(dirs),
            "undetermined_translation_axes": np.array(axes).reshape(-1, 3) if axes else None,
            "covariance": cov, "std_deg": tuple(float(x) for x in std[:3]),
            "std_m": tuple(float(x) for x in std[3:]),
            "sigma_rotation_deg": float(np.degrees(np.sqrt(np.trace(cov[:3, :3])))),
            "sigma_translation_m": float(np.sqrt(np.trace(cov[3:, 3:])))}


def _singular_values(sol):
    try:
        return np.asarray(sol.observability.singular_values, dtype=np.float64)
    except Exception:  # noqa: BLE001 - descriptive only
        return None


def _prior(st: RunState):
    from simcalib.solvers.api import Prior
    pc = st.cfg.prior
    if pc.translation_m is not None:
        X = transform_from_rotation_translation(
            matrix_from_rotvec(np.deg2rad(np.asarray(pc.rotvec_deg))), np.asarray(
                pc.translation_m))
        origin = "given"
    else:
        rng = st.rngs["prior"]
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        direction = rng.standard_normal(3)
        direction /= np.linalg.norm(direction)
        dR = matrix_from_rotvec(axis * np.deg2rad(pc.rotation_error_deg))
        X = st.X_true.copy()
        X[:3, :3] = X[:3, :3] @ dR
        X[:3, 3] = X[:3, 3] + direction * pc.translation_error_m
        origin = "true X perturbed"
    info = {"X": X.tolist(), "a": pc.a, "b": pc.b, "origin": origin,
            "rotation_error_deg": float(np.rad2deg(rotation_error_rad(X, st.X_true))),
            "translation_error_m": float(np.linalg.norm(X[:3, 3] - st.X_true[:3, 3]))}
    return Prior(X=X, a=pc.a, b=pc.b), info


def _stage_solvers(st: RunState) -> None:
    from simcalib.report import results as reports
    cfg = st.cfg
    if st.kernel_loader is not None:
        t0 = time.perf_counter()
        st.kernel_loader.join()
        st.kernel_loader = None
        st.timing["waited_for_kernels"] = time.perf_counter() - t0
    jobs = [(m, m, False) for m in cfg.solvers]
    prior = prior_info = None
    if cfg.prior.enabled:
        prior, prior_info = _prior(st)
        jobs += [(f"{m}+prior", m, True) for m in cfg.prior.methods]
    rng_children = st.rngs["solvers"].spawn(len(jobs))
    C, H = st.pairs.C, st.pairs.H
    st.pose_bias, st.sensing["calibration_bias"] = calibration_bias(st)
    st.pose_error_basis = pose_error_basis(st)
    choice = choose_run_alpha(cfg, C, H)
    for (label, method, with_prior), rng in zip(
            progress(jobs, enabled=cfg.progress, desc="solvers", unit="method",
                             position=1), rng_children):
        st.solvers.append(_solve_one(st, label, method, prior if with_prior else None,
                                     prior_info if with_prior else None, C, H, rng, choice))


def choose_run_alpha(cfg, C, H) -> dict:
    """The alpha of a run's headline estimates, never from the ground truth.

    ``alpha: <number>``: that alpha. ``alpha: auto`` or a list: dqopt at alpha = 1, then
    :func:`simcalib.solvers.diagnostics.uncertainty.choose_alpha` (``noise_ratio``) from its
    residuals. Returns ``{"alpha", "how", "source", ...}`` (results.json ``alpha_choice``)."""
    if cfg.alpha != "auto" and not isinstance(cfg.alpha, tuple):
        return {"alpha": float(cfg.alpha), "source": "config", "how": "given in the config"}
    from simcalib.solvers.api import solve
    from simcalib.solvers.diagnostics.uncertainty import choose_alpha
    try:
        sol = solve(C, H, method="dqopt", alpha=1.0)
        if not sol.success or not np.isfinite(sol.X).all():
            raise ValueError(sol.solver_message or "dqopt failed")
        ch = choose_alpha(C, H, sol.X, 1.0, tolerance_deg=cfg.verdict.tolerance_deg,
                          tolerance_m=cfg.verdict.tolerance_m)
    except Exception as exc:  # noqa: BLE001 - fall back, and say so
        return {"alpha": 1.0, "source": "fallback",
                "how": f"alpha = 1: the data-driven choice failed ({type(exc).__name__}: "
                       f"{exc})"}
    return {"alpha": float(ch.alpha), "source": "data", "how": ch.how,
            "initial": "dqopt at alpha = 1", "sigma_r_deg": float(np.degrees(ch.sigma_r_rad)),
            "sigma_t_m": float(ch.sigma_t_m)}


def _failure_reason(sol) -> str | None:
    """Why ``sol`` is not an estimate (``None`` when it is one)."""
    X = np.asarray(sol.X, dtype=np.float64)
    if not sol.success:
        return sol.solver_message or "the solver reported failure"
    if X.shape != (4, 4) or not np.isfinite(X).all():
        return "non-finite X"
    return None


def _failed(label, method, prior_info, reason, sweep=(), choice=None, oracle=None,
            convergence=()) -> SolverResult:
    return SolverResult(label=label, method=method, alpha=None, prior=prior_info, X=None,
                        rotation_error_deg=None, translation_error_m=None,
                        translation_error_determined_m=None, cost=None, runtime_s=None,
                        success=False, degenerate=None, error=reason.splitlines()[0],
                        message=f"{method}: FAILED ({reason.splitlines()[0]})",
                        sweep=tuple(sweep), alpha_choice=choice, oracle=oracle,
                        convergence=tuple(convergence))


def calibration_bias(st) -> tuple:
    """The known calibration uncertainty of the run's cameras, an input of the covariance
    (``solve(..., pose_bias=...)``): ``(PoseBias or None, report)``. A camera measured by
    the ``aruco`` source gets the covariance of the run-constant pose error that
    ``vision.intrinsics_error`` (read as the 1-sigma of the calibration the estimator has)
    and the marker map's error (``vision.map_position_std_m`` / ``map_rotation_std_deg``,
    the survey's accuracy) cause (:func:`simcalib.sources.vision.stream.calibration_pose_bias`, no
    rendering); other sources
    have no calibration term. ``report`` (results.json ``calibration_bias``):
    ``included`` and per camera its 1-sigma (deg, m) and inputs."""
    from simcalib.solvers.diagnostics.uncertainty import PoseBias
    truth = st.truth
    report = {"included": False, "source": "vision.intrinsics_error (1-sigma of the "
              "calibration) and vision.map_position_std_m / map_rotation_std_deg (marker "
              "map) through PnP of the marker corners seen from the true poses",
              "cameras": {}}
    if truth is None or truth.world is None:
        return None, report
    bias = {}
    for name in dict.fromkeys(st.camera_sources.get(c) for c in CAMERAS):
        if name is None:
            continue
        cams = [c for c in CAMERAS if st.camera_sources.get(c) == name]
        bias.update(get_source(name, "sim").calibration_bias(truth.world, st.cfg, cams))
    if not bias:
        return None, report
    report["included"] = True
    report["cameras"] = {c: b.report() for c, b in bias.items()}
    covs = [bias[c].covariance if c in bias else None for c in CAMERAS]
    return PoseBias(*covs), report


def _recorded(st) -> bool:
    """The run's motions came through the recorded-data path (``estimation.motions`` not
    ``pairing``)."""
    est = getattr(st.cfg, "estimation", None)
    return bool(est is not None and est.recorded)


def correlation_lag(st) -> int:
    """Pairs ``(k, k + step)`` of consecutive datapoints of pose streams share poses up to
    lag ``step``: the uncertainty corrects for that serial correlation. Relative motions
    from a source (synthetic) or random pairing: independent (0)."""
    if st.motions_from_source is not None or st.cfg.pairing.mode != "consecutive" \
            or _recorded(st):
        return 0
    return int(st.cfg.pairing.step)


def basis_layout(world) -> dict:
    """Columns of the systematic pose-error basis of a world (:func:`pose_error_basis`):
    ``map`` (6 per marker of the field: the survey error), ``cal_a`` / ``cal_b`` (8 each:
    the cameras' calibrations), ``dh`` (24: the arm's DH table, 4 per joint), ``P`` the
    total."""
    M = world.marker_field.T_world_marker.shape[0] if world.marker_field is not None else 0
    n = 6 * M
    return {"map": slice(0, n), "cal_a": slice(n, n + 8), "cal_b": slice(n + 8, n + 16),
            "dh": slice(n + 16, n + 40), "P": n + 40}


def stop_error_basis(world, cfg, cam: str, source: str, T_world_cam, qpos=None,
                     visible=None) -> np.ndarray | None:
    """``(F, 6, P)`` (:func:`basis_layout`) systematic pose errors of camera ``cam``
    measured by ``source`` at the poses ``T_world_cam`` (F, 4, 4): ``aruco`` — the marker
    map's and the camera's calibration errors (:func:`simcalib.sources.vision.stream.pose_error_basis`;
    ``visible`` the markers each pose rests on, default the layout's); ``robot_fk`` — the
    arm's DH deviation (``robot.kinematic_error``, :func:`simcalib.world.robot_error.
    fk_pose_error_basis`; ``qpos`` (F, nq) the MuJoCo joint state at each pose). None for
    other sources or when the configuration has no such error."""
    if source is None:
        return None
    return get_source(source, "sim").error_basis(world, cfg, cam, T_world_cam,
                                                 basis_layout(world), qpos=qpos,
                                                 visible=visible)


def pose_error_basis(st, compress: bool = True):
    """The known systematic pose errors of the run's datapoints, an input of the
    covariance (``solve(..., pose_error_basis=...)``; with :func:`pose_pairs`): ``(Ba, Bb)``
    ``(D, 6, P)`` for the ``D`` matched datapoints, or None. Per camera
    :func:`stop_error_basis` of its source at its measured poses (ArUco: with the markers
    the PnP used; robot_fk: the joint state of each frame), in the columns of
    :func:`basis_layout` (the map and the DH table are shared, each calibration is its
    camera's); other sources have zero columns. ``compress``: drop the columns no
    datapoint uses (markers never seen); False keeps the full layout (e.g. to add stops'
    bases in the same columns)."""
    truth = st.truth
    if pose_pairs(st) is None or truth is None or truth.world is None:
        return None
    world = truth.world
    frames = {"cam_a": np.asarray(st.pairs.frame_a), "cam_b": np.asarray(st.pairs.frame_b)}
    D = frames["cam_a"].shape[0]
    out = []
    for cam in CAMERAS:
        src = st.camera_sources.get(cam)
        B = None
        if src is not None and get_source(src, "sim").has_error_basis \
                and cam in world.camera_names and cam in st.measured:
            m = st.measured[cam]
            pos = {int(f): k for k, f in enumerate(np.asarray(m.frame_index))}
            if not all(int(f) in pos for f in frames[cam]):
                return None
            T = np.asarray(m.T_world_cam)[[pos[int(f)] for f in frames[cam]]]
            B = get_source(src, "sim").datapoint_error_basis(st, world, cam, T, frames[cam],
                                                              basis_layout(world))
        out.append(np.zeros((D, 6, basis_layout(world)["P"])) if B is None else B)
    used = np.any(out[0] != 0, axis=(0, 1)) | np.any(out[1] != 0, axis=(0, 1))
    if not used.any():
        return None
    if not compress:
        return tuple(out)
    return tuple(B[:, :, used] for B in out)     # markers never seen carry nothing


def pose_pairs(st):
    """``(N, 2)`` datapoint indices (start, end) of the run's motions when they are pairs of
    consecutive datapoints of the pose streams, or the recorded-data path's pairs of
    synchronised instants (they then share poses: the uncertainty tests the pose noise for
    whiteness and, if white, simulates with that structure); else None."""
    if st.pairs is None or (correlation_lag(st) == 0 and not _recorded(st)):
        return None
    return np.stack([np.asarray(st.pairs.start), np.asarray(st.pairs.end)], axis=1)


def _solve_at(st, method, alpha, prior, rng, C, H, pairs=None):
    """(solution, errors dict) at ``alpha``, or (solution or None, failure reason).
    ``pairs``: the motions' datapoint pairs (:func:`pose_pairs`), for the headline."""
    from simcalib.solvers.api import solve
    cfg = st.cfg
    sol = solve(C, H, method=method, alpha=alpha, prior=prior,
                         rng=np.random.default_rng(rng.bit_generator.seed_seq),
                         tolerance_deg=cfg.verdict.tolerance_deg,
                         tolerance_m=cfg.verdict.tolerance_m,
                         correlation_lag=correlation_lag(st), pose_bias=st.pose_bias,
                         pose_pairs=pairs,
                         pose_error_basis=st.pose_error_basis if pairs is not None else None,
                         pose_simulation=st.pose_simulation if pairs is not None and
                         prior is None else None)
    reason = _failure_reason(sol)
    if pairs is not None and prior is None and st.pose_simulation is None \
            and sol.uncertainty is not None and sol.uncertainty.simulation is not None:
        # one simulation per run: the covariance of the alpha-cost minimiser near X serves
        # every solver's headline (each adds its own offset from the minimiser)
        st.pose_simulation = sol.uncertainty.simulation
    if reason is not None:
        return sol, reason
    v = _verdict(sol)
    axes = v.get("undetermined_translation_axes")
    return sol, estimate_errors(sol.X, st.X_true, axes if v["degenerate"] else None)


def _solve_one(st, label, method, prior, prior_info, C, H, rng, choice) -> SolverResult:
    """The headline estimate at the data-chosen alpha (``choice``); with an alpha list in
    the config every alpha is solved too (``sweep``) and the one best against the ground
    truth is reported as ``oracle`` (it never replaces the headline)."""
    cfg = st.cfg
    sweep = []
    oracle = None
    try:
        if isinstance(cfg.alpha, tuple):
            best = None
            for alpha in cfg.alphas:
                sol_a, res = _solve_at(st, method, alpha, prior, rng, C, H)
                if isinstance(res, str):
                    sweep.append({"alpha": float(alpha), "rotation_error_deg": None,
                                  "translation_error_m": None,
                                  "translation_error_determined_m": None, "cost": None,
                                  "runtime_s": float(sol_a.runtime_s), "success": False,
                                  "error": res})
                    continue
                sweep.append({"alpha": float(alpha), **res, "cost": float(sol_a.cost),
                              "runtime_s": float(sol_a.runtime_s), "success": True,
                              "error": None, "verdict": sol_a.verdict})
                if best is None or res["rotation_error_deg"] < best["rotation_error_deg"]:
                    best = {"alpha": float(alpha), **res}
            if best is not None:
                oracle = {"uses_ground_truth": True,
                          "note": "the alpha of the config list with the lowest rotation "
                                  "error against the GROUND TRUTH (not available with real "
                                  "data; the headline uses the data-chosen alpha)",
                          "oracle_alpha": best["alpha"],
                          "rotation_error_deg": best["rotation_error_deg"],
                          "translation_error_m": best["translation_error_m"],
                          "translation_error_determined_m":
                              best["translation_error_determined_m"]}
        sol, res = _solve_at(st, method, choice["alpha"], prior, rng, C, H, pose_pairs(st))
        convergence = convergence_curve(st, method, choice["alpha"], prior, rng, C, H,
                                        last=(sol, res))
    except Exception as exc:  # noqa: BLE001 - one failing method must not sink the run
        return _failed(label, method, prior_info, f"{type(exc).__name__}: {exc}",
                       sweep, choice, oracle)
    if isinstance(res, str):
        return _failed(label, method, prior_info, res, sweep, choice, oracle, convergence)
    v = _verdict(sol)
    try:
        message = sol.message
    except Exception as exc:  # noqa: BLE001 - a broken diagnostic must not kill the run
        message = f"{sol.solver_message} (message unavailable: {exc})"
    degenerate = v["degenerate"]
    return SolverResult(
        label=label, method=method, alpha=float(sol.alpha), prior=prior_info,
        X=np.asarray(sol.X, dtype=np.float64), rotation_error_deg=res["rotation_error_deg"],
        translation_error_m=res["translation_error_m"],
        translation_error_determined_m=res["translation_error_determined_m"],
        cost=float(sol.cost), runtime_s=float(sol.runtime_s), success=True,
        degenerate=degenerate, undetermined=v["undetermined"] if degenerate is not False
        else (), undetermined_directions=v.get("undetermined_directions", ()),
        undetermined_translation_axes=v.get("undetermined_translation_axes"),
        singular_values=_singular_values(sol), message=message, sweep=tuple(sweep),
        covariance=v.get("covariance"), std_deg=v.get("std_deg"), std_m=v.get("std_m"),
        sigma_rotation_deg=v.get("sigma_rotation_deg"),
        sigma_translation_m=v.get("sigma_translation_m"), verdict=v["verdict"],
        verdict_directions=v["undetermined"] if degenerate is not False else (),
        alpha_choice=choice, oracle=oracle, convergence=tuple(convergence),
        covariance_calibration=None if sol.uncertainty is None
        else sol.uncertainty.bias_covariance, uncertainty_model=_uncertainty_model(sol))


def _uncertainty_model(sol) -> dict | None:
    """results.json ``uncertainty_model``: the covariance's method ("sandwich" or
    "pose_simulation"), the white pose-noise test of motions sharing poses, the simulated
    bias (deg, m)."""
    u = sol.uncertainty
    if u is None:
        return None
    t = u.pose_noise_test
    b = u.simulated_bias_determined          # null along the undetermined axes
    wn = u.white_pose_noise
    return {"method": u.method,
            "systematic_parameters": int(u.systematic_parameters),
            "white_pose_noise": None if wn is None else {
                "sigma_r_deg": math.degrees(wn[0]), "sigma_t_m": float(wn[1])},
            "pose_noise_test": None if t is None else t.to_dict(digits=4),
            "simulated_bias_deg": None if b is None else [
                float(x) if np.isfinite(x) else None for x in np.degrees(b[:3])],
            "simulated_bias_m": None if b is None else [
                float(x) if np.isfinite(x) else None for x in b[3:]]}


def convergence_points(n: int, points: int, k_min: int = 3) -> tuple[int, ...]:
    """Up to ``points`` log-spaced motion counts from ``k_min`` to ``n`` (distinct, with n)."""
    if points <= 0 or n < k_min:
        return ()
    ks = np.unique(np.round(np.geomspace(k_min, n, points)).astype(int))
    return tuple(int(k) for k in ks)


def convergence_curve(st, method, alpha, prior, rng, C, H, last=None) -> tuple[dict, ...]:
    """Solve on the first k motions for growing k (``verdict.convergence_points`` log-spaced
    values): per k the errors against the ground truth, the predicted 1-sigma (RMS of the
    rotation / translation error; None when undetermined) and the verdict. The curve a user
    looks at to see when the motion became rich enough. ``last``: the headline's
    ``(solution, errors)``, used for k = all motions (the points before it use the
    first-order uncertainty; only the headline runs the pose-noise simulation)."""
    out = []
    for k in convergence_points(C.shape[0], st.cfg.verdict.convergence_points):
        try:
            if last is not None and k == C.shape[0]:
                sol, res = last
            else:
                sol, res = _solve_at(st, method, alpha, prior, rng, C[:k], H[:k])
        except ValueError as exc:   # too few usable motions for this method
            out.append({"k": k, "success": False, "error": str(exc).splitlines()[0]})
            continue
        if isinstance(res, str):
            out.append({"k": k, "success": False, "error": res.splitlines()[0]})
            continue
        v = _verdict(sol)
        out.append({"k": k, "success": True, "rotation_error_deg": res["rotation_error_deg"],
                    "translation_error_m": res["translation_error_m"],
                    "sigma_rotation_deg": v.get("sigma_rotation_deg"),
                    "sigma_translation_m": v.get("sigma_translation_m"),
                    "verdict": v["verdict"]})
    return tuple(out)


def _stage_evaluation(st: RunState) -> None:
    """Pose-source errors per camera: the source's own (relative motions) or its stream
    against the ground truth at the same frames."""
    st.pose_errors = {cam: st.source_pose_errors[cam] if cam in st.source_pose_errors
                      else pose_source_errors(st.measured[cam], st.truth.streams[cam])
                      for cam in CAMERAS}


def _stage_reports(st: RunState) -> None:
    """Summary table, TUM files, extrinsics.json, results.json."""
    from simcalib.report import results as reports
    from simcalib.sources import get_source
    from simcalib.pipeline.eye_to_hand import eye_to_hand_report
    t0 = time.perf_counter()
    out = st.out
    e2h = eye_to_hand_report(st)
    if e2h is not None:
        st.sensing["eye_to_hand"] = e2h
    from simcalib.report.console import summary_table
    st.summary = summary_table(st.result())
    tum = out / "tum"
    tum.mkdir(exist_ok=True)
    world = st.truth.world
    for cam, s in st.gt.items():   # ground truth at the TRUE capture times (sensor clocks aside)
        t_true = (s.timestamp_s if world is None
                  else np.asarray(world.frames(cam).time_s)[np.asarray(s.frame_index)])
        reports.write_tum(tum / f"{cam}_ground_truth.tum", t_true, s.T_world_cam)
    for cam, s in st.measured.items():
        name = st.camera_sources[cam]
        if not get_source(name).info.exact:
            reports.write_tum(tum / f"{cam}_{name}.tum", s.timestamp_s, s.T_world_cam)
    reports.write_json(out / "extrinsics.json", reports.extrinsics_dict(st.result()))
    now = time.perf_counter()
    done = st.result()
    done = dataclasses.replace(done, completed_stages=done.completed_stages + ("reports",),
                               timing_s=done.timing_s | {"reports": now - t0,
                                                         "total": now - st.t_start})
    reports.write_json(out / "results.json", reports.results_dict(done))
