"""One offscreen render context that renders a model's camera at any size up to its buffer.

``mujoco.Renderer`` renders one size per context, and a context costs the upload of the model's
textures (0.4 s for the belt stage's board on 2 cores): an area-of-interest read-out, whose size
changes from view to view, would pay it again for each size. This renders any viewport of the
one buffer, with the same calls as ``mujoco.Renderer`` (so a full frame is the same pixels).
The render contexts of a thread are made in one GL context, kept for the process.
"""

from __future__ import annotations

import os
import threading

import mujoco
import numpy as np

from calibench.errors import BadInput

# This thread's GL contexts, kept for the process: MuJoCo's render contexts are made in one after
# another, as a study worker's trials make theirs (a fresh GL context's first render context
# costs 0.1 s on llvmpipe, its shaders compiled; the next ones 8-30 ms). mujoco.egl terminates
# the display at exit, which frees them.
_GL = threading.local()


def _gl_context(width: int, height: int) -> mujoco.GLContext:
    """This thread's GL context for buffers up to ``width`` x ``height``, made on first use: one
    for every size under EGL, which renders to the render context's own buffers; one per size
    under OSMesa and GLFW, whose context has a buffer (or window) of its size."""
    egl = mujoco.GLContext.__module__.startswith("mujoco.egl")
    key = None if egl else (width, height)
    contexts = _GL.__dict__.setdefault("contexts", {})
    gl = contexts.get(key)
    if gl is None:
        gl = contexts[key] = mujoco.GLContext(width, height)
    return gl


def no_gl_context(e: BaseException) -> BadInput:
    """The bad input where no offscreen GL context could be made: the environment's MUJOCO_GL
    (garbage, empty, ``glfw`` without a display, ``osmesa`` without its library, ``disable``),
    said with what to set. ``e``: the backend's own failure, quoted in short."""
    said = os.environ.get("MUJOCO_GL")
    why = (str(e).strip().splitlines() or [type(e).__name__])[-1][:100]
    backend = "MUJOCO_GL unset" if said is None else f"MUJOCO_GL={said!r}"
    return BadInput(
        f"cannot render offscreen with {backend} ({why}): set MUJOCO_GL=egl (Mesa renders on "
        "the CPU, no display needed), or run with --fidelity analytic"
    )


def _renderer_name() -> str:
    """GL_RENDERER of the current context; "unknown" where PyOpenGL cannot ask (a name is a
    report's detail, never a reason for a render to fail)."""
    try:
        from OpenGL import GL  # PyOpenGL, MuJoCo's EGL binding's own dependency

        name = GL.glGetString(GL.GL_RENDERER)
    except Exception:  # noqa: BLE001 - any binding's failure is the same "unknown"
        return "unknown"
    return name.decode() if isinstance(name, bytes) else "unknown"


def gl_renderer(model: mujoco.MjModel) -> str:
    """The GL_RENDERER string of an offscreen context for ``model`` (a GPU's name, or Mesa's
    llvmpipe when the frames are rasterised on the CPU)."""
    screen = Offscreen(model)
    try:
        return screen.renderer
    finally:
        screen.close()


class Offscreen:
    """A model's offscreen renderer: any (width, height) within ``vis.global_.offwidth`` x
    ``offheight``, in the thread that made it (its GL context is that thread's).

    Where no light of the model casts a shadow when it is made, it renders without a shadow map
    (one cast later is not drawn by it).

    Parameters
    ----------
    model : mujoco.MjModel
        The model; its offscreen buffer bounds the sizes.
    max_geom : int
        The scene's capacity (``mujoco.Renderer``'s default).
    """

    def __init__(self, model: mujoco.MjModel, max_geom: int = 10000):
        self.model = model
        self.max_size = (int(model.vis.global_.offwidth), int(model.vis.global_.offheight))
        try:
            self._gl = _gl_context(*self.max_size)
            self._gl.make_current()
        except Exception as e:  # noqa: BLE001 - every backend fails in its own words
            raise no_gl_context(e) from None
        # no light casts a shadow, so no shadow pass: the shadow map (4096 px square by default)
        # would be allocated for nothing, and it was most of a render context's cost; MuJoCo
        # reads the size only here, so the caller's model keeps its own
        shadow = int(model.vis.quality.shadowsize)
        if not model.light_castshadow.any():
            model.vis.quality.shadowsize = 0
        try:
            self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
        except mujoco.FatalError as e:
            # GLFW without a display "makes" a context that is none: MuJoCo finds out here
            if "OpenGL" not in str(e):
                raise
            raise no_gl_context(e) from None
        finally:
            model.vis.quality.shadowsize = shadow
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._context)
        self._scene = mujoco.MjvScene(model=model, maxgeom=max_geom)
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.renderer = _renderer_name()

    def render(
        self,
        data: mujoco.MjData,
        camera_id: int,
        option: mujoco.MjvOption,
        width: int,
        height: int,
    ) -> np.ndarray:
        """The camera's view now, (height, width, 3) uint8, rows from the top.

        Raises
        ------
        ValueError
            The size exceeds the model's offscreen buffer.
        """
        if width > self.max_size[0] or height > self.max_size[1]:
            raise ValueError(f"a {width}x{height} render exceeds the {self.max_size} buffer")
        self._gl.make_current()
        # the GL context is shared: its framebuffer binding may be another render context's
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._context)
        self._camera.fixedcamid = camera_id
        mujoco.mjv_updateScene(
            self.model,
            data,
            option,
            None,
            self._camera,
            mujoco.mjtCatBit.mjCAT_ALL.value,
            self._scene,
        )
        rect = mujoco.MjrRect(0, 0, width, height)
        mujoco.mjr_render(rect, self._scene, self._context)
        pixels = np.empty((height, width, 3), np.uint8)
        mujoco.mjr_readPixels(pixels, None, rect, self._context)
        return np.flipud(pixels)

    def close(self) -> None:
        """Free the render context (idempotent); the thread's GL context stays for the next."""
        if self._context is not None:
            self._gl.make_current()
            self._context.free()
            self._context = None
