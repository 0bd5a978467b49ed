"""Effects a drive log cannot separate by physics: ties reported with both estimates.

Under Coulomb friction a lateral centre of mass (``cg_y``) and a friction asymmetry
(``mu_ratio``) both set the traction ratio mu_L N_L / (mu_R N_R) of the two sides
(:data:`TRACTION_PAIR`): a diagnosis that finds both names one, lists the other tied with it and
gives each estimate in the other's terms (:func:`physical_tie`), with what would separate them.

A drive force limit (``drive_force_limit`` F per side) and a lower friction (``friction_scale``
s) both cap the traction a side can exert, F against s mu N with N the side's load
(:data:`FORCE_PAIR`): in a skid turn, where every side's traction is at its cap, the two act
alike at s = 2 F / (mu m g). They differ where the ground asks for less than the friction can
give: a straight acceleration above 2 F / m binds the force limit only, and a force-limited
track falls behind its command where a slipping one keeps its speed. When the held-out gains of
the two are equal within noise, the tie says so with each estimate in the other's terms
(:func:`equivalence_note`); when they are not, the log has told them apart and the better one is
named.

Derivation: docs/theory/diagnosis.md, "Selection rules".
"""

from __future__ import annotations

from mjtrack.io.robot import G

TRACTION_PAIR = ("cg_y", "mu_ratio")
FORCE_PAIR = ("drive_force_limit", "friction_scale")


def traction_ratio(robot, name: str, value: float) -> float:
    """mu_L N_L / (mu_R N_R), the traction ratio of the two tracks (lever rule for the loads),
    set by cg_y = value or mu_ratio = value, the other at its nominal."""
    half = robot.track_gauge / 2
    cy = value if name == "cg_y" else robot.cg_y
    a = value if name == "mu_ratio" else robot.friction_left / robot.friction_right
    return a * (half + cy) / (half - cy)


def equivalent(robot, name: str, value: float) -> float:
    """The value of the other effect of :data:`TRACTION_PAIR` that sets the same traction ratio."""
    rho = traction_ratio(robot, name, value)
    half = robot.track_gauge / 2
    if name == "cg_y":  # -> mu_ratio, the nominal cg_y kept
        return rho * (half - robot.cg_y) / (half + robot.cg_y)
    r = rho / (robot.friction_left / robot.friction_right)  # -> cg_y, the nominal asymmetry kept
    return half * (r - 1.0) / (r + 1.0)


def physical_tie(robot, a, b) -> str | None:
    """Why two findings (each with ``effect`` and ``estimate``) cannot be separated by physics, or None
    (module docstring)."""
    if {a.effect.name, b.effect.name} != set(TRACTION_PAIR):
        return None
    cy, fa = (a, b) if a.effect.name == "cg_y" else (b, a)
    rho_c = traction_ratio(robot, "cg_y", float(cy.estimate[0]))
    rho_f = traction_ratio(robot, "mu_ratio", float(fa.estimate[0]))
    if (rho_c - 1.0) * (rho_f - 1.0) <= 0:  # they disagree on which track grips more
        return None
    return (f"under Coulomb friction cg_y and mu_ratio both set the traction ratio "
            f"mu_L N_L / (mu_R N_R) of the two tracks: cg_y = {cy.estimate[0]:.4g} m gives {rho_c:.3g}, "
            f"as mu_ratio = {equivalent(robot, 'cg_y', float(cy.estimate[0])):.4g} would; "
            f"mu_ratio = {fa.estimate[0]:.4g} gives {rho_f:.3g}, as cg_y = "
            f"{equivalent(robot, 'mu_ratio', float(fa.estimate[0])):.4g} m would. A drive log cannot separate "
            f"them; weighing the left and right tracks (or wheels) can: a lateral centre of mass moves the load "
            f"(left share {0.5 + float(cy.estimate[0]) / robot.track_gauge:.3f} here), a friction asymmetry does not")


def force_friction_scale(robot, force: float) -> float:
    """The friction scale whose cap on one side's traction, s mu m g / 2 (the load shared equally),
    equals a drive force limit ``force`` [N per side]; :func:`friction_force` is its inverse."""
    return 2.0 * force / (robot.mu * robot.mass * G)


def friction_force(robot, scale: float) -> float:
    """The drive force limit [N per side] that caps one side's traction as ``scale`` x the friction does."""
    return scale * robot.mu * robot.mass * G / 2.0


def equivalence_note(robot, a, b) -> str | None:
    """Why two findings whose held-out gains are equal within noise are two readings of one physics,
    with each estimate in the other's terms and what would separate them, or None (module docstring)."""
    if {a.effect.name, b.effect.name} != set(FORCE_PAIR):
        return None
    fl, fs = (a, b) if a.effect.name == "drive_force_limit" else (b, a)
    force, scale = float(fl.estimate[0]), float(fs.estimate[0])
    return (f"drive_force_limit and friction_scale both cap the traction of each side and cannot be told apart on "
            f"this log: drive_force_limit = {force:.4g} N caps a side as friction_scale = "
            f"{force_friction_scale(robot, force):.3g} would; friction_scale = {scale:.3g} caps it as "
            f"drive_force_limit = {friction_force(robot, scale):.4g} N would. Straight accelerations above "
            f"{2 * force / robot.mass:.3g} m/s^2 (2 F / m) would separate them (they bind the force limit, not "
            f"the friction), and so would measured track speeds (a force-limited track falls behind its command, "
            f"a slipping one keeps it)")


__all__ = ["FORCE_PAIR", "TRACTION_PAIR", "equivalence_note", "equivalent", "force_friction_scale", "friction_force",
           "physical_tie", "traction_ratio"]
