"""Choice of the offscreen OpenGL backend (EGL, OSMesa, GLFW) for MuJoCo rendering.

How MuJoCo 4.0.0 picks its backend (read from ``mujoco/rendering/classic/gl_context.py``):
``import mujoco`` reads ``MUJOCO_GL`` once, at import time, and binds
``mujoco.GLContext`` (the class ``mujoco.Renderer`` instantiates) to ``mujoco.egl``,
``mujoco.osmesa`` or, when the variable is unset, ``mujoco.glfw`` (which needs a display).
Setting ``MUJOCO_GL`` after ``mujoco`` was imported therefore has no effect on
``mujoco.Renderer``, and the rest of mjtrack imports ``mujoco`` early. The backend
modules themselves can still be imported afterwards: ``mujoco.egl.GLContext`` made current
before ``mujoco.MjrContext`` renders fine in a process whose ``mujoco`` bound GLFW (checked
on MuJoCo 4.0.0, Debian 12, Mesa llvmpipe, no GPU, no display). mjtrack's renderer
(:mod:`mjtrack.render.offscreen`) therefore creates its context from the backend module
directly and never depends on the import order.

A second constraint comes from PyOpenGL, which both backends use: its platform
(``PYOPENGL_PLATFORM``, set to ``egl`` or ``osmesa`` by the backend module when unset) is
fixed when ``OpenGL`` is first imported. A process that tried EGL cannot fall back to
OSMesa. The automatic choice therefore probes each candidate in a short-lived subprocess
(one tiny offscreen render, about a second, once per process) and only then loads the
winner here.

Order: ``MUJOCO_GL`` if the user set it (no fallback: the user asked for it); otherwise
``egl`` then ``osmesa``. When nothing works, :class:`RenderUnavailableError` says what was
tried, why each failed and which Debian packages provide the backends.
"""

from __future__ import annotations

import importlib
import logging
import os
import subprocess
import sys

from mjtrack.errors import MjtrackError

logger = logging.getLogger(__name__)

CANDIDATES = ("egl", "osmesa")
_DISABLED = ("disable", "disabled", "off", "false", "0")
_PROBE_TIMEOUT = 60.0  # [s] a cold import of mujoco + one render takes about 1 s

INSTALL_HINT = (
    "install EGL (apt-get install libegl1 libgl1-mesa-dri libopengl0) "
    "or OSMesa (apt-get install libosmesa6), or set MUJOCO_GL to a backend that works here"
)

# Renders one frame of an empty model with the backend named in MUJOCO_GL.
_PROBE = """
import importlib, os, mujoco
ctx = importlib.import_module("mujoco." + os.environ["MUJOCO_GL"]).GLContext(16, 16)
ctx.make_current()
model = mujoco.MjModel.from_xml_string("<mujoco/>")
mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, mjr)
mujoco.mjr_render(mujoco.MjrRect(0, 0, 16, 16), mujoco.MjvScene(model, 10), mjr)
mjr.free()
ctx.free()
"""

_chosen: str | None = None


class RenderUnavailableError(MjtrackError, RuntimeError):
    """No offscreen OpenGL backend works in this process (message: what was tried, what to install)."""


def _module_name(backend: str) -> str:
    """The ``mujoco`` submodule that provides ``GLContext`` for a ``MUJOCO_GL`` value (as MuJoCo maps it)."""
    return backend if backend in ("egl", "osmesa") else "glfw"


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else "no message"


def probe(backend: str, *, timeout: float = _PROBE_TIMEOUT) -> str | None:
    """Try one offscreen render with ``backend`` in a subprocess; ``None`` if it works, else why not."""
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    if backend in ("egl", "osmesa"):
        env["PYOPENGL_PLATFORM"] = backend
    try:
        proc = subprocess.run(
            [sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        return f"no answer within {timeout:g} s"
    except OSError as exc:
        return f"could not start {sys.executable}: {exc}"
    if proc.returncode != 0:
        return _last_line(proc.stderr)
    return None


def select_backend() -> str:
    """Name of the backend this process renders with (``MUJOCO_GL`` value); chosen once, then cached.

    Sets ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM`` for EGL/OSMesa) in ``os.environ`` when they
    are unset, so that code importing ``mujoco`` later (and subprocesses) use the same backend.

    Raises:
        RenderUnavailableError: rendering is disabled, or no candidate works.
    """
    global _chosen
    if _chosen is not None:
        return _chosen
    user = os.environ.get("MUJOCO_GL", "").strip().lower()
    if user in _DISABLED:
        raise RenderUnavailableError(f"rendering is disabled by MUJOCO_GL={user!r}; unset it or set it to egl or osmesa")
    if user:
        logger.debug("MUJOCO_GL=%s set by the user", user)
        backend = user
    else:
        failures = []
        backend = ""
        for candidate in CANDIDATES:
            why = probe(candidate)
            if why is None:
                backend = candidate
                break
            failures.append(f"{candidate}: {why}")
            logger.info("offscreen backend %s does not work here: %s", candidate, why)
        if not backend:
            raise RenderUnavailableError(
                f"no offscreen OpenGL backend works (tried {'; '.join(failures)}); {INSTALL_HINT}"
            )
        os.environ["MUJOCO_GL"] = backend
    if backend in ("egl", "osmesa"):
        os.environ.setdefault("PYOPENGL_PLATFORM", backend)
    logger.info("offscreen rendering with MUJOCO_GL=%s", backend)
    _chosen = backend
    return backend


def make_context(width: int, height: int):
    """A current OpenGL context of the selected backend, large enough for ``width`` x ``height`` [px].

    The caller owns it and calls ``.free()`` when done.

    Raises:
        RenderUnavailableError: the backend cannot be loaded or cannot create a context.
    """
    backend = select_backend()
    try:
        module = importlib.import_module(f"mujoco.{_module_name(backend)}")
        context = module.GLContext(width, height)
        context.make_current()
    except Exception as exc:  # ImportError, OSError, RuntimeError, GLError... all mean the same here
        raise RenderUnavailableError(
            f"offscreen backend MUJOCO_GL={backend} failed: {type(exc).__name__}: {_last_line(str(exc))}; {INSTALL_HINT}"
        ) from exc
    return context
