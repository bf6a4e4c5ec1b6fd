"""The MuJoCo model's visible geometry as plain data, for drawing the scene elsewhere
(the rerun recording): geoms grouped by body, and each moving body's pose per frame.

``scene_geometry(model, qpos, mocap_pos, mocap_quat_wxyz)`` -> :class:`SceneGeometry`:

* ``static``: the world body's geoms (room, markers) with their world poses;
* ``bodies``: every other body that carries geoms (cart, wheels, arm links, rig), each with
  its geoms in the body frame (logged once) and ``T_world_body`` ``(F, 4, 4)`` per frame
  (the simulated states, posed with ``mj_kinematics``).

Geom kinds: ``box`` (``size`` = half sizes), ``sphere`` (radius), ``capsule`` and
``cylinder`` (radius, half length along the geom's z), ``ellipsoid`` (radii), ``plane``
(half extents), ``mesh`` (``vertices`` (V, 3) and ``faces`` (T, 3) in the geom frame).
Height fields are skipped. Quaternions (x, y, z, w) as everywhere in simcalib.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcalib.geometry import quat_from_matrix, quat_xyzw_from_wxyz

__all__ = ["Geom", "BodyGeometry", "SceneGeometry", "scene_geometry"]

_KINDS = {0: "plane", 2: "sphere", 3: "capsule", 4: "ellipsoid", 5: "cylinder", 6: "box",
          7: "mesh"}


@dataclass(frozen=True)
class Geom:
    """One geom: ``kind``, ``name``, ``size`` (MuJoCo's 3 numbers), pose in its parent
    (``pos``, ``quat_xyzw``), ``rgba`` (0..1), ``vertices``/``faces`` for meshes."""
    name: str
    kind: str
    size: np.ndarray
    pos: np.ndarray
    quat_xyzw: np.ndarray
    rgba: np.ndarray
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None


@dataclass(frozen=True)
class BodyGeometry:
    """A moving body: its geoms (body frame) and ``T_world_body`` ``(F, 4, 4)``."""
    name: str
    geoms: tuple[Geom, ...]
    T_world_body: np.ndarray


@dataclass(frozen=True)
class SceneGeometry:
    static: tuple[Geom, ...]
    bodies: tuple[BodyGeometry, ...] = field(default_factory=tuple)


def _geom_rgba(model, g: int) -> np.ndarray:
    mat = int(model.geom_matid[g])
    rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]
    return np.asarray(rgba, dtype=np.float64).copy()


def _geom(model, g: int, pos, quat_xyzw) -> Geom | None:
    import mujoco
    kind = _KINDS.get(int(model.geom_type[g]))
    if kind is None:
        return None
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom_{g}"
    verts = faces = None
    if kind == "mesh":
        m = int(model.geom_dataid[g])
        va, vn = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
        fa, fn = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
        verts = np.asarray(model.mesh_vert[va:va + vn], dtype=np.float32).copy()
        faces = np.asarray(model.mesh_face[fa:fa + fn], dtype=np.uint32).copy()
    return Geom(name=name, kind=kind, size=np.asarray(model.geom_size[g], dtype=np.float64).copy(),
                pos=np.asarray(pos, dtype=np.float64).copy(),
                quat_xyzw=np.asarray(quat_xyzw, dtype=np.float64).copy(),
                rgba=_geom_rgba(model, g), vertices=verts, faces=faces)


def scene_geometry(model, qpos: np.ndarray, mocap_pos: np.ndarray,
                   mocap_quat_wxyz: np.ndarray, *, skip_prefix: tuple[str, ...] = ("marker_",)
                   ) -> SceneGeometry:
    """See the module docstring. ``qpos`` ``(F, nq)``, ``mocap_pos`` ``(F, nmocap, 3)``,
    ``mocap_quat_wxyz`` ``(F, nmocap, 4)``: the simulated states of F frames. World geoms
    whose name starts with ``skip_prefix`` are left out (the markers are drawn from the
    marker field)."""
    import mujoco
    qpos = np.asarray(qpos, dtype=np.float64)
    n = qpos.shape[0]
    qpos = qpos.reshape(n, model.nq)
    mocap_pos = np.asarray(mocap_pos, dtype=np.float64).reshape(n, model.nmocap, 3)
    mocap_quat = np.asarray(mocap_quat_wxyz, dtype=np.float64).reshape(n, model.nmocap, 4)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    static = []
    by_body: dict[int, list[Geom]] = {}
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        if b == 0:
            geom = _geom(model, g, data.geom_xpos[g],
                         quat_from_matrix(data.geom_xmat[g].reshape(3, 3)))
            if geom is not None and not geom.name.startswith(skip_prefix):
                static.append(geom)
        else:
            geom = _geom(model, g, model.geom_pos[g], quat_xyzw_from_wxyz(model.geom_quat[g]))
            if geom is not None:
                by_body.setdefault(b, []).append(geom)
    ids = sorted(by_body)
    T = np.tile(np.eye(4), (n, len(ids), 1, 1))
    for k in range(n):
        if model.nq:
            data.qpos[:] = qpos[k]
        if model.nmocap:
            data.mocap_pos[:] = mocap_pos[k]
            data.mocap_quat[:] = mocap_quat[k]
        mujoco.mj_kinematics(model, data)
        T[k, :, :3, :3] = data.xmat[ids].reshape(-1, 3, 3)
        T[k, :, :3, 3] = data.xpos[ids]
    bodies = tuple(BodyGeometry(name=mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
                                or f"body_{b}", geoms=tuple(by_body[b]),
                                T_world_body=T[:, j].copy())
                   for j, b in enumerate(ids))
    return SceneGeometry(static=tuple(static), bodies=bodies)
