"""A minimal offscreen MuJoCo renderer on the context of :mod:`mjtrack.render.gl`.

It does what ``mujoco.Renderer`` does (scene update, render into the offscreen buffer, read
the pixels back) but takes its OpenGL context from :func:`mjtrack.render.gl.make_context`,
so it works whatever ``MUJOCO_GL`` held when ``mujoco`` was imported (see that module), and
it lets callers add decoration geoms (grid, trail, markers) to the scene between the
update and the render.

Pixels: ``mjr_readPixels`` returns rows bottom-up (OpenGL's origin is the lower-left
corner); :meth:`OffscreenRenderer.render` flips them so that row 0 is the top of the image.
"""

from __future__ import annotations

import copy
import logging

import mujoco
import numpy as np

from mjtrack.render.gl import INSTALL_HINT, RenderUnavailableError, make_context, select_backend

logger = logging.getLogger(__name__)

_IDENTITY = np.eye(3).ravel()


class OffscreenRenderer:
    """Render ``model`` offscreen at ``width`` x ``height`` pixels.

    Args:
        model: the MuJoCo model (not modified: a copy is used when its offscreen buffer
            ``vis.global_.offwidth/offheight`` is smaller than the image).
        width, height: image size [px].
        max_geom: room in the scene for model geoms plus decorations.

    Use as a context manager or call :meth:`close`.
    """

    def __init__(self, model: mujoco.MjModel, *, width: int, height: int, max_geom: int = 10000) -> None:
        if model.vis.global_.offwidth < width or model.vis.global_.offheight < height:
            model = copy.copy(model)
            model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
            model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self.model = model
        self.width, self.height = width, height
        self.scene = mujoco.MjvScene(model, max_geom)
        self.option = mujoco.MjvOption()
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._pixels = np.empty((height, width, 3), dtype=np.uint8)
        self._mjr = None
        self._gl = make_context(width, height)
        try:
            self._mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        except Exception as exc:  # mujoco.FatalError when the context has no usable GL
            self.close()
            raise RenderUnavailableError(
                f"MuJoCo could not create its render context with MUJOCO_GL={select_backend()}: {exc}; {INSTALL_HINT}"
            ) from exc

    def update_scene(self, data: mujoco.MjData) -> None:
        """Fill the scene from ``data`` (kinematics must be current) seen by :attr:`camera`."""
        mujoco.mjv_updateScene(
            self.model, data, self.option, None, self.camera, mujoco.mjtCatBit.mjCAT_ALL, self.scene
        )

    def add_geom(self, gtype: int, size, pos, rgba, *, mat=None) -> bool:
        """Append a decoration geom to the scene; ``False`` (and nothing drawn) when the scene is full."""
        scene = self.scene
        if scene.ngeom >= scene.maxgeom:
            return False
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(
            geom, int(gtype), np.asarray(size, float), np.asarray(pos, float),
            _IDENTITY if mat is None else np.asarray(mat, float).ravel(), np.asarray(rgba, np.float32),
        )
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        scene.ngeom += 1
        return True

    def add_connector(self, gtype: int, width: float, start, end, rgba) -> bool:
        """Append a segment (``mjGEOM_LINE``: ``width`` in pixels; capsule/cylinder: radius [m])."""
        if not self.add_geom(gtype, np.zeros(3), np.zeros(3), rgba):
            return False
        geom = self.scene.geoms[self.scene.ngeom - 1]
        mujoco.mjv_connector(geom, int(gtype), float(width), np.asarray(start, float), np.asarray(end, float))
        return True

    def render(self, overlay: str | None = None) -> np.ndarray:
        """The current scene as a new (height, width, 3) uint8 RGB image, row 0 at the top.

        ``overlay``: text drawn in the top-left corner (MuJoCo's font: ASCII only; tabs
        separate columns, newlines lines).
        """
        self._gl.make_current()
        mujoco.mjr_render(self._rect, self.scene, self._mjr)
        if overlay:
            font = mujoco.mjtFont.mjFONT_BIG if self.height >= 480 else mujoco.mjtFont.mjFONT_NORMAL
            mujoco.mjr_overlay(font, mujoco.mjtGridPos.mjGRID_TOPLEFT, self._rect, overlay, "", self._mjr)
        mujoco.mjr_readPixels(self._pixels, None, self._rect, self._mjr)
        return np.flipud(self._pixels).copy()

    def close(self) -> None:
        """Free the MuJoCo and OpenGL contexts (once; later calls do nothing)."""
        if self._mjr is not None:
            self._gl.make_current()
            self._mjr.free()
            self._mjr = None
        if getattr(self, "_gl", None) is not None:
            self._gl.free()
            self._gl = None

    def __enter__(self) -> "OffscreenRenderer":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
