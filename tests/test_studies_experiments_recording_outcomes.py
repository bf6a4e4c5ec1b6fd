"""simcalib.studies.experiments.recording_outcomes: the acceptance checks of one outcome."""

import dataclasses

from simcalib.studies.experiments import recording_outcomes as R


def test_step_acceptance():
    base = R.Outcome("continuous", 0, 0, 1.0, rot_error_deg=0.01, trans_error_mm=0.1)
    assert R.step_failures(base) == []
    assert R.step_failures(dataclasses.replace(base, steps=((5.0, 0.4),))) == [
        "false clock step"]
    stepped = dataclasses.replace(base, kind="clock_step", true_step=(5.0, 0.4))
    assert R.step_failures(stepped) == ["clock step"]
    for told in [((5.0, 0.41),), ((5.05, 0.4),), ((5.0, 0.4), (7.0, 0.1))]:
        assert R.step_failures(dataclasses.replace(stepped, steps=told)) == ["clock step"]
    assert R.step_failures(dataclasses.replace(stepped, steps=((5.01, 0.402),))) == []
    assert "clock step" in R.acceptance_failures(stepped)


def test_mount_acceptance():
    base = R.Outcome("stations", 0, 0, 1.0)
    assert R.mount_failures(base) == []
    assert R.mount_failures(dataclasses.replace(base, mount_change_s=(3.0, 4.0))) == [
        "false mount change"]
    bumped = dataclasses.replace(base, kind="bumped_camera", true_change_s=(3.0, 4.0),
                                 rot_error_deg=0.01, trans_error_mm=0.1)
    assert R.mount_failures(bumped) == ["mount change"]
    assert R.mount_failures(dataclasses.replace(bumped, mount_change_s=(4.0, 5.0))) == [
        "mount change"]
    assert R.mount_failures(dataclasses.replace(bumped, mount_change_s=(3.0, 4.0))) == []
    assert "mount change" in R.acceptance_failures(bumped)
