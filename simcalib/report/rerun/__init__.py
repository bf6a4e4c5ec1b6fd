"""ALL rerun code of simcalib, split by what it records (docs/recording.md shows them).

Nothing outside this folder imports rerun; nothing here imports it at module level (a
run never imports rerun: :mod:`.worker` hands the calls to a process that does).

* :mod:`.common` — colours, entity names, number formats, eyes, opening a recording
* :mod:`.worker` — the recording worker's client (stand-ins for ``rerun`` whose calls are
  pickled into a spool file), :mod:`.replay` the worker itself (a script: stdlib + rerun)
* :mod:`.labels` — labels laid out on a 3D view's screen so that none overlaps another
* a run (``recording.rrd`` of ``simcalib run``): :mod:`.run` (:class:`~.run.RunRecorder`,
  the one place deciding what each stage's results look like), :mod:`.run_scene` (room,
  markers, platform, trajectories, cameras and images), :mod:`.run_closeup` (the
  extrinsic close-up), :mod:`.run_plots` (pose-source errors, convergence),
  :mod:`.run_summary` (the summary pane), :mod:`.run_layout` (the blueprints)
* :mod:`.calibration` — ``simcalib calibrate``'s recording
* :mod:`.studies` — sweep and experiment recordings
* :mod:`.advice` — ``simcalib advise``'s recording
"""
