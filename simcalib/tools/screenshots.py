"""Screenshots of run recordings in the real rerun viewer, checked like a reviewer looks.

    python -m simcalib.tools.screenshots                 # planar, 3d, line -> runs/screenshots
    python -m simcalib.tools.screenshots --docs          # also refresh docs/figures/recording_*.png
    python -m simcalib.tools.screenshots --scenario planar --override world.duration_s=6

Each scenario is run (``python -m simcalib run``), its ``recording.rrd`` opened with
``rerun FILE --port auto --screenshot-to PNG --window-size 1600x1000`` under Xvfb (Mesa's
software Vulkan, llvmpipe) three times: the default layout, the extrinsic close-up alone and the
scene alone (blueprint files ``.rbl`` that maximise one view). Checks, each failure a line
of the report:

* no pane of the default layout says "No data available" (OCR with tesseract);
* the close-up shows a label for every successful estimate (OCR of the close-up shot);
* simulated runs: the scene is framed on the room/platform (the scene shot is not a speck
  in an empty void: at least ``MIN_SCENE_FILL`` of its pixels differ from the background;
  synthetic runs have no room and draw only thin paths, so they are not held to it).

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

from simcalib.rerun_log import CLOSEUP_BACKGROUND, SCENE_BACKGROUND

__all__ = ["missing_prerequisites", "screenshot", "ocr_text", "check_recording",
           "ShotReport", "text_contains", "DEFAULT_SCENARIOS", "WINDOW_SIZE", "MIN_SCENE_FILL", "main"]

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
    views' white labels on grey boxes over a dark background)."""
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
                             text=True, timeout=300)
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
    import rerun.blueprint as rrb
    views = json.loads((rrd_dir / "recording_view.json").read_text())
    e = views.get("closeup_eye" if which == "closeup" else "eye")
    eye = None if e is None else rrb.EyeControls3D(
        kind=rrb.Eye3DKind.Orbital, position=e["position"], look_target=e["look_target"],
        eye_up=e["eye_up"])
    view = rrb.Spatial3DView(origin="closeup" if which == "closeup" else "world",
                             name=which, eye_controls=eye, background=(
                                 CLOSEUP_BACKGROUND if which == "closeup" else SCENE_BACKGROUND),
                             line_grid=rrb.LineGrid3D(visible=False))
    rrb.Blueprint(view, rrb.TimePanel(state="hidden"), rrb.BlueprintPanel(state="hidden"),
                  rrb.SelectionPanel(state="hidden"), rrb.TopPanel(state="hidden"),
                  auto_views=False).save("simcalib", str(path))
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m simcalib.tools.screenshots",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append", help="scenario (repeatable); default: "
                    + ", ".join(DEFAULT_SCENARIOS))
    ap.add_argument("--override", action="append", default=[],
                    help="key=value passed to every run")
    ap.add_argument("--output", default="runs/screenshots", help="runs and screenshots")
    ap.add_argument("--docs", action="store_true",
                    help="write docs/figures/recording_<scenario>.png")
    args = ap.parse_args(argv)
    missing = missing_prerequisites()
    if missing:
        print("cannot take screenshots; missing: " + "; ".join(missing), file=sys.stderr)
        return 2
    out = Path(args.output)
    failed = 0
    for name in args.scenario or DEFAULT_SCENARIOS:
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
