"""Issue 14, session 9 (negative result, nothing in the library): slip compensation whose map is
the Coulomb reference's steady ICRs at the reference command (mjtrack.models.coulomb.steady_state,
3 fixed-point iterations of inverse_micr, |w| floored at 0.05 rad/s) instead of the nominal map
("phys"), and that map as the reference the online estimate is blended against ("phys+est").
Prototype: it swaps mjtrack.control.compensation.SlipCompensation for a subclass while it runs.
Run: python experiments/notes/issue14_physics_map.py (about 90 s). Results in issue14_known_icrs.md.
"""
import sys, math, time, numpy as np
import mjtrack.control.compensation as C
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import steady_state
from mjtrack.estimation.icr_ekf import InverseICR
from mjtrack.errors import MjtrackError

class CoulombMap:
    def __init__(self, robot, w_floor=0.05, iters=3):
        self.robot, self.w_floor, self.iters, self.cache = robot, w_floor, iters, {}
    def psi(self, v, w):
        v = max(abs(v), 0.05) * (1 if v >= 0 else -1)
        w = math.copysign(max(abs(w), self.w_floor), w if w != 0 else 1.0)
        key = (round(v, 3), round(w, 3))
        if key in self.cache: return self.cache[key]
        T = self.robot.track_gauge
        yl, yr, xc = T/2, -T/2, 0.0
        try:
            for _ in range(self.iters):
                vl, vr = C.inverse_micr(key[0], key[1], yl, yr)
                s = steady_state(self.robot, vl, vr)
                yl, yr, xc = s.icr
            p = InverseICR.from_icr(yl, yr, xc).params
        except MjtrackError:
            p = np.array([0.0, 0.0, 1.0/T])
        self.cache[key] = p
        return p

class PhysComp(C.SlipCompensation):
    cmap = None; use_estimate = False
    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self._ref = None
    def track_speeds(self, v, w, feedforward=None):
        v_d, w_d = feedforward if feedforward is not None else (v, w)
        ref = self.cmap.psi(v_d, w_d)
        if self.use_estimate and self.estimator is not None and self.admissible(self.estimator.psi):
            # weight of the estimate against the physics map
            lam = self.weight_phys(ref, v_d, w_d)
            psi_ff = ref + lam * (self.estimator.psi - ref)
        else:
            psi_ff = ref
        self._applied = psi_ff
        self._last_command = (float(v_d), float(w_d))
        return C.track_speeds_from_psi(v_d, w_d, psi_ff) + C.track_speeds_from_psi(v - v_d, w - w_d, self.psi_nominal)
    def weight_phys(self, ref, v_d, w_d):
        scale = self.trust_scale * math.sqrt(max(1.0, self.nis_mean))
        return self.explained * C.trust_weight(self.estimator.psi, self.estimator.psi_cov, ref, v_d, w_d, poles=self.poles, scale=scale)

def run(robot, sc, mode, v, seed, variant):
    laps = 1.0 if sc == "figure_eight" else None
    if variant == "online" or mode == "none":
        return C.run_tracking(robot, scenario=sc, compensation=mode, speed=v, seed=seed, laps=laps).metrics
    orig = C.SlipCompensation
    PhysComp.cmap = CoulombMap(robot); PhysComp.use_estimate = (variant == "phys+est")
    C.SlipCompensation = PhysComp
    try:
        return C.run_tracking(robot, scenario=sc, compensation=mode, speed=v, seed=seed, laps=laps).metrics
    finally:
        C.SlipCompensation = orig

if __name__ == "__main__":
    cases = [("lane_change",0.4,-0.05,0.5,1),("lane_change",0.4,-0.05,0.5,0),("lane_change",0.8,-0.05,0.5,1),("figure_eight",0.4,-0.05,0.5,0),("figure_eight",0.4,-0.05,0.5,1),("circle",0.4,-0.05,0.5,0),("circle",0.8,0.05,1.0,0),("figure_eight",0.4,0.05,1.0,0),("lane_change",0.8,-0.05,1.0,0)]
    for sc, mu, cg, v, seed in cases:
        robot = Robot(mu=mu, cg_x=cg)
        n = run(robot, sc, "none", v, seed, None)
        out = []
        t0=time.time()
        for mode in ("icr", "vir"):
            for var in ("online", "phys", "phys+est"):
                m = run(robot, sc, mode, v, seed, var)
                out.append(f"{mode} {var} {m['rms_cross_track_m']/n['rms_cross_track_m']:.3f},{m['max_cross_track_m']/n['max_cross_track_m']:.3f}")
        print(sc, mu, cg, v, seed, f"none {1e3*n['rms_cross_track_m']:.1f}mm", " ".join(out), f"{time.time()-t0:.0f}s", flush=True)
