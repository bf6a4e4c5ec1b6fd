"""Screenshots of run recordings in the real rerun viewer, checked like a reviewer looks.

    python -m simcalib.tools.screenshots                 # planar, 3d, line -> runs/screenshots
    python -m simcalib.tools.screenshots --docs          # also refresh docs/figures/recording_*.png
    python -m simcalib.tools.screenshots --all           # every scenario
    python -m simcalib.tools.screenshots --scenario planar --override world.duration_s=6
    python -m simcalib.tools.screenshots --calibrations --docs   # calibration recordings
    python -m simcalib.tools.screenshots --advise        # advice recordings (scara, planar, files)

Each scenario is run (``python -m simcalib run``), its ``recording.rrd`` opened with
``rerun FILE --port auto --screenshot-to PNG --window-size 1600x1000`` under Xvfb (Mesa's
software Vulkan, llvmpipe) three times: the default layout, the extrinsic close-up alone and the
scene alone (blueprint files ``.rbl`` that maximise one view). Checks, each failure a line
of the report:

* no pane of the default layout says "No data available" (OCR with tesseract);
* every verdict line of the summary pane is read whole (not cut off at the pane's edge);
* the close-up shows a label for every successful estimate (OCR of the close-up shot);
* simulated runs: the scene is framed on the room/platform (the scene shot is not a speck
  in an empty void: at least ``MIN_SCENE_FILL`` of its pixels differ from the background;
  synthetic runs have no room and draw only thin paths, so they are not held to it).

``--calibrations`` (:func:`calibration_main`): ``simcalib calibrate``'s recording of each of
:data:`CALIBRATION_SETS` (three shared real sets, a synthetic rig with outliers and an
offset), the default layout and the 3D view alone, checked by :func:`check_calibration`: no
"No data available", every pane shows pixels of its own colour, every summary line is read
whole (not cut off), the 3D view framed on the trajectories; ``--docs`` writes
``docs/figures/calibration_<set>.png``.

``--advise`` (:func:`advice_main`): ``simcalib advise``'s recording of each of
:data:`ADVICE_CASES`, the layout and the stops' 3D view alone, checked by
:func:`check_advice`: no "No data available", the plots in deg and in cm and the summary's
"from the previous stop" read, every stop labelled, the stops framed.

Needs the Debian packages ``xvfb``, ``mesa-vulkan-drivers`` and ``tesseract-ocr``
(:func:`missing_prerequisites` says which are absent); rerun-sdk provides the viewer.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simcalib.report.rerun.common import SCENE_BACKGROUND

__all__ = ["missing_prerequisites", "screenshot", "ocr_text", "check_recording",
           "ShotReport", "text_contains", "DEFAULT_SCENARIOS", "WINDOW_SIZE", "MIN_SCENE_FILL",
           "main",
           "CALIBRATION_SETS", "check_calibration", "run_calibration", "calibration_main",
           "synthetic_calibration_input", "pane_pixels", "framing", "cut_lines",
           "calibration_pane_boxes", "ADVICE_CASES", "run_advice", "check_advice",
           "advice_main", "color_extent"]

DEFAULT_SCENARIOS = ("planar", "3d", "line")
WINDOW_SIZE = (1600, 1000)
MIN_SCENE_FILL = 0.15
REPO = Path(__file__).resolve().parents[2]


def missing_prerequisites() -> list[str]:
    """What is missing to take and check screenshots ([] = ready): executables and the
    Mesa Vulkan driver."""
    missing = []
    for exe, pkg in (("xvfb-run", "xvfb"), ("tesseract", "tesseract-ocr")):
        if shutil.which(exe) is None:
            missing.append(f"{exe} (Debian package {pkg})")
    icd = [p for d in ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d")
           for p in (Path(d).glob("lvp_icd*.json") if Path(d).is_dir() else [])]
    if not icd:
        missing.append("Mesa's software Vulkan driver (Debian package mesa-vulkan-drivers)")
    if _rerun_exe() is None:
        missing.append("the rerun viewer (pip package rerun-sdk)")
    return missing


def _rerun_exe() -> str | None:
    exe = shutil.which("rerun")
    if exe is None:
        cand = Path(sys.executable).with_name("rerun")
        exe = str(cand) if cand.exists() else None
    return exe


def screenshot(rrd: Path, png: Path, *, blueprint: Path | None = None,
               size: tuple[int, int] = WINDOW_SIZE, timeout_s: float = 300.0) -> Path:
    """Open ``rrd`` (and optionally a blueprint ``.rbl``) in the real viewer under Xvfb and
    save a screenshot to ``png``. The virtual screen is much larger than the window so the
    mouse pointer (at the screen's centre) hovers nothing."""
    missing = missing_prerequisites()
    if any("xvfb" in m or "Vulkan" in m or "rerun" in m for m in missing):
        raise RuntimeError("cannot take screenshots; missing: " + "; ".join(missing))
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    if png.exists():
        png.unlink()
    w, h = size
    cmd = ["xvfb-run", "-a", "-s", f"-screen 0 {4 * w}x{4 * h}x24", _rerun_exe(), str(rrd)]
    if blueprint is not None:
        cmd.append(str(blueprint))
    # --port auto: always a viewer of its own (another one listening on the default port
    # would otherwise receive the file and this command would exit with no screenshot)
    cmd += ["--port", "auto", "--screenshot-to", str(png), "--window-size", f"{w}x{h}"]
    env = dict(os.environ, RERUN_ANALYTICS="0", XDG_RUNTIME_DIR=tempfile.gettempdir())
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env)
    if proc.returncode != 0 or not png.exists():
        tail = "\n".join((proc.stderr or proc.stdout).strip().splitlines()[-8:])
        raise RuntimeError(f"rerun screenshot failed (exit {proc.returncode}): {tail}")
    return png


def ocr_text(png: Path, bright_text: bool = False) -> str:
    """The text tesseract reads in ``png``: inverted (the viewer draws light text on a dark
    theme), or with ``bright_text`` only the near-white pixels as black text (the 3D
    views' white labels on grey boxes over a dark background).

    tesseract runs on one OpenMP thread (``OMP_THREAD_LIMIT=1``): it reads the same text,
    for about a quarter of the CPU time its threads' waiting costs (a 3200x2000 layout
    shot: 1.4 s against 5.7-6.1 s of CPU)."""
    from PIL import Image, ImageOps
    im = Image.open(png).convert("L")
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "ocr.png"
        if bright_text:
            a = np.asarray(im.resize((2 * im.width, 2 * im.height), Image.LANCZOS))
            Image.fromarray(np.where(a >= 215, 0, 255).astype(np.uint8)).save(p)
        else:
            ImageOps.autocontrast(ImageOps.invert(im)).save(p)
        out = subprocess.run(["tesseract", str(p), "-", "--psm", "11"], capture_output=True,
                             text=True, timeout=300,
                             env=dict(os.environ, OMP_THREAD_LIMIT="1"))
    return out.stdout


def _norm(text: str) -> str:
    # tesseract reads a thin "l" as "|" (e.g. "dqconvr|x"): that is the letter, not a gap
    return re.sub(r"[^a-z0-9]", "", text.replace("|", "l").lower())


def text_contains(text: str, label: str) -> bool:
    """Whether OCR ``text`` contains ``label`` (letters and digits only, case-insensitive),
    allowing one misread character in five (tesseract reads q as g or a at small sizes)."""
    t, w = _norm(text), _norm(label)
    if not w or w in t:
        return bool(w)
    tol = len(w) // 5
    a = np.frombuffer(t.encode(), dtype=np.uint8)
    b = np.frombuffer(w.encode(), dtype=np.uint8)
    if tol == 0 or a.size < b.size:
        return False
    win = np.lib.stride_tricks.sliding_window_view(a, b.size)
    return bool(((win != b).sum(axis=1) <= tol).any())


def _scene_fill(png: Path) -> float:
    """Fraction of the 3D view's pixels (below the title bar) that are not background."""
    from PIL import Image
    a = np.asarray(Image.open(png).convert("RGB"), dtype=np.int16)
    h = a.shape[0]
    body = a[int(0.08 * h):int(0.9 * h)]
    bg = np.abs(body - np.array(SCENE_BACKGROUND)).sum(axis=2) <= 12
    return float(1.0 - bg.mean())


@dataclass
class ShotReport:
    """What :func:`check_recording` found: the screenshots and the failed checks."""
    scenario: str
    shots: dict = field(default_factory=dict)
    problems: list = field(default_factory=list)
    scene_fill: float | None = None

    @property
    def ok(self) -> bool:
        return not self.problems


def _single_view_blueprint(rrd_dir: Path, which: str, path: Path) -> Path:
    """A blueprint file showing only ``which`` ("closeup" or "scene") of a run recording,
    with the eye the recording's own blueprint uses (from ``recording_view.json``)."""
    from simcalib.report.rerun.run_layout import single_view_blueprint
    views = json.loads((rrd_dir / "recording_view.json").read_text())
    eye = views.get("closeup_eye" if which == "closeup" else "eye")
    single_view_blueprint(which, eye).save("simcalib", str(path))
    return path


def check_recording(run_dir: Path, out_dir: Path, scenario: str | None = None) -> ShotReport:
    """Screenshot ``run_dir/recording.rrd`` (default layout, close-up, scene) into
    ``out_dir`` and check them against ``run_dir/results.json`` (see module docstring)."""
    run_dir, out_dir = Path(run_dir), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    results = json.loads((run_dir / "results.json").read_text())
    name = scenario or results.get("scenario", run_dir.name)
    rep = ShotReport(scenario=name)
    rrd = run_dir / "recording.rrd"
    rep.shots["layout"] = screenshot(rrd, out_dir / f"{name}_layout.png")
    rep.shots["closeup"] = screenshot(rrd, out_dir / f"{name}_closeup.png",
                                      blueprint=_single_view_blueprint(
                                          run_dir, "closeup", out_dir / f"{name}_closeup.rbl"))
    rep.shots["scene"] = screenshot(rrd, out_dir / f"{name}_scene.png",
                                    blueprint=_single_view_blueprint(
                                        run_dir, "scene", out_dir / f"{name}_scene.rbl"))
    if shutil.which("tesseract") is None:
        rep.problems.append("tesseract missing: text checks not run")
    else:
        text = ocr_text(rep.shots["layout"])
        if "nodataavailable" in _norm(text) or "no data available" in text.lower():
            rep.problems.append("a pane says 'No data available'")
        from simcalib.report.rerun.run import summary_of
        verdicts = "\n".join(ln for ln in summary_of(rrd).splitlines()
                              if ln.startswith("- verdict ["))
        rep.problems += [f"summary line not read whole (cut off?): {ln[:60]!r}"
                         for ln in cut_lines(text, verdicts)]
        close = ocr_text(rep.shots["closeup"], bright_text=True)
        for label, s in (results.get("solvers") or {}).items():
            if s.get("X") is not None and not text_contains(close, label):
                rep.problems.append(f"close-up: no label for successful estimate {label!r}")
    rep.scene_fill = _scene_fill(rep.shots["scene"])
    view = json.loads((run_dir / "recording_view.json").read_text())
    if view.get("room") is not None and rep.scene_fill < MIN_SCENE_FILL:
        rep.problems.append(f"scene view nearly empty (only {rep.scene_fill:.0%} of the pixels "
                            f"show anything; framed far outside the room?)")
    return rep


def _run_scenario(name: str, out: Path, overrides=()) -> Path:
    cmd = [sys.executable, "-m", "simcalib", "run", f"scenario={name}", f"output={out}",
           "progress=false", *overrides]
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=REPO)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-600:]}")
    return out


def _docs_png(src: Path, dst: Path, width: int = 1400) -> None:
    from PIL import Image
    im = Image.open(src).convert("RGB")
    im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
    dst.parent.mkdir(parents=True, exist_ok=True)
    im.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(dst, optimize=True)


# ------------------------------------------------------------- calibration recordings
#: the calibrations ``--calibrations`` screenshots: three shared real sets and a synthetic
#: 60 s recording with 15 % outlier poses in b and a 100 ms clock offset
CALIBRATION_SETS = ("rwhecalib_kuka_1", "tum_fr2_desk_orb", "scara_handeye4dof", "synthetic")
#: a pane shows its data when at least this many pixels have its colour (3200x2000 shot)
MIN_PANE_PIXELS = 400
#: the 3D view alone: the kept trajectories' extent on screen (fraction of width or height)
MIN_FRAMING = 0.35


def synthetic_calibration_input(folder: Path, seed: int = 0) -> Path:
    """Write ``a.txt``, ``b.txt`` (TUM) of :func:`simcalib.world.stream_sim.rig_streams` (60 s,
    15 % outlier poses in b, offset 0.1 s) into ``folder`` and return it."""
    from simcalib.report.results import write_tum
    from simcalib.world.stream_sim import rig_streams
    s = rig_streams(offset_s=0.1, outlier_fraction=0.15, duration_s=60.0,
                    rng=np.random.default_rng(seed))
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_tum(folder / "a.txt", s.t_a, s.T_a)
    write_tum(folder / "b.txt", s.t_b, s.T_b)
    return folder


def _calibration_input(name: str, work: Path) -> Path:
    if name == "synthetic":
        return synthetic_calibration_input(work / "synthetic_input")
    from simcalib.studies.experiments.real_sets import real_dir
    d = real_dir() / name
    if not (d / "a.txt").exists():
        raise FileNotFoundError(f"real set {name!r}: no {d / 'a.txt'} (set SIMCALIB_REAL_DIR"
                                " or see docs/real-data.md)")
    return d


def run_calibration(inp: Path, out: Path):
    """Calibrate ``inp/a.txt``, ``inp/b.txt`` into ``out`` as ``simcalib calibrate`` does
    (calibration.json, motions.npz, recording.rrd); returns ``(StreamCalibration,
    seconds)``."""
    import time
    from simcalib.pipeline.calibrate import calibrate, parse_options, write_outputs
    t0 = time.perf_counter()
    opts = parse_options([f"a={inp / 'a.txt'}", f"b={inp / 'b.txt'}", f"output={out}"])
    r, a = calibrate(opts)
    write_outputs(opts, r, a)
    return r, time.perf_counter() - t0


def _color_mask(a: np.ndarray, color) -> np.ndarray:
    """Pixels of ``color``'s hue, however the viewer shades it (bar charts are drawn
    translucent): the chroma (RGB minus its smallest channel) points the same way
    (cosine > 0.995) and is at least 0.4 of the colour's own."""
    c = np.array(color, dtype=np.float64)
    c -= c.min()
    px = a.astype(np.float64)
    px -= px.min(axis=2, keepdims=True)
    norm = np.linalg.norm(px, axis=2)
    cos = (px @ c) / np.maximum(norm * np.linalg.norm(c), 1e-9)
    return (cos > 0.995) & (norm >= 0.4 * np.linalg.norm(c))


def _color_pixels(a: np.ndarray, color) -> int:
    """The number of pixels of ``color``'s hue (:func:`_color_mask`)."""
    return int(_color_mask(a, color).sum())


def calibration_pane_boxes(panes) -> dict:
    """Where each pane of :func:`simcalib.report.rerun.calibration.calibration_blueprint` lies in a
    layout shot, as fractions ``(x0, x1, y0, y1)`` of the image (a margin inside the pane):
    the trajectories top left (11/20 of the width, 5/8 of the body), the plots ``panes``
    (in the layout's order) stacked evenly on the right."""
    top, bottom = 0.035, 0.965
    h = bottom - top
    boxes = {"trajectories": (0.02, 0.53, top + 0.05 * h, top + 0.6 * h)}
    plots = [p for p in panes if p != "trajectories"]
    for k, p in enumerate(plots):
        y0, y1 = top + h * k / len(plots), top + h * (k + 1) / len(plots)
        boxes[p] = (0.57, 0.99, y0 + 0.02, y1 - 0.02)
    return boxes


def pane_pixels(png: Path, present: dict, boxes: dict | None = None) -> dict:
    """Pixels of each pane's own colour in ``png`` (``present``: pane -> colour names of
    :data:`simcalib.report.rerun.calibration.CALIBRATION_COLORS`), counted inside the pane's box
    (``boxes``: pane -> fractions ``(x0, x1, y0, y1)``; default the whole image)."""
    from PIL import Image
    from simcalib.report.rerun.calibration import CALIBRATION_COLORS
    a = np.asarray(Image.open(png).convert("RGB"), dtype=np.int16)
    H, W = a.shape[:2]
    out = {}
    for pane, colors in present.items():
        x0, x1, y0, y1 = (boxes or {}).get(pane, (0.0, 1.0, 0.0, 1.0))
        sub = a[int(y0 * H):int(y1 * H), int(x0 * W):int(x1 * W)]
        out[pane] = min(_color_pixels(sub, CALIBRATION_COLORS[c]) for c in colors)
    return out


def framing(png: Path, background=None) -> float:
    """The drawn extent of a 3D view shot: the larger of the width and height fractions
    spanned by pixels differing from ``background`` (default the calibration recording's;
    below the title bar)."""
    from PIL import Image
    if background is None:
        from simcalib.report.rerun.calibration import CALIBRATION_BACKGROUND as background
    a = np.asarray(Image.open(png).convert("RGB"), dtype=np.int16)
    h = a.shape[0]
    body = a[int(0.05 * h):int(0.97 * h)]
    drawn = np.abs(body - np.array(background)).sum(axis=2) > 30
    if not drawn.any():
        return 0.0
    rows, cols = np.flatnonzero(drawn.any(axis=1)), np.flatnonzero(drawn.any(axis=0))
    return float(max((rows[-1] - rows[0]) / drawn.shape[0], (cols[-1] - cols[0]) /
                     drawn.shape[1]))


def color_extent(png: Path, colors) -> float:
    """The extent of the pixels of ``colors``' hues in a shot (below the title bar): the
    larger of the width and height fractions they span (0 when there are fewer than 50)."""
    from PIL import Image
    a = np.asarray(Image.open(png).convert("RGB"), dtype=np.int16)
    h = a.shape[0]
    body = a[int(0.05 * h):int(0.97 * h)]
    mask = np.zeros(body.shape[:2], dtype=bool)
    for c in colors:
        mask |= _color_mask(body, c)
    if mask.sum() < 50:
        return 0.0
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return float(max((rows[-1] - rows[0]) / mask.shape[0], (cols[-1] - cols[0]) /
                     mask.shape[1]))


def _line_ends(line: str, n: int = 18) -> list[str]:
    """The first ``n`` letters/digits of a summary line and its last word (the last two
    when the last is shorter than 4): both must be read for the line to be whole, not cut
    at an edge (the pane wraps long lines at words, so only the last word is sure to stay
    on the line's last row)."""
    words = [_norm(x) for x in re.sub(r"[*`]", "", line).split()]
    words = [x for x in words if x]
    w = "".join(words)
    tail = words[-1] if words and len(words[-1]) >= 4 else "".join(words[-2:])
    return [w] if len(w) <= n else [w[:n], tail]


def cut_lines(text: str, summary: str) -> list[str]:
    """The lines of ``summary`` that the OCR ``text`` does not hold whole
    (:func:`_line_ends`)."""
    return [line for line in summary.splitlines() if line.strip()
            and not all(text_contains(text, p) for p in _line_ends(line))]


def check_calibration(out: Path, r, shots: Path, name: str) -> ShotReport:
    """Screenshot ``out/recording.rrd`` (default layout, the 3D view alone) and check:
    no pane says "No data available", every pane shows its data (pixels of its colour),
    every line of the summary is read whole (its first and last letters), the 3D view
    is framed on the trajectories (:data:`MIN_FRAMING`)."""
    from simcalib.report.rerun.calibration import (CALIBRATION_PANE_COLORS,
                                                   calibration_summary,
                                                   save_calibration_blueprint)
    rep = ShotReport(scenario=name)
    rrd = Path(out) / "recording.rrd"
    rep.shots["layout"] = screenshot(rrd, shots / f"calibration_{name}_layout.png")
    rep.shots["world"] = screenshot(rrd, shots / f"calibration_{name}_world.png",
                                    blueprint=save_calibration_blueprint(
                                        r, shots / f"calibration_{name}_world.rbl", "world"))
    panes = {k: v for k, v in CALIBRATION_PANE_COLORS.items()
             if k != "correlation over lag" or _has_correlation(r)}
    for pane, n in pane_pixels(rep.shots["layout"], panes,
                               calibration_pane_boxes(list(panes))).items():
        if n < MIN_PANE_PIXELS:
            rep.problems.append(f"pane {pane!r} shows no data ({n} px of its colour)")
    text = ocr_text(rep.shots["layout"])
    if "nodataavailable" in _norm(text):
        rep.problems.append("a pane says 'No data available'")
    report = json.loads((Path(out) / "calibration.json").read_text())
    rep.problems += [f"summary line not read whole (cut off?): {line[:60]!r}"
                     for line in cut_lines(text, calibration_summary(r, report))]
    rep.scene_fill = framing(rep.shots["world"])
    if rep.scene_fill < MIN_FRAMING:
        rep.problems.append(f"3D view badly framed: the drawing spans {rep.scene_fill:.0%} "
                            f"of the view (< {MIN_FRAMING:.0%})")
    return rep


def _has_correlation(r) -> bool:
    from simcalib.report.rerun.calibration import has_correlation
    return has_correlation(r.time_offset)


def calibration_main(names, output: Path, docs: bool) -> int:
    """``--calibrations``: calibrate, screenshot and check each set; one line per set."""
    failed = 0
    for name in names:
        out = output / "calibrations" / name
        r, seconds = run_calibration(_calibration_input(name, output), out)
        rep = check_calibration(out, r, output / "shots", name)
        size_mb = (out / "recording.rrd").stat().st_size / 1e6
        print(f"calibration {name}: recording {size_mb:.2f} MB, calibrate + outputs "
              f"{seconds:.1f} s; 3D framing {rep.scene_fill:.0%}; "
              + ("OK" if rep.ok else "PROBLEMS: " + "; ".join(rep.problems)), flush=True)
        failed += not rep.ok
        if docs:
            _docs_png(rep.shots["layout"], REPO / "docs" / "figures" / f"calibration_{name}.png")
    return 1 if failed else 0


# ------------------------------------------------------------------- advice recordings
#: the advice ``--advise`` screenshots: two scenarios (arm, cart) and recorded files (a
#: synthetic planar rig, platform=cart); each name -> the advise arguments
ADVICE_CASES = {"scara": ["scenario=scara", "k=5"], "planar": ["scenario=planar", "k=5"],
                "files": ["platform=cart", "k=4"]}


def run_advice(name: str, out: Path) -> Path:
    """``simcalib advise`` of :data:`ADVICE_CASES` ``name`` into ``out`` (the files case
    calibrates a synthetic planar rig's TUM files written beside it)."""
    args = list(ADVICE_CASES[name])
    if name == "files":
        from simcalib.report.results import write_tum
        from simcalib.world.stream_sim import rig_streams
        s = rig_streams(path="planar", duration_s=20.0, rng=np.random.default_rng(0))
        inp = Path(out).with_name(f"{Path(out).name}_input")
        inp.mkdir(parents=True, exist_ok=True)
        args += [f"a={write_tum(inp / 'a.txt', s.t_a, s.T_a)}",
                 f"b={write_tum(inp / 'b.txt', s.t_b, s.T_b)}"]
    cmd = [sys.executable, "-m", "simcalib", "advise", *args, f"output={out}"]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO, check=False,
                          env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-600:]}")
    return Path(out)


def check_advice(out: Path, shots: Path, name: str) -> ShotReport:
    """Screenshot ``out/advice.rrd`` (default layout, the 3D view of the stops alone) and
    check: no pane says "No data available", the summary says the stops are motions from
    the previous stop, both plots (deg, cm) are there, every stop's label is read in the 3D
    view, and the stops' drawing spans at least :data:`MIN_FRAMING` of that view."""
    from simcalib.report.rerun.advice import ADVICE_APP_ID, advice_blueprint
    from simcalib.report.rerun.common import CAMERA_COLORS
    out = Path(out)
    rep = ShotReport(scenario=f"advise {name}")
    rrd = out / "advice.rrd"
    rep.shots["layout"] = screenshot(rrd, shots / f"advice_{name}_layout.png")
    eye = json.loads((out / "advice_view.json").read_text())["eye"]
    rbl = shots / f"advice_{name}_stops.rbl"
    advice_blueprint(eye, only="stops").save(ADVICE_APP_ID, str(rbl))
    rep.shots["stops"] = screenshot(rrd, shots / f"advice_{name}_stops.png", blueprint=rbl)
    text = ocr_text(rep.shots["layout"])
    if "nodataavailable" in _norm(text):
        rep.problems.append("a pane says 'No data available'")
    for words in ("from the previous stop", "predicted 1-sigma, rotation [deg]",
                  "predicted 1-sigma, translation [cm]"):
        if not text_contains(text, words):
            rep.problems.append(f"layout: {words!r} not read")
    labels = ocr_text(rep.shots["stops"], bright_text=True)
    k = len(json.loads((out / "advice.json").read_text())["motions"])
    rep.problems += [f"3D view: no label 'stop {j}'" for j in range(1, k + 1)
                     if not re.search(rf"stop\s*{j}\b", labels, re.IGNORECASE)]
    rep.scene_fill = color_extent(rep.shots["stops"], CAMERA_COLORS.values())
    if rep.scene_fill < MIN_FRAMING:
        rep.problems.append(f"3D view badly framed: the cameras' paths and stops span "
                            f"{rep.scene_fill:.0%} of the view (< {MIN_FRAMING:.0%})")
    return rep


def advice_main(names, output: Path, docs: bool) -> int:
    """``--advise``: advise, screenshot and check each case; one line per case."""
    failed = 0
    for name in names:
        rep = check_advice(run_advice(name, output / "advice" / name), output / "shots", name)
        print(f"advise {name}: 3D framing {rep.scene_fill:.0%}; "
              + ("OK" if rep.ok else "PROBLEMS: " + "; ".join(rep.problems)), flush=True)
        failed += not rep.ok
        if docs:
            _docs_png(rep.shots["layout"], REPO / "docs" / "figures" / f"advice_{name}.png")
    return 1 if failed else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m simcalib.tools.screenshots",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append", help="scenario (repeatable); default: "
                    + ", ".join(DEFAULT_SCENARIOS))
    ap.add_argument("--override", action="append", default=[],
                    help="key=value passed to every run")
    ap.add_argument("--output", default="runs/screenshots", help="runs and screenshots")
    ap.add_argument("--docs", action="store_true",
                    help="write docs/figures/recording_<scenario>.png (calibration_<set>.png)")
    ap.add_argument("--calibrations", action="store_true",
                    help="calibration recordings instead: " + ", ".join(CALIBRATION_SETS))
    ap.add_argument("--set", action="append", dest="sets",
                    help="with --calibrations: a set (repeatable); default: all")
    ap.add_argument("--all", action="store_true",
                    help="every scenario (`python -m simcalib list`) instead of "
                    + ", ".join(DEFAULT_SCENARIOS))
    ap.add_argument("--advise", action="append", nargs="?", const="all",
                    help="advice recordings instead: " + ", ".join(ADVICE_CASES)
                    + " (repeatable; alone: all)")
    args = ap.parse_args(argv)
    missing = missing_prerequisites()
    if missing:
        print("cannot take screenshots; missing: " + "; ".join(missing), file=sys.stderr)
        return 2
    out = Path(args.output)
    if args.calibrations:
        return calibration_main(args.sets or CALIBRATION_SETS, out, args.docs)
    if args.advise:
        cases = list(ADVICE_CASES) if "all" in args.advise else args.advise
        return advice_main(cases, out, args.docs)
    if args.all:
        from simcalib.pipeline.scenario import list_scenarios
        names = list(list_scenarios())
    else:
        names = args.scenario or DEFAULT_SCENARIOS
    failed = 0
    for name in names:
        run_dir = _run_scenario(name, out / name, args.override)
        rep = check_recording(run_dir, out / "shots", name)
        size_mb = (run_dir / "recording.rrd").stat().st_size / 1e6
        view = json.loads((run_dir / "recording_view.json").read_text())
        rec_s = view["recording_s"]
        total_s = json.loads((run_dir / "results.json").read_text())["timing_s"]["total"]
        worker = view.get("worker") or {}
        beside = (f" (worker process beside the run: rerun import {worker['import_s']:.2f} s, "
                  f"logging {worker['log_s']:.2f} s)" if worker.get("import_s") is not None
                  else "")
        print(f"{name}: recording {size_mb:.1f} MB, {rec_s:.2f} s of the run's {total_s:.1f} s "
              f"({100 * rec_s / total_s:.1f} %){beside}; scene fill {rep.scene_fill:.0%}; "
              + ("OK" if rep.ok else "PROBLEMS: " + "; ".join(rep.problems)), flush=True)
        failed += not rep.ok
        if args.docs:
            _docs_png(rep.shots["layout"], REPO / "docs" / "figures" / f"recording_{name}.png")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
