"""Offscreen rendering: the forward camera's frames and the human-facing view with the flow overlay.

Renderers (and their GL contexts) are created lazily on first use, so an env can be constructed in one process
and stepped in another (``SubprocVecEnv``, ``AsyncVectorEnv``). Headless rendering goes through MuJoCo's
``MUJOCO_GL`` backend; :mod:`flownav_env` defaults it to ``egl``.
"""

from __future__ import annotations

import os

import cv2
import mujoco
import numpy as np

from flownav_env.scene import DRONE_GROUP, PARKED_GROUP

# Size (width, height) of each half of the env's rgb_array render: the camera panel and the chase view.
VIEW_PANEL_SIZE = (320, 240)

# The process that made this process's first GL context, and, in a child forked after that, the parent's pid:
# EGL state does not survive fork(), and a child that renders with it hangs without a word.
_GL_PROCESS: int | None = None
_GL_INHERITED_FROM: int | None = None


def _remember_inherited_gl() -> None:
    global _GL_INHERITED_FROM
    if _GL_PROCESS is not None:
        _GL_INHERITED_FROM = _GL_PROCESS


os.register_at_fork(after_in_child=_remember_inherited_gl)


class ForkedGLContextError(RuntimeError):
    """GL was used in a process forked from one that had already rendered (EGL would hang there)."""


def _check_gl_usable() -> None:
    """Raise instead of hanging when this process was forked after its parent rendered with EGL."""
    global _GL_PROCESS
    if _GL_INHERITED_FROM is not None and os.environ.get("MUJOCO_GL") == "egl":
        raise ForkedGLContextError(
            f"process {os.getpid()} was forked from process {_GL_INHERITED_FROM} after that one had rendered "
            "with EGL, which cannot render after fork() (it hangs). Start worker processes with the 'spawn' "
            "or 'forkserver' method instead: multiprocessing.get_context('forkserver'), "
            "gymnasium.vector.AsyncVectorEnv(..., context='forkserver'), "
            "SubprocVecEnv(..., start_method='forkserver')."
        )
    if _GL_PROCESS is None:
        _GL_PROCESS = os.getpid()


def new_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """A MuJoCo offscreen renderer (and its GL context): the one place FlowNav creates GL contexts.

    Raises:
        ForkedGLContextError: this process was forked after its parent had rendered with EGL.
    """
    _check_gl_usable()
    return mujoco.Renderer(model, height=height, width=width)


def gl_renderer_name() -> str:
    """The OpenGL renderer MuJoCo draws with, as the driver names it (Mesa's ``llvmpipe``, a GPU, ...);
    ``unknown (...)`` where no context can be made, so a report never fails on it."""
    try:
        # Inside the try: a machine whose GL library does not load gets "unknown (ImportError)" too.
        from OpenGL import GL

        _check_gl_usable()
        context = mujoco.GLContext(16, 16)
        context.make_current()
        try:
            name = GL.glGetString(GL.GL_RENDERER)
        finally:
            context.free()
    except Exception as error:  # any GL stack failure: the report names it instead of failing
        return f"unknown ({type(error).__name__})"
    return name.decode() if isinstance(name, bytes) else str(name)


class CameraRenderer:
    """Renders one named camera of a model at a fixed size, creating the GL context on first use.

    ``onboard=True`` is for the drone's own camera: it leaves out the drone's geoms and sites, which that camera
    cannot see from inside the hull but a software rasteriser would still draw.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int, *, onboard: bool = False) -> None:
        self.model = model
        self.width = width
        self.height = height
        self._renderer: mujoco.Renderer | None = None
        self._options = mujoco.MjvOption()
        self._options.geomgroup[PARKED_GROUP] = 0
        if onboard:
            self._options.geomgroup[DRONE_GROUP] = 0
            self._options.sitegroup[DRONE_GROUP] = 0

    def render(self, data: mujoco.MjData, camera: str | int) -> np.ndarray:
        """RGB image (height, width, 3) uint8 of ``camera``, row 0 at the top."""
        if self._renderer is None:
            self._renderer = new_renderer(self.model, self.width, self.height)
        self._renderer.update_scene(data, camera=camera, scene_option=self._options)
        return self._renderer.render()

    def render_depth(self, data: mujoco.MjData, camera: str | int) -> np.ndarray:
        """Depth buffer (height, width) float32: z-depth in metres along the camera axis."""
        if self._renderer is None:
            self._renderer = new_renderer(self.model, self.width, self.height)
        self._renderer.enable_depth_rendering()
        try:
            self._renderer.update_scene(data, camera=camera, scene_option=self._options)
            return self._renderer.render().copy()
        finally:
            self._renderer.disable_depth_rendering()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def depth_colour(depth: np.ndarray, max_depth: float) -> np.ndarray:
    """RGB colours (N, 3) uint8 for depths: red near, through yellow and green, to blue far."""
    if np.size(depth) == 0:
        return np.zeros((0, 3), np.uint8)
    scaled = np.clip(np.asarray(depth, np.float32) / max_depth, 0.0, 1.0)
    lut_input = (255 * (1.0 - scaled)).astype(np.uint8).reshape(-1, 1)
    return cv2.applyColorMap(lut_input, cv2.COLORMAP_JET).reshape(-1, 3)[:, ::-1]


def draw_flow_overlay(
    image: np.ndarray,
    points: np.ndarray,
    next_points: np.ndarray,
    depth: np.ndarray,
    valid: np.ndarray,
    *,
    scale: int,
    max_depth: float,
) -> np.ndarray:
    """The thesis's camera view (Figs. 25–27): tracked points, flow vectors and depth-coloured circles.

    Args:
        image: the camera's RGB frame (H, W, 3).
        points, next_points: (N, 2) pixel positions in the previous and the current frame.
        depth: (N,) estimated depth (m); drawn where ``valid``.
        valid: (N,) bool.
        scale: integer upscaling of the frame so the annotations stay legible.
        max_depth: depth mapped to the far end of the colour scale.

    Returns:
        RGB image (H·scale, W·scale, 3).
    """
    canvas = cv2.resize(
        image, (image.shape[1] * scale, image.shape[0] * scale), interpolation=cv2.INTER_NEAREST
    )
    start = np.round(np.asarray(points) * scale + scale / 2).astype(np.int32)
    end = np.round(np.asarray(next_points) * scale + scale / 2).astype(np.int32)
    valid = np.asarray(valid, bool)
    colours = depth_colour(np.where(valid, depth, max_depth), max_depth)
    for (x0, y0), (x1, y1) in zip(start[~valid], end[~valid], strict=False):
        cv2.line(canvas, (int(x0), int(y0)), (int(x1), int(y1)), (160, 160, 160), 1, cv2.LINE_AA)
    for (x0, y0), (x1, y1), colour in zip(start[valid], end[valid], colours[valid], strict=False):
        rgb = tuple(int(c) for c in colour)
        cv2.line(canvas, (int(x0), int(y0)), (int(x1), int(y1)), (255, 255, 255), 1, cv2.LINE_AA)
        cv2.circle(canvas, (int(x1), int(y1)), 3, rgb, -1, cv2.LINE_AA)
    return canvas


def camera_panel(
    frame: np.ndarray,
    points: np.ndarray,
    next_points: np.ndarray,
    depth: np.ndarray,
    valid: np.ndarray,
    max_depth: float,
) -> np.ndarray:
    """The flow overlay of ``frame`` upscaled by a whole factor to fit, on black, into a
    :data:`VIEW_PANEL_SIZE` panel: small camera frames stay legible beside the chase view."""
    panel_width, panel_height = VIEW_PANEL_SIZE
    scale = max(1, min(panel_width // frame.shape[1], panel_height // frame.shape[0]))
    overlay = draw_flow_overlay(frame, points, next_points, depth, valid, scale=scale, max_depth=max_depth)
    panel = np.zeros((panel_height, panel_width, 3), np.uint8)
    panel[: overlay.shape[0], : overlay.shape[1]] = overlay[:panel_height, :panel_width]
    return panel
