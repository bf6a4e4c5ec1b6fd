"""The end-to-end run: world -> pose streams -> motion pairs -> solvers -> evaluation.

``simcalib.run(config) -> RunResult`` (plain data). Every random draw comes from a child of
``np.random.SeedSequence(config.seed)``; one child per stage, always spawned in the same
order, so a stage's draws do not depend on what other stages drew.

Outputs (run directory): ``config.yaml`` (resolved), ``results.json``, ``extrinsics.json``,
``tum/<camera>_<source>.tum``, ``recording.rrd``; a summary table on stdout.
A ``KeyboardInterrupt`` closes the recording (readable), writes results.json with
``status: "interrupted"`` and the finished stages, and raises :class:`RunInterrupted`.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simcalib.config import ScenarioConfig
from simcalib.evaluation import PoseErrors, estimate_errors, pose_source_errors
from simcalib.geometry import (invert_transform, matrix_from_rotvec, rotation_error_rad,
                               transform_from_rotation_translation)

__all__ = ["RunResult", "SolverResult", "RunInterrupted", "run", "STAGES"]

STAGES = ("world", "streams", "pairs", "solvers", "evaluation", "reports")
CAMERAS = ("cam_a", "cam_b")
# order of the child generators spawned from the run's seed (never reorder: determinism)
_RNG_STREAMS = ("world", "noise", "vision", "synthetic", "pairing", "solvers", "prior")


@dataclass(frozen=True)
class SolverResult:
    """One solver's estimate (``label`` is the method, ``<method>+prior`` with a prior)."""
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
    undetermined_translation_axes: np.ndarray | None = None
    singular_values: np.ndarray | None = None
    message: str = ""
    error: str | None = None
    sweep: tuple[dict, ...] = ()


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
class _State:
    cfg: ScenarioConfig
    out: Path
    rngs: dict
    timing: dict = field(default_factory=dict)
    done: list = field(default_factory=list)
    X_true: np.ndarray | None = None
    world: object = None
    synthetic: object = None
    gt: dict = field(default_factory=dict)        # camera -> PoseStream (ground truth)
    source: dict = field(default_factory=dict)    # camera -> PoseStream (pose source)
    visual_log: object = None
    frames: dict = field(default_factory=dict)
    pairs: object = None
    pairing: dict = field(default_factory=dict)
    pose_errors: dict = field(default_factory=dict)
    solvers: list = field(default_factory=list)
    recorder: object = None

    def result(self, interrupted=False, results_path=None) -> RunResult:
        rec = self.recorder.path if self.recorder is not None and self.recorder.path else None
        return RunResult(config=self.cfg, output_dir=self.out, camera_names=CAMERAS,
                         X_true=self.X_true, frames=dict(self.frames),
                         pairing=dict(self.pairing), pose_errors=dict(self.pose_errors),
                         solvers=tuple(self.solvers), timing_s=dict(self.timing),
                         completed_stages=tuple(self.done), interrupted=interrupted,
                         results_path=results_path, recording_path=rec)


def _output_dir(cfg: ScenarioConfig) -> Path:
    if cfg.output:
        return Path(cfg.output)
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{cfg.scenario}-{stamp}"


def run(config, overrides=(), *, echo: bool = True) -> RunResult:
    """Run one scenario end to end and write its outputs; see the module docstring.

    ``config``: a :class:`ScenarioConfig` (``simcalib.load_config(...)``) or a scenario
    name / YAML path, resolved with ``overrides`` (``["seed=3", ...]``).
    ``echo`` prints the summary table to stdout.
    """
    if isinstance(config, (str, Path)):
        from simcalib.config import load_config
        config = load_config(str(config), list(overrides))
    elif overrides:
        raise TypeError("overrides are only accepted with a scenario name; apply them with "
                        "simcalib.load_config(name, overrides)")
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig (simcalib.load_config(...)); "
                        f"received {type(config).__name__}")
    import yaml
    from simcalib.config import to_dict
    from simcalib import reports
    cfg = config
    out = _output_dir(cfg)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.yaml").write_text(yaml.safe_dump(to_dict(cfg), sort_keys=False))
    children = np.random.SeedSequence(cfg.seed).spawn(len(_RNG_STREAMS))
    rngs = {name: np.random.default_rng(s) for name, s in zip(_RNG_STREAMS, children)}
    st = _State(cfg=cfg, out=out, rngs=rngs)
    t_start = time.perf_counter()
    if cfg.recording.enabled:
        from simcalib.rerun_log import RunRecorder
        st.recorder = RunRecorder(out / "recording.rrd", cfg)
    stage_fns = {"world": _stage_world, "streams": _stage_streams, "pairs": _stage_pairs,
                 "solvers": _stage_solvers, "evaluation": _stage_evaluation}
    bar = reports.progress(total=len(STAGES), enabled=cfg.progress, desc="stages",
                           unit="stage", position=0)
    try:
        for name, fn in stage_fns.items():
            bar.set_description(name)
            t0 = time.perf_counter()
            fn(st)
            st.timing[name] = time.perf_counter() - t0
            st.done.append(name)
            bar.update(1)
        t0 = time.perf_counter()
        st.timing["total"] = time.perf_counter() - t_start
        result = st.result()
        table = reports.summary_table(result)
        if st.recorder is not None:
            st.recorder.log_summary(table)
        _write_outputs(st, result)
        st.timing["reports"] = time.perf_counter() - t0
        st.done.append("reports")
        st.timing["total"] = time.perf_counter() - t_start
        results_path = reports.write_json(out / "results.json",
                                          reports.results_dict(st.result()))
        if st.recorder is not None:
            st.recorder.close()
        bar.close()
        if echo:
            print(table)
            print(f"wrote {out}/results.json, extrinsics.json, tum/, "
                  f"{'recording.rrd ' if st.recorder is not None else ''}"
                  f"in {st.timing['total']:.1f} s")
        return st.result(results_path=results_path)
    except KeyboardInterrupt:
        bar.close()
        st.timing["total"] = time.perf_counter() - t_start
        partial = st.result(interrupted=True)
        try:
            if st.recorder is not None:
                st.recorder.close()
            rp = reports.write_json(out / "results.json", reports.results_dict(partial))
            partial = dataclasses.replace(partial, results_path=rp)
        except Exception:  # keep the interrupt as the reported cause
            pass
        raise RunInterrupted(partial) from None
    except BaseException:
        bar.close()
        if st.recorder is not None:
            st.recorder.close()
        raise


# ----------------------------------------------------------------------------- stages
def _stage_world(st: _State) -> None:
    cfg = st.cfg
    if cfg.kind == "synthetic":
        from simcalib.synthetic import synthetic_problem
        syn = cfg.synthetic  # measurement noise already synced with noise.* by the config
        if cfg.pairing.n_pairs > syn.num_motions:
            raise ValueError(f"pairing.n_pairs={cfg.pairing.n_pairs} exceeds "
                             f"synthetic.num_motions={syn.num_motions}")
        st.synthetic = synthetic_problem(syn, n=cfg.pairing.n_pairs,
                                         rng=st.rngs["synthetic"])
        st.X_true = np.asarray(st.synthetic.X, dtype=np.float64)
        if st.recorder is not None:
            st.recorder.log_world(None)
        return
    from simcalib.world import build_world
    st.world = build_world(cfg.world, st.rngs["world"])
    st.X_true = np.asarray(st.world.trajectory.T_a_b, dtype=np.float64)
    if st.recorder is not None:
        st.recorder.log_world(getattr(st.world, "marker_field", None))


def _stage_streams(st: _State) -> None:
    cfg = st.cfg
    from simcalib.streams import PoseStream
    if cfg.kind == "synthetic":
        ds = st.synthetic.dataset
        T_w_b = np.asarray(ds.T_world_b)
        T_w_a = T_w_b @ invert_transform(st.X_true)
        n = T_w_b.shape[0]
        t = np.arange(n, dtype=np.float64)
        for cam, T in (("cam_a", T_w_a), ("cam_b", T_w_b)):
            st.gt[cam] = PoseStream(camera=cam, source="ground_truth",
                                    frame_index=np.arange(n), timestamp_s=t,
                                    T_world_cam=T, n_frames=n)
        idx = np.asarray(st.synthetic.indices)
        # the synthetic source measures relative motions: its errors are those of C and H
        for cam, M, M_true in (("cam_a", st.synthetic.C, ds.C_true[idx]),
                               ("cam_b", st.synthetic.H, ds.H_true[idx])):
            st.pose_errors[cam] = PoseErrors(
                camera=cam, source=f"{cfg.source} (relative motions)", frame_index=idx,
                rotation_deg=np.rad2deg(rotation_error_rad(M, M_true)),
                translation_m=np.linalg.norm(M[:, :3, 3] - M_true[:, :3, 3], axis=-1))
        st.frames = {"rendered": 0, "generated_motions": int(ds.num_motions)}
        for cam in CAMERAS:
            st.frames[cam] = {"used": int(idx.size), "dropped": 0, "drop_reasons": {}}
        if st.recorder is not None:
            st.recorder.log_trajectories(st.gt, {}, st.X_true)
        return

    import simcalib.world as W
    traj = st.world.trajectory
    frames = {"cam_a": traj.cam_a, "cam_b": traj.cam_b}
    for cam, fr in frames.items():
        st.gt[cam] = W.ground_truth_stream(fr)
    if cfg.source == "ground_truth":
        st.source = dict(st.gt)
    elif cfg.source == "noisy":
        rng_a, rng_b = st.rngs["noise"].spawn(2)
        for cam, rng in (("cam_a", rng_a), ("cam_b", rng_b)):
            st.source[cam] = W.noisy_stream(frames[cam], np.deg2rad(cfg.noise.sigma_r_deg),
                                            cfg.noise.sigma_t_m, rng)
    else:  # aruco
        from simcalib.vision import visual_streams
        streams, log = visual_streams(st.world, cfg.vision, st.rngs["vision"],
                                      workers=cfg.workers)
        st.source = {cam: streams[cam] for cam in CAMERAS}
        st.visual_log = log
    rendered = max(int(fr.n_frames) for fr in frames.values())
    st.frames = {"rendered": rendered}
    for cam in CAMERAS:
        s = st.source[cam]
        st.frames[cam] = {"frames": int(s.n_frames), "used": int(s.n_used),
                          "dropped": int(s.n_dropped),
                          "drop_reasons": {str(k): int(v) for k, v in
                                           dict(s.drop_reasons).items()}}
    if st.recorder is not None:
        st.recorder.log_trajectories(st.gt, st.source if cfg.source != "ground_truth" else {},
                                     st.X_true)
        st.recorder.log_cameras(getattr(st.world, "intrinsics", {}), st.gt, st.visual_log)


def _stage_pairs(st: _State) -> None:
    from simcalib.pairing import make_pairs, pairs_from_motions
    cfg = st.cfg
    if cfg.kind == "synthetic":
        st.pairs = pairs_from_motions(st.synthetic.C, st.synthetic.H)
        st.pairing = dict(st.pairs.counts) | {"mode": "random (appendix D sampling)"}
        return
    st.pairs = make_pairs(st.source["cam_a"], st.source["cam_b"], cfg.pairing,
                          st.rngs["pairing"])
    st.pairing = dict(st.pairs.counts) | {"mode": cfg.pairing.mode}


def _observability(sol) -> tuple:
    """(degenerate, words, direction dicts, undetermined translation axes, singular values)
    from ``sol.observability`` (simcalib.solvers.observability.Observability)."""
    try:
        obs = sol.observability
    except Exception as exc:  # diagnostics unavailable: say so, never pretend
        return (None, (f"observability unavailable: {type(exc).__name__}: {exc}",), (), None,
                None)
    words, dirs, axes = [], [], []
    for d in getattr(obs, "undetermined", ()) or ():
        if isinstance(d, str):
            words.append(d)
            continue
        status = ("not determined by the motions" if d.reason == "undetermined"
                  else f"poorly determined (1-sigma {d.std:.3g})")
        src = "value from the prior" if d.determined_by_prior else "value is not a measurement"
        words.append(f"{d.description}: {status}; {src}")
        dirs.append({"kind": d.kind, "reason": d.reason, "dims": int(d.dims),
                     "description": d.description,
                     "rotation_axis_a": np.asarray(d.rotation_axis_a, dtype=float).tolist(),
                     "translation_dir_a": np.asarray(d.translation_dir_a, dtype=float).tolist(),
                     "std": float(d.std), "determined_by_prior": bool(d.determined_by_prior)})
        if d.kind == "translation" and not d.determined_by_prior:
            v = np.asarray(d.translation_dir_a, dtype=np.float64)
            if d.dims == 1:
                axes.append(v)
            elif d.dims == 2:  # the plane perpendicular to v
                _, _, Vt = np.linalg.svd(v[None, :])
                axes.extend(Vt[1:])
            else:
                axes.extend(np.eye(3))
    sv = getattr(obs, "singular_values", None)
    return (bool(getattr(obs, "degenerate", False)), tuple(words), tuple(dirs),
            np.array(axes).reshape(-1, 3) if axes else None,
            None if sv is None else np.asarray(sv, dtype=np.float64))


def _prior(st: _State):
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


def _stage_solvers(st: _State) -> None:
    from simcalib import reports
    cfg = st.cfg
    jobs = [(m, m, False) for m in cfg.solvers]
    prior = prior_info = None
    if cfg.prior.enabled:
        prior, prior_info = _prior(st)
        jobs += [(f"{m}+prior", m, True) for m in cfg.prior.methods]
    rng_children = st.rngs["solvers"].spawn(len(jobs))
    C, H = st.pairs.C, st.pairs.H
    for (label, method, with_prior), rng in zip(
            reports.progress(jobs, enabled=cfg.progress, desc="solvers", unit="method",
                             position=1), rng_children):
        st.solvers.append(_solve_one(st, label, method, prior if with_prior else None,
                                     prior_info if with_prior else None, C, H, rng))
    if st.recorder is not None:
        st.recorder.log_estimates(st.solvers, st.X_true, st.gt)


def _solve_one(st, label, method, prior, prior_info, C, H, rng) -> SolverResult:
    import simcalib
    cfg = st.cfg
    sweep = []
    best = None
    try:
        for alpha in cfg.alphas:
            sol = simcalib.solve(C, H, method=method, alpha=alpha, prior=prior,
                                 rng=np.random.default_rng(rng.bit_generator.seed_seq))
            degenerate, und, dirs, axes, sv = _observability(sol)
            err = estimate_errors(sol.X, st.X_true, axes if degenerate else None)
            entry = {"alpha": float(alpha), **err, "cost": float(sol.cost),
                     "runtime_s": float(sol.runtime_s), "success": bool(sol.success)}
            sweep.append(entry)
            if best is None or err["rotation_error_deg"] < best[1]["rotation_error_deg"]:
                best = (sol, err, degenerate, und, dirs, axes, sv)
    except Exception as exc:  # noqa: BLE001 - one failing method must not sink the run
        return SolverResult(label=label, method=method, alpha=None, prior=prior_info,
                            X=None, rotation_error_deg=None, translation_error_m=None,
                            translation_error_determined_m=None, cost=None, runtime_s=None,
                            success=False, degenerate=None,
                            error=f"{type(exc).__name__}: {exc}".splitlines()[0])
    sol, err, degenerate, und, dirs, axes, sv = best
    try:
        message = sol.message
    except Exception as exc:  # noqa: BLE001 - a broken diagnostic must not kill the run
        message = f"{sol.solver_message} (message unavailable: {exc})"
    return SolverResult(
        label=label, method=method, alpha=float(sol.alpha), prior=prior_info,
        X=np.asarray(sol.X, dtype=np.float64), rotation_error_deg=err["rotation_error_deg"],
        translation_error_m=err["translation_error_m"],
        translation_error_determined_m=err["translation_error_determined_m"],
        cost=float(sol.cost), runtime_s=float(sol.runtime_s), success=bool(sol.success),
        degenerate=degenerate, undetermined=und if degenerate or degenerate is None else (),
        undetermined_directions=dirs,
        undetermined_translation_axes=axes if degenerate else None, singular_values=sv,
        message=message, sweep=tuple(sweep) if cfg.is_sweep else ())


def _stage_evaluation(st: _State) -> None:
    # synthetic scenarios have no pose streams: their errors were computed with the motions
    if st.cfg.kind != "synthetic":
        source = st.gt if st.cfg.source == "ground_truth" else st.source
        st.pose_errors = {cam: pose_source_errors(source[cam], st.gt[cam]) for cam in CAMERAS}
    if st.recorder is not None:
        st.recorder.log_pose_errors(st.pose_errors)


def _write_outputs(st: _State, result: RunResult) -> None:
    from simcalib import reports
    out = st.out
    tum = out / "tum"
    tum.mkdir(exist_ok=True)
    for cam, s in st.gt.items():
        reports.write_tum(tum / f"{cam}_ground_truth.tum", s.timestamp_s, s.T_world_cam)
    if st.cfg.kind == "sim" and st.cfg.source != "ground_truth":
        for cam, s in st.source.items():
            reports.write_tum(tum / f"{cam}_{st.cfg.source}.tum", s.timestamp_s,
                              s.T_world_cam)
    reports.write_json(out / "extrinsics.json", reports.extrinsics_dict(result))
