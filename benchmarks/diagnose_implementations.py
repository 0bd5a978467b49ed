"""Diagnosis of effect families in physically different implementations, from two generators that
share no code with the diagnosis (:mod:`mjtrack.testing.implementations`: the cases, the family of
every effect name and the scoring; the generators :mod:`mjtrack.testing.diagnose_physics` "A" and
:mod:`mjtrack.testing.bristle_physics` "B").

For every case x generator: a 60 s pose-only log with 5 mm pose noise, ``diagnose`` at default
options with each requested baseline ("auto": the default, the MuJoCo robot when the description
can build it; "surrogate"), and per log the true families, what was named (chosen and tied), the
verdict (right / tie / wrong / spurious / missed), the estimates with their 95 % intervals, and the
time. Prints one line per log and the counts per baseline, the load before and after.

    python benchmarks/diagnose_implementations.py                        # both baselines, every case
    python benchmarks/diagnose_implementations.py --baselines surrogate --cases lag_speed,dead_time
    python benchmarks/diagnose_implementations.py --compound    # lag + dead time, generator B, auto only

Each row also says how each true effect was named (``truth_named``: chosen, tied, a finding not
chosen, missing): for the lag + dead time compound, named as both or as a tie.

Writes benchmarks/results/diagnose_implementations.json (rows of another selection are kept; a
row of the same case, generator and baseline is replaced).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from mjtrack.diagnose import diagnose
from mjtrack.testing.implementations import BY_NAME, CASES, GENERATORS, make_case_log, score, truth_named

RESULT = Path(__file__).resolve().parent / "results" / "diagnose_implementations.json"
VERDICTS = ("right", "tie", "wrong", "spurious", "missed")
COMMAND = "python benchmarks/diagnose_implementations.py"


def finding_json(f) -> dict:
    return {"effect": f.effect.name, "estimate": [float(v) for v in f.estimate],
            "interval": [[float(a), float(b)] for a, b in f.interval], "tied_with": list(f.tied_with),
            "on_top_of": list(f.on_top_of), "relative_gain": float(f.relative)}


def run(case_name: str, generator: str, baseline: str, *, seed: int, log=None) -> dict:
    case = BY_NAME[case_name]
    lg, robot = log if log is not None else make_case_log(case, generator, seed=seed)
    t0 = time.perf_counter()
    d = diagnose(lg, robot, baseline=baseline)
    seconds = time.perf_counter() - t0
    s = score(d, case)
    return {"case": case.name, "generator": generator, "baseline": baseline, "chosen_baseline": d.baseline.name,
            "seed": seed, "families": list(case.families), "params": case.params[generator], "truth": case.truth,
            **s, "truth_named": truth_named(d, case), "cause": d.cause, "findings": [finding_json(f) for f in d.findings],
            "chosen": [f.effect.name for f in d.chosen], "seconds": round(seconds, 1)}


def line(r: dict) -> str:
    est = "; ".join(f"{f['effect']}=" + ",".join(f"{v:.3g} [{a:.3g}, {b:.3g}]" for v, (a, b)
                                                  in zip(f["estimate"], f["interval"]))
                    + (f" ~{'/'.join(f['tied_with'])}" if f["tied_with"] else "") for f in r["findings"]) or "none"
    flags = ",".join(x for x in (("extra:" + "+".join(r["extra"])) if r["extra"] else "",
                                 ("ties:" + "+".join(r["ties"])) if r["ties"] else "",
                                 "confused" if r["confused"] else "") if x)
    return (f"{r['case']:<15}{r['generator']:<3}{r['baseline']:<10}{'/'.join(r['families']) or 'none':<34}"
            f"{r['verdict']:<9}{est}  {flags}  "
            + " ".join(f"{k}:{v}" for k, v in r.get("truth_named", {}).items()) + f"  {r['seconds']:.0f}s")


def counts(rows: list[dict]) -> dict:
    return {v: sum(r["verdict"] == v for r in rows) for v in VERDICTS}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baselines", default="auto,surrogate")
    ap.add_argument("--cases", default=",".join(c.name for c in CASES))
    ap.add_argument("--generators", default=",".join(GENERATORS))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", default=str(RESULT))
    ap.add_argument("--label", default="", help="a label stored with the rows (e.g. the code's state)")
    ap.add_argument("--compound", action="store_true",
                    help="only the lag + dead time compound on generator B with the default baseline (auto)")
    args = ap.parse_args(argv)
    if args.compound:
        args.cases, args.generators, args.baselines = "lag_delay", "B", "auto"
    load0 = os.getloadavg()
    rows = []
    for name in args.cases.split(","):
        for g in args.generators.split(","):
            log = make_case_log(BY_NAME[name], g, seed=args.seed)
            for b in args.baselines.split(","):
                r = run(name, g, b, seed=args.seed, log=log)
                r["label"] = args.label
                r["load_average"] = round(os.getloadavg()[0], 1)
                rows.append(r)
                print(line(r), flush=True)
                store(Path(args.out), [r])  # row by row: a long run interrupted keeps what it did
    print(f"load average before {load0[0]:.1f}, after {os.getloadavg()[0]:.1f}")
    for b in args.baselines.split(","):
        sel = [r for r in rows if r["baseline"] == b]
        print(f"{b}: " + ", ".join(f"{k} {v}" for k, v in counts(sel).items()) + f" of {len(sel)}")


def store(out: Path, rows: list[dict]) -> None:
    """Merge ``rows`` into the result file (a row of the same case, generator, baseline and seed
    is replaced) and rewrite its summary."""
    old = json.loads(out.read_text())["rows"] if out.exists() else []
    key = {(r["case"], r["generator"], r["baseline"], r["seed"]) for r in rows}
    merged = [r for r in old if (r["case"], r["generator"], r["baseline"], r["seed"]) not in key] + rows
    summary = {}
    for b in sorted({r["baseline"] for r in merged}):
        sel = [r for r in merged if r["baseline"] == b]
        summary[b] = {"all": {**counts(sel), "logs": len(sel)}}
        for g in GENERATORS:
            mine = [r for r in sel if r["generator"] == g]
            summary[b][g] = {**counts(mine), "logs": len(mine)}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"command": COMMAND, "rows": merged, "summary": summary}, indent=1) + "\n")


if __name__ == "__main__":
    main()
