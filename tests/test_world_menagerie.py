"""Optional Menagerie arm (``arm_model="menagerie"`` with ``$MENAGERIE_ROOT``).

No Menagerie copy exists offline, so the test writes a minimal stand-in with the
Menagerie UR5e's file layout (``universal_robots_ur5e/ur5e.xml``, ``meshdir="assets"``,
mesh geoms, body names, kinematic chain, no ``attachment_site``) and checks that the loader
resolves meshes, adds the flange site, solves the home pose and simulates exactly."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from simcalib.geometry import relative_motions
from simcalib.world import WorldConfig, build_world

pytest.importorskip("mujoco")

CUBE_OBJ = """v -0.03 -0.03 -0.03
v 0.03 -0.03 -0.03
v 0.03 0.03 -0.03
v -0.03 0.03 -0.03
v -0.03 -0.03 0.03
v 0.03 -0.03 0.03
v 0.03 0.03 0.03
v -0.03 0.03 0.03
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""

UR5E_LIKE = """<mujoco model="ur5e">
  <compiler angle="radian" meshdir="assets" autolimits="true"/>
  <default>
    <joint axis="0 1 0" range="-6.28319 6.28319"/>
    <default class="visual"><geom type="mesh" contype="0" conaffinity="0" group="2"/></default>
  </default>
  <asset><mesh name="cube" file="cube.obj"/></asset>
  <worldbody>
    <light name="spotlight" mode="targetbodycom" target="wrist_2_link" pos="0 -1 2"/>
    <body name="base" quat="1 0 0 1">
      <inertial mass="4.0" pos="0 0 0" diaginertia="0.0044 0.0044 0.0072"/>
      <geom mesh="cube" class="visual"/>
      <body name="shoulder_link" pos="0 0 0.163">
        <inertial mass="3.7" pos="0 0 0" diaginertia="0.01 0.01 0.0067"/>
        <joint name="shoulder_pan_joint" axis="0 0 1"/>
        <geom mesh="cube" class="visual"/>
        <body name="upper_arm_link" pos="0 0.138 0" quat="1 0 1 0">
          <inertial mass="8.4" pos="0 0 0.2125" diaginertia="0.13 0.13 0.015"/>
          <joint name="shoulder_lift_joint"/>
          <geom mesh="cube" class="visual"/>
          <body name="forearm_link" pos="0 -0.131 0.425">
            <inertial mass="2.3" pos="0 0 0.196" diaginertia="0.031 0.031 0.0041"/>
            <joint name="elbow_joint" range="-3.1415 3.1415"/>
            <geom mesh="cube" class="visual"/>
            <body name="wrist_1_link" pos="0 0 0.392" quat="1 0 1 0">
              <inertial mass="1.2" pos="0 0.127 0" diaginertia="0.0026 0.0026 0.0022"/>
              <joint name="wrist_1_joint"/>
              <geom mesh="cube" class="visual"/>
              <body name="wrist_2_link" pos="0 0.127 0">
                <inertial mass="1.2" pos="0 0 0.1" diaginertia="0.0026 0.0026 0.0022"/>
                <joint name="wrist_2_joint" axis="0 0 1"/>
                <geom mesh="cube" class="visual"/>
                <body name="wrist_3_link" pos="0 0 0.1">
                  <inertial mass="0.19" pos="0 0.077 0" diaginertia="0.00013 0.0001 0.0001"/>
                  <joint name="wrist_3_joint"/>
                  <geom mesh="cube" class="visual"/>
                </body>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe><key name="home" qpos="-1.5708 -1.5708 1.5708 -1.5708 -1.5708 0"/></keyframe>
</mujoco>
"""


@pytest.mark.slow
def test_menagerie_arm_loads_and_simulates(tmp_path, monkeypatch):
    d = tmp_path / "universal_robots_ur5e"
    (d / "assets").mkdir(parents=True)
    (d / "assets" / "cube.obj").write_text(CUBE_OBJ)
    (d / "ur5e.xml").write_text(UR5E_LIKE)
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    cfg = WorldConfig(path="3d", arm_model="menagerie", duration_s=10.0)
    w = build_world(cfg, np.random.default_rng(0))
    assert w.model.nmesh == 1 and w.model.nq == 6
    assert w.scene.mount_site == "arm/attachment_site"
    assert w.ik["max_pos_error_m"] < 1e-6
    tr = w.trajectory
    i = np.arange(tr.cam_a.n_frames - 1)
    C, H = relative_motions(tr.cam_a.T_world_cam, tr.cam_b.T_world_cam, i, i + 1)
    assert np.abs(C @ tr.T_a_b - tr.T_a_b @ H).max() < 1e-9
    # same flange path as the built-in arm -> the same camera poses
    ref = build_world(WorldConfig(path="3d", duration_s=10.0), np.random.default_rng(0))
    assert np.abs(tr.cam_a.T_world_cam - ref.trajectory.cam_a.T_world_cam).max() < 1e-6
    assert tr.cam_a.visible_markers.min() >= 4


def test_menagerie_errors_name_the_variable(tmp_path, monkeypatch):
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    with pytest.raises(ValueError, match="MENAGERIE_ROOT"):
        build_world(WorldConfig(path="3d", arm_model="menagerie"), np.random.default_rng(0))
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    with pytest.raises(ValueError, match="has no universal_robots_ur5e/ur5e.xml"):
        build_world(WorldConfig(path="3d", arm_model="menagerie"), np.random.default_rng(0))
    with pytest.raises(ValueError, match="arm_model must be 'builtin'"):
        WorldConfig(path="3d", arm_model="ur10")
