"""Effects a drive log cannot separate by physics: ties reported with both estimates.

Under Coulomb friction a lateral centre of mass (``cg_y``) and a friction asymmetry
(``mu_ratio``) both set the traction ratio mu_L N_L / (mu_R N_R) of the two sides
(:data:`TRACTION_PAIR`): a diagnosis that finds both names one, lists the other tied with it and
gives each estimate in the other's terms (:func:`physical_tie`), with what would separate them.

Derivation: docs/theory/diagnosis.md, "Selection rules".
"""

from __future__ import annotations

TRACTION_PAIR = ("cg_y", "mu_ratio")


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


__all__ = ["TRACTION_PAIR", "equivalent", "physical_tie", "traction_ratio"]
