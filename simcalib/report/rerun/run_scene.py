"""A run recording's scene: the room, the marker field, the platform's geoms posed per
frame, the true and measured trajectories, both cameras (pinhole, images with the
detections of the same frames). Mixed into :class:`~simcalib.report.rerun.run.RunRecorder`
(``self.rec``: the stream, ``self.rr``: rerun or its stand-in)."""

from __future__ import annotations

import numpy as np

from simcalib.geometry import quat_from_matrix
from simcalib.report.rerun.common import CAMERA_COLORS, entity_name, orbital_eye

__all__ = ["SceneLogging", "iter_visual_log"]


class SceneLogging:
    """The scene part of a run recording (entities ``world/...``)."""

    # ------------------------------------------------------------------ world
    def log_room_and_platform(self, world) -> None:
        """The room (floor solid, walls/ceiling as outlines) and the platform: every moving
        body's geoms logged once in the body frame, the body posed per simulated frame."""
        rr = self.rr
        from simcalib.world.visual import scene_geometry
        frames = world.frames(world.camera_names[0])
        geo = scene_geometry(world.model, frames.qpos, frames.mocap_pos, frames.mocap_quat_wxyz)
        size = np.asarray(world.config.room.size_m, dtype=np.float64)
        self.room = (np.array([-0.5 * size[0], -0.5 * size[1], 0.0]),
                     np.array([0.5 * size[0], 0.5 * size[1], size[2]]))
        for g in geo.static:
            if g.kind != "box":
                continue
            # clip the wall slabs to the room so nothing is drawn outside it
            lo = np.maximum(g.pos - g.size, self.room[0] - 0.02)
            hi = np.minimum(g.pos + g.size, self.room[1] + 0.02)
            floor = g.name == "floor"
            if floor:
                lo[2], hi[2] = -0.01, 0.0
            self.rec.log(f"world/room/{entity_name(g.name)}", rr.Boxes3D(
                centers=[0.5 * (lo + hi)], half_sizes=[0.5 * (hi - lo)],
                colors=[(200, 200, 205) if floor else (150, 150, 150)],
                fill_mode="solid" if floor else "majorwireframe", radii=0.004),
                static=True)
        frame_idx = np.arange(frames.qpos.shape[0], dtype=np.int64)
        for body in geo.bodies:
            ent = f"world/platform/{entity_name(body.name)}"
            T = body.T_world_body
            self.rec.send_columns(ent, indexes=[rr.TimeColumn("frame", sequence=frame_idx)],
                                  columns=rr.Transform3D.columns(   # quaternions: vectorised
                                      translation=T[:, :3, 3],
                                      quaternion=quat_from_matrix(T[:, :3, :3])))
            self._log_geoms(f"{ent}/geoms", body.geoms)
            self._workspace.append(T[:, :3, 3])
        self._update_eye()

    def _log_geoms(self, ent: str, geoms) -> None:
        rr = self.rr
        by_kind: dict[str, list] = {}
        for g in geoms:
            by_kind.setdefault(g.kind, []).append(g)
        for kind, gs in by_kind.items():
            pos = np.array([g.pos for g in gs])
            quat = np.array([g.quat_xyzw for g in gs])
            col = (np.clip(np.array([g.rgba for g in gs]), 0, 1) * 255).astype(np.uint8)
            size = np.array([g.size for g in gs])
            if kind == "box":
                arch = rr.Boxes3D(centers=pos, half_sizes=size, quaternions=quat, colors=col,
                                  fill_mode="solid")
            elif kind == "cylinder":
                arch = rr.Cylinders3D(centers=pos, lengths=2 * size[:, 1], radii=size[:, 0],
                                      quaternions=quat, colors=col, fill_mode="solid")
            elif kind == "capsule":
                from simcalib.geometry import matrix_from_quat
                z = matrix_from_quat(quat)[..., :, 2]
                arch = rr.Capsules3D(translations=pos - z * size[:, 1:2],
                                     lengths=2 * size[:, 1], radii=size[:, 0],
                                     quaternions=quat, colors=col, fill_mode="solid")
            elif kind in ("sphere", "ellipsoid"):
                half = np.repeat(size[:, :1], 3, axis=1) if kind == "sphere" else size
                arch = rr.Ellipsoids3D(centers=pos, half_sizes=half, quaternions=quat,
                                       colors=col, fill_mode="solid")
            elif kind == "mesh":
                for k, g in enumerate(gs):
                    self.rec.log(f"{ent}/{entity_name(g.name)}",
                                 rr.Transform3D(translation=g.pos, quaternion=g.quat_xyzw),
                                 rr.Mesh3D(vertex_positions=g.vertices,
                                           triangle_indices=g.faces,
                                           albedo_factor=tuple(col[k])), static=True)
                continue
            else:   # planes: the room's floor is a box; a plane is drawn as a thin box
                arch = rr.Boxes3D(centers=pos, half_sizes=np.c_[size[:, :2], 0.001 * np.ones(
                    len(gs))], quaternions=quat, colors=col, fill_mode="solid")
            self.rec.log(f"{ent}/{kind}", arch, static=True)

    def log_world(self, marker_field) -> None:
        """The marker field as textured quads (the ArUco pattern with its quiet zone)."""
        rr = self.rr
        if marker_field is None or len(getattr(marker_field, "ids", ())) == 0:
            return
        from simcalib.targets.markers import marker_image
        T = np.asarray(marker_field.T_world_marker)
        cell = 6
        for mid, Tm in zip(marker_field.ids, T):
            img = marker_image(int(mid), pixels=8 * cell, dictionary=marker_field.dictionary)
            img = np.pad(img, cell, constant_values=255)
            n_cells = img.shape[0] / cell
            h = 0.5 * float(marker_field.side_m) * n_cells / (n_cells - 2)
            local = np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])
            verts = local @ Tm[:3, :3].T + Tm[:3, 3] + 0.003 * Tm[:3, 2]
            self.rec.log(f"world/markers/{int(mid)}", rr.Mesh3D(
                vertex_positions=verts, triangle_indices=[[0, 2, 1], [0, 3, 2]],
                vertex_texcoords=[[0, 0], [1, 0], [1, 1], [0, 1]],
                albedo_texture=np.repeat(img[:, :, None], 3, axis=2)), static=True)

    # ----------------------------------------------------------- trajectories
    def log_trajectories(self, gt: dict, source: dict, X_true) -> None:
        rr = self.rr
        scale = 0.08
        pts = [np.asarray(s.T_world_cam)[:, :3, 3] for s in gt.values()]
        if pts:
            allp = np.concatenate(pts)
            ext = float(np.linalg.norm(allp.max(0) - allp.min(0))) if len(allp) else 1.0
            scale = float(np.clip(0.04 * ext, 0.02, 0.1))
        for cam, s in gt.items():
            color = CAMERA_COLORS.get(cam, (200, 200, 200))
            T = np.asarray(s.T_world_cam)
            self._workspace.append(T[:, :3, 3])
            self.rec.log(f"world/trajectories/{cam}/ground_truth",
                         rr.LineStrips3D([T[:, :3, 3]], colors=color, radii=0.1 * scale,
                                         labels=[f"{cam} true path"], show_labels=False),
                         static=True)
            frames = np.asarray(s.frame_index, dtype=np.int64)
            self.rec.send_columns(
                f"world/{cam}",
                indexes=[rr.TimeColumn("frame", sequence=frames),
                         rr.TimeColumn("sim_time", duration=np.asarray(s.timestamp_s,
                                                                        dtype=np.float64))],
                columns=rr.Transform3D.columns(translation=T[:, :3, 3],
                                               quaternion=quat_from_matrix(T[:, :3, :3])))
            self.rec.log(f"world/{cam}/axes", rr.TransformAxes3D(1.5 * scale), static=True)
        for cam, s in source.items():
            color = tuple(int(0.55 * c) for c in CAMERA_COLORS.get(cam, (200, 200, 200)))
            T = np.asarray(s.T_world_cam)
            if T.shape[0] == 0:
                continue
            p = T[:, :3, 3]
            if self.room is not None:   # a wild pose-source sample must not zoom the view out
                p = np.clip(p, self.room[0], self.room[1])
            self.rec.log(f"world/trajectories/{cam}/{s.source}",
                         rr.Points3D(p, colors=color, radii=0.12 * scale), static=True)
        self._update_eye()

    def _update_eye(self) -> None:
        if not self._workspace:
            return
        self.present.add("scene")
        p = np.concatenate(self._workspace)
        lo, hi = p.min(0), p.max(0)
        if self.room is not None:
            lo = np.minimum(lo, [lo[0], lo[1], 0.0])     # include the floor under the platform
            self.eye = orbital_eye(lo, hi, (-1.0, -1.4, 1.0), (0, 0, 1), inside=self.room,
                            min_dist=2.5)
        else:
            self.eye = orbital_eye(lo, hi, (-1.0, -1.4, 0.9), (0, 0, 1))

    # ---------------------------------------------------------------- cameras
    def log_cameras(self, intrinsics: dict, gt: dict, visual_log) -> None:
        """Pinholes of both cameras, and (aruco source) the logged images and corners."""
        rr = self.rr
        intrinsics = dict(getattr(visual_log, "intrinsics", None) or intrinsics or {})
        for cam, K in intrinsics.items():
            self.rec.log(f"world/{cam}/image",
                         rr.Pinhole(image_from_camera=np.asarray(K.K),
                                    resolution=[K.width, K.height],
                                    image_plane_distance=0.15,
                                    color=CAMERA_COLORS.get(cam, (200, 200, 200))), static=True)
        if visual_log is None:
            return
        for cam, frame, image, corners, ids in iter_visual_log(visual_log,
                                                                self.cfg.recording):
            self.rec.set_time("frame", sequence=int(frame))
            ent = f"world/{cam}/image"
            if image is not None:
                self.images = True
                self.image_cameras.add(cam)
                if isinstance(image, (bytes, bytearray, memoryview)):
                    self.rec.log(ent, rr.EncodedImage(contents=bytes(image),
                                                      media_type="image/jpeg"))
                else:
                    self.rec.log(ent, rr.Image(np.asarray(image)).compress(
                        jpeg_quality=self.cfg.recording.jpeg_quality))
            if corners is not None and len(corners):
                c = np.asarray(corners, dtype=np.float32).reshape(-1, 4, 2)
                labels = None if ids is None else [str(int(i)) for i in np.ravel(ids)]
                self.rec.log(f"{ent}/corners", rr.Points2D(c.reshape(-1, 2),
                                                           colors=(0, 255, 0), radii=2.0))
                self.rec.log(f"{ent}/markers", rr.LineStrips2D(
                    np.concatenate([c, c[:, :1]], axis=1), colors=(0, 255, 0),
                    labels=labels))
            else:  # no detections in this frame: no overlay from an older one
                self.rec.log(f"{ent}/corners", rr.Clear(recursive=False))
                self.rec.log(f"{ent}/markers", rr.Clear(recursive=False))
        self.rec.reset_time()


def iter_visual_log(log, rec_cfg):
    """Yield ``(camera, frame, image, corners (K,4,2) | None, ids | None)`` from the vision
    stage's :class:`~simcalib.sources.vision.stream.VisualLog` (``frames[camera]``:
    per-frame records with ``frame_index``, ``ids``, ``corners_px``;
    ``images_jpeg[camera][frame_index]``: JPEG bytes). At most ``rec_cfg.max_images``
    images per camera are yielded (evenly subsampled), each with the corners detected in
    THAT frame; frames without a logged image are not yielded, so an overlay never sits
    on another frame's image."""
    frames_by_cam = getattr(log, "frames", None) or {}
    images = getattr(log, "images_jpeg", None) or {}
    for cam, entries in dict(frames_by_cam).items():
        cam_images = dict(images.get(cam, {}))
        logged = sorted(cam_images)
        keep = set(logged)
        if rec_cfg.max_images < len(logged):
            sel = np.linspace(0, len(logged) - 1, rec_cfg.max_images).round().astype(int) \
                if rec_cfg.max_images else []
            keep = {logged[i] for i in sel}
        for e in entries:
            frame = int(_get(e, "frame_index", "frame"))
            if frame not in keep:
                continue
            yield cam, frame, cam_images[frame], _get(e, "corners_px", "corners"), \
                _get(e, "ids")


def _get(entry, *names):
    for n in names:
        if isinstance(entry, dict) and n in entry:
            return entry[n]
        if hasattr(entry, n):
            return getattr(entry, n)
    return None
