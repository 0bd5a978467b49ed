"""Controllers of the wheeled-robot thesis (its chapter 3), usable on any model with an adapter.

A controller maps (t, measured pose, optional twist) to a body command (v, w); see
:mod:`mjtrack.control.interface`.  Open loop: :class:`FeedForward` (3.1-3.4).  Closed loop:
:class:`ReactiveController` (3.5-3.6), :class:`PolarPostureController` (3.7-3.10),
:class:`LineFollower` (3.2.2), :class:`TrajectoryTracker` (3.11-3.21).
"""

from mjtrack.control.feedforward import ConstantSpeedProfile as ConstantSpeedProfile
from mjtrack.control.feedforward import FeedForward as FeedForward
from mjtrack.control.feedforward import Reference as Reference
from mjtrack.control.feedforward import TriangularProfile as TriangularProfile
from mjtrack.control.interface import AckermannAdapter as AckermannAdapter
from mjtrack.control.interface import ClosedLoopResult as ClosedLoopResult
from mjtrack.control.interface import Controller as Controller
from mjtrack.control.interface import Plant as Plant
from mjtrack.control.interface import TrackSpeedAdapter as TrackSpeedAdapter
from mjtrack.control.interface import WheelSpeedAdapter as WheelSpeedAdapter
from mjtrack.control.interface import adapter_for as adapter_for
from mjtrack.control.interface import run_closed_loop as run_closed_loop
from mjtrack.control.line_following import LineFollower as LineFollower
from mjtrack.control.paths import ParametricPath as ParametricPath
from mjtrack.control.paths import Polyline as Polyline
from mjtrack.control.paths import circle_path as circle_path
from mjtrack.control.paths import figure_eight_path as figure_eight_path
from mjtrack.control.paths import lane_change_path as lane_change_path
from mjtrack.control.posture import PolarPostureController as PolarPostureController
from mjtrack.control.posture import polar_error as polar_error
from mjtrack.control.reactive import ReactiveController as ReactiveController
from mjtrack.control.tracked import TrackedKinematic as TrackedKinematic
from mjtrack.control.tracking import TrajectoryTracker as TrajectoryTracker
from mjtrack.control.tracking import error_matrix as error_matrix
from mjtrack.control.tracking import placement_gains as placement_gains
from mjtrack.control.tracking import tracking_error as tracking_error
