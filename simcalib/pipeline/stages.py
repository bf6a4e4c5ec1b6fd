"""The end-to-end run: world -> pose streams -> motion pairs -> solvers -> evaluation.

``simcalib.run(config) -> RunResult`` (plain data, :mod:`simcalib.pipeline.state`). Every
random draw comes from a child of ``np.random.SeedSequence(config.seed)``; one child per
stage, always spawned in the same order (:data:`~simcalib.pipeline.state.RNG_STREAMS`), so
a stage's draws do not depend on what other stages drew.

Outputs (run directory): ``config.yaml`` (resolved), ``results.json``, ``extrinsics.json``,
``tum/<camera>_<source>.tum``, ``recording.rrd``; a summary table on stdout.
A ``KeyboardInterrupt`` closes the recording (readable), writes results.json with
``status: "interrupted"`` and the finished stages, and raises :class:`RunInterrupted`;
any other exception writes results.json with ``status: "failed"`` and ``error`` (type,
message, stage) and propagates.

The run is the plain sequence :data:`STAGES` of functions ``stage(RunState)``: world,
streams, pairs and evaluation here, the solvers in :mod:`simcalib.pipeline.solver_stage`;
none of them branches on ``kind`` or ``source`` (the ground truth comes from
:func:`simcalib.sources.build_truth`, the measurements from the registered
:mod:`simcalib.sources`), and none of them writes the recording: after each stage,
:meth:`simcalib.report.rerun.run.RunRecorder.record_stage` logs what it produced.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import sys
import time
from pathlib import Path

import numpy as np

from simcalib.evaluation import pose_source_errors
from simcalib.pipeline.scenario import ScenarioConfig
from simcalib.pipeline.solver_stage import stage_solvers
from simcalib.pipeline.state import CAMERAS, RunInterrupted, RunResult, RunState, run_rngs
from simcalib.progress import progress, progress_line, stage_frames
from simcalib.sources import get_source

__all__ = ["STAGES", "run", "state_through_pairs"]

STAGES = ("world", "streams", "pairs", "solvers", "evaluation", "reports")


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
            ("solvers", stage_solvers), ("evaluation", _stage_evaluation),
            ("reports", _stage_reports))


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
    cfg = _resolved(config, overrides)
    out = _prepared_output(cfg)
    t_start = time.perf_counter()
    st = RunState(cfg=cfg, out=out, rngs=run_rngs(cfg.seed), t_start=t_start)
    recorder = _recorder(cfg, out)
    rec_path = None if recorder is None else recorder.path
    kernels = _prepare_kernels(st)
    bar = progress(total=len(STAGES), enabled=cfg.progress, desc="stages",
                   unit="stage", position=0)
    try:
        _run_stages(st, kernels, bar, recorder)
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
        raise RunInterrupted(_interrupted_result(st, recorder, rec_path)) from None
    except BaseException as exc:
        bar.close()
        _write_failure(st, recorder, rec_path, exc)
        raise


def _resolved(config, overrides) -> ScenarioConfig:
    """The run's :class:`ScenarioConfig`: ``config`` itself, or the scenario it names
    resolved with ``overrides``."""
    if isinstance(config, (str, Path)):
        from simcalib.pipeline.scenario import load_config
        config = load_config(str(config), list(overrides))
    elif overrides:
        raise TypeError("overrides are only accepted with a scenario name; apply them with "
                        "simcalib.load_config(name, overrides)")
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig (simcalib.load_config(...)); "
                        f"received {type(config).__name__}")
    return config


def _prepared_output(cfg: ScenarioConfig) -> Path:
    """The run directory (:func:`_output_dir`), created, with the resolved ``config.yaml``."""
    import yaml
    from simcalib.config.engine import to_dict
    from simcalib.config.files import output_folder
    out = output_folder(_output_dir(cfg))
    (out / "config.yaml").write_text(yaml.safe_dump(to_dict(cfg), sort_keys=False))
    return out


def _recorder(cfg: ScenarioConfig, out: Path):
    """The run's :class:`~simcalib.report.rerun.run.RunRecorder`, or None without a
    recording (a worker process started ahead for it is then cancelled)."""
    # the worker hides rerun's import: a process that imported it already logs itself
    background = cfg.recording.background and "rerun" not in sys.modules
    worker = sys.modules.get("simcalib.report.rerun.worker")
    if worker is not None and not (cfg.recording.enabled and background):
        worker.cancel_prestarted_worker()   # one `simcalib run` started would only compete
    if not cfg.recording.enabled:
        return None
    from simcalib.report.rerun.run import RunRecorder
    return RunRecorder(out / "recording.rrd", cfg, background=background)


def _run_stages(st: RunState, kernels, bar, recorder) -> None:
    """Every stage in order, each followed by the recording of what it produced;
    ``st.stage`` names the one running (or being recorded)."""
    cfg = st.cfg
    for stage, fn in _stages():
        st.stage = stage
        bar.set_description(stage)
        t0 = time.perf_counter()
        with kernels(), stage_frames(bar, stage, len(st.done), enabled=cfg.progress):
            fn(st)
        st.timing[stage] = time.perf_counter() - t0
        st.done.append(stage)
        progress_line(f"{stage} done in {st.timing[stage]:.1f} s "
                      f"({len(st.done)}/{len(STAGES)})", enabled=cfg.progress)
        st.timing["total"] = time.perf_counter() - st.t_start
        if recorder is not None:
            st.stage = f"recording ({stage})"
            recorder.record_stage(stage, st)
        bar.update(1)


def _interrupted_result(st: RunState, recorder, rec_path) -> RunResult:
    """The partial result of an interrupted run, its recording closed and its
    results.json (``status: "interrupted"``) written when possible."""
    from simcalib.report import results as reports
    st.timing["total"] = time.perf_counter() - st.t_start
    partial = st.result(interrupted=True, recording_path=rec_path)
    try:
        if recorder is not None:
            recorder.close()
        rp = reports.write_json(st.out / "results.json", reports.results_dict(partial))
        partial = dataclasses.replace(partial, results_path=rp)
    except Exception:  # keep the interrupt as the reported cause
        pass
    return partial


def _write_failure(st: RunState, recorder, rec_path, exc: BaseException) -> None:
    """Close the recording and write results.json with ``status: "failed"`` and the error
    (type, message, stage) of a run that raised ``exc``."""
    from simcalib.report import results as reports
    st.timing["total"] = time.perf_counter() - st.t_start
    st.error = {"type": type(exc).__name__, "message": str(exc), "stage": st.stage}
    try:
        if recorder is not None:
            recorder.close()
        reports.write_json(st.out / "results.json",
                           reports.results_dict(st.result(recording_path=rec_path)))
    except Exception:  # noqa: BLE001 - the stage's exception is the one to report
        pass


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
