"""Offscreen rendering: MuJoCo videos (MP4) and animated plots of planar paths (GIF).

No display is needed: :mod:`mjtrack.render.gl` picks an offscreen OpenGL backend
(``MUJOCO_GL`` if set, else EGL, else OSMesa).
"""

from mjtrack.render.animation import AnimationStats as AnimationStats
from mjtrack.render.animation import animate_paths as animate_paths
from mjtrack.render.decor import icr_markers as icr_markers
from mjtrack.render.gl import RenderUnavailableError as RenderUnavailableError
from mjtrack.render.gl import select_backend as select_backend
from mjtrack.render.offscreen import OffscreenRenderer as OffscreenRenderer
from mjtrack.render.video import VideoStats as VideoStats
from mjtrack.render.video import qpos_from_poses as qpos_from_poses
from mjtrack.render.video import render_video as render_video
from mjtrack.render.video import track_travel_from_speeds as track_travel_from_speeds
from mjtrack.render.video import turn_wheels as turn_wheels
