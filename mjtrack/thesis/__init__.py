"""Reproductions of the source thesis's chapter-4 experiments (``mjtrack thesis``)."""

from mjtrack.thesis.run import SECTIONS as SECTIONS
from mjtrack.thesis.run import Section as Section
from mjtrack.thesis.run import run_thesis as run_thesis
