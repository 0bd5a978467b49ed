"""Screening rules: the windows of a log that no model of the ground can explain.

Two rules, each stated with the physics that makes it safe (:data:`AGAINST_WHY`,
:data:`STUCK_WHY`): poses that move against the tracks without the braking the ground forces,
and a robot held still while a track runs under it. Calibration and diagnosis leave such windows
out and list them (:func:`without_contradicting`, :func:`left_out_counts`).
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G
from mjtrack.windows.define import WindowSet

#: A window's poses contradict its tracks when, with the tracks' path pointing the same way in both
#: halves of the window, the body moves at least ``AGAINST_PATH_M`` against it in the second half
#: without having slowed down: a body moving against its tracks on level ground is braked by the
#: ground, at ``AGAINST_MU`` or more times g, so its second-half path against them is at least
#: AGAINST_MU g tau^2 shorter than its first-half path (halves of tau seconds). A body still
#: coasting against tracks that reversed (a DRIVE window that starts at speed) slows down and is not
#: flagged; a record whose localisation jumped or flipped, or whose speeds have the wrong sign, is.
#: A robot sliding down a slope its tracks cannot climb is flagged too (the docs say so).
AGAINST_PATH_M = 0.5
AGAINST_MU = 0.05
AGAINST_WHY = (f"in the second half of the window the poses move at least {AGAINST_PATH_M:g} m against the tracks, "
               f"which push the same way in both halves, without the slowing down that ground friction (at least "
               f"{AGAINST_MU:g} g) forces on a body moving against its tracks on level ground: the window's pose or "
               "speed record is wrong")


def _middle_row(log: DriveLog, s: int, e: int) -> int | None:
    """The first row at or after the middle of rows s..e in time; None when it is an end row."""
    m = int(np.searchsorted(log.t[s:e + 1], log.t[s] + 0.5 * float(log.t[e] - log.t[s]) - 1e-9)) + s
    return m if s < m < e else None


def _track_speeds(log: DriveLog) -> tuple[np.ndarray, np.ndarray]:
    """Each row's left and right track speed: measured where the log has it, else commanded."""
    vl = log.v_left if log.has_track_speeds else log.v_left_cmd
    vr = log.v_right if log.has_track_speeds else log.v_right_cmd
    return np.where(np.isfinite(vl), vl, log.v_left_cmd), np.where(np.isfinite(vr), vr, log.v_right_cmd)


def contradicting_windows(log: DriveLog, ws: WindowSet) -> list[dict]:
    """The windows whose measured poses move against the tracks in a way the ground cannot allow
    (:data:`AGAINST_WHY`), each as ``{"index", "t0", "track_path_m", "body_path_m"}``: the window's
    index in ``ws``, its start time, and, per half of the window, the signed path of the mean track
    speed (measured when present, else commanded) and the signed path of the poses along their own
    heading."""
    if len(ws) == 0:
        return []
    vl, vr = _track_speeds(log)
    v = 0.5 * (vl + vr)
    out = []
    for j, (s, e) in enumerate(zip(ws.starts, ws.ends)):
        m = _middle_row(log, s, e)
        if m is None:
            continue
        tau = 0.5 * float(log.t[e] - log.t[s])
        track, body = [], []
        for a, b in ((s, m), (m, e)):
            track.append(float(np.sum(v[a:b] * np.diff(log.t[a:b + 1]))))
            yaw = log.yaw[a:b]
            body.append(float(np.sum(np.diff(log.x[a:b + 1]) * np.cos(yaw) + np.diff(log.y[a:b + 1]) * np.sin(yaw))))
        if track[0] * track[1] <= 0:
            continue
        against = [-np.sign(track[0]) * b for b in body]
        if against[1] >= AGAINST_PATH_M and against[1] > against[0] - AGAINST_MU * G * tau ** 2:
            out.append({"index": j, "t0": float(log.t[s]), "track_path_m": track, "body_path_m": body})
    return out


#: A window's robot is held by something the simulation does not have (an obstacle, a rut, a
#: ledge it is high-centred on) when, in one half of the window, a track runs at least
#: ``STUCK_PATH_M`` while neither point under the tracks' centres gets ``STUCK_SHARE`` of that away
#: from where it was at the half's start.
#: On level ground a track that slides under the body pushes it: in the steady state of Coulomb
#: ground the points under the tracks move by about a sixth of the faster track's speed or more, for every
#: track length up to four times the gauge, pivot and spin turns included (docs/theory/simulator.md,
#: "Windows of a log"), and from rest a ground of at least ``AGAINST_MU`` friction moves them by
#: AGAINST_MU g tau^2 / 2, about 0.25 m in a one-second half.
STUCK_PATH_M = 0.5
STUCK_SHARE = 0.1
STUCK_WHY = (f"in one half of the window a track runs at least {STUCK_PATH_M:g} m while neither point under the "
             f"tracks' centres gets {STUCK_SHARE:g} of that away from where it was: on level ground a track that "
             "slides under the body pushes it, so something the simulation does not have (an obstacle, a rut, a "
             "ledge) held the robot")


def stuck_windows(log: DriveLog, ws: WindowSet, gauge: float) -> list[dict]:
    """The windows in which the robot is held still while a track runs under it (:data:`STUCK_WHY`),
    each as ``{"index", "t0", "track_path_m", "body_path_m"}``: per half of the window, the longer
    of the two tracks' paths (measured speeds when present, else commanded; unsigned) and how far the
    points under the tracks' centres (at +-gauge/2 across the body) get from where they were at the
    half's start (the larger of the two; the farthest sample, so that a body that reverses within
    the half counts how far it went, and pose noise is not summed up as motion)."""
    vl, vr = (np.abs(v) for v in _track_speeds(log))
    out = []
    for j, (s, e) in enumerate(zip(ws.starts, ws.ends)):
        m = _middle_row(log, s, e)
        if m is None:
            continue
        track, body = [], []
        for a, b in ((s, m), (m, e)):
            dt = np.diff(log.t[a:b + 1])
            track.append(float(max(np.sum(vl[a:b] * dt), np.sum(vr[a:b] * dt))))
            moved = 0.0
            for y in (0.5 * gauge, -0.5 * gauge):  # the point under each track's centre, in the world
                px = log.x[a:b + 1] - y * np.sin(log.yaw[a:b + 1])
                py = log.y[a:b + 1] + y * np.cos(log.yaw[a:b + 1])
                moved = max(moved, float(np.max(np.hypot(px - px[0], py - py[0]))))
            body.append(moved)
        if any(tp >= STUCK_PATH_M and bp <= STUCK_SHARE * tp for tp, bp in zip(track, body)):
            out.append({"index": j, "t0": float(log.t[s]), "track_path_m": track, "body_path_m": body})
    return out


def without_contradicting(log: DriveLog, ws: WindowSet, gauge: float) -> tuple[WindowSet, list[dict]]:
    """``ws`` less the windows the ground cannot explain, and those windows, in time order: each
    with ``kind`` ("against": :func:`contradicting_windows`; "stuck": :func:`stuck_windows` for a
    robot of track gauge ``gauge`` [m]), ``t0``, ``track_path_m``, ``body_path_m``. A window both
    rules find is listed once, as "against"."""
    rows = {b["index"]: {"kind": "against", **b} for b in contradicting_windows(log, ws)}
    for b in stuck_windows(log, ws, gauge):
        rows.setdefault(b["index"], {"kind": "stuck", **b})
    keep = np.ones(len(ws), bool)
    keep[list(rows)] = False
    return ws.subset(keep), [{k: v for k, v in rows[i].items() if k != "index"} for i in sorted(rows)]


def left_out_counts(rows: Sequence[Mapping]) -> str:
    """"2 whose poses move against the tracks, 6 in which the robot was held still" (the kinds present)."""
    words = {"against": "whose poses move against the tracks", "stuck": "in which the robot was held still"}
    n = {k: sum(r["kind"] == k for r in rows) for k in words}
    return ", ".join(f"{n[k]} {w}" for k, w in words.items() if n[k])
