"""Platform ``cart``: a kinematic (mocap) cart on the floor; the path moves its base."""

from __future__ import annotations

import numpy as np

from simcalib.world.platforms.base import PlatformInfo, PlatformMotion
from simcalib.world.platforms.registry import register

__all__ = ["CartPlatform"]


class CartPlatform:
    info = PlatformInfo(name="cart", rig_mount_m=(0.16, 0.0, 1.10), description="kinematic cart (mocap body) sliding on the "
                                                 "flat floor; its base is the target frame")

    def attach(self, spec, cfg) -> str:
        import mujoco
        from simcalib.world.scene import MODELS_DIR
        cart = mujoco.MjSpec.from_file(str(MODELS_DIR / "cart.xml"))
        spec.attach(cart, prefix="cart/", frame=spec.worldbody.add_frame())
        return "cart/rig_mount"

    def home(self, model, data, mount_site, cfg):
        return np.eye(4), np.zeros(model.nq)

    def drive(self, scene, T_world_target, t, cfg) -> PlatformMotion:
        from simcalib.geometry import quat_from_matrix, quat_wxyz_from_xyzw
        T = np.asarray(T_world_target, dtype=np.float64)
        return PlatformMotion(
            qpos=np.zeros((T.shape[0], scene.model.nq)),
            mocap_pos=T[:, None, :3, 3].copy(),
            mocap_quat_wxyz=quat_wxyz_from_xyzw(quat_from_matrix(T[:, :3, :3]))[:, None, :])


register(CartPlatform())
