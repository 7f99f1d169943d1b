#!/usr/bin/env python3
"""The reduced model's stated bounds on every built-in with a clearance interface, in three
settings: the defaults (h_m = 1e-3 s, the micro step lash chooses, the coupling lash chooses:
one-way unless the error estimate finds one-way coupling's own error past 10 %), one-way coupling
at the default steps, converged steps in one-way coupling (h_m = 1e-4 s, h_r = 1e-6 s: what is
left is the interface model's own error, not its steps') and two-way coupling at the default
steps. Runs `lash compare` for each (skipping those
already in the work folder) and prints the table of docs/validation.md: per setting, how many of
the checks hold and which do not (the checks and the window are `bounds` in comparison.json),
then per setting the scenarios that meet every bound and the checks missed.

    python3 examples/bounds_study.py [path/to/lash] [work-dir] [horizon-of-the-planar-runs] [realisations]

The planar scenarios run over 0.2 s (16 revolutions at 5000 rpm, 10 at 3000 rpm) unless told
otherwise; the spatial ones over their own horizon (two revolutions).

With `realisations` (any fourth argument), the defaults' reduced run is also held against three
more realisations of the converged full model — the scenario at atol one rounding step above its
1e-12, at rtol 1e-10 and at 1e-11 (atol 1e-3 rtol): each converged, each a different path of a
pin that rattles chaotically — and every check is counted as met against all four, some, or
none (the same reduced run each time: its coupling and micro step given as the defaults chose
them, its rows checked equal).
"""
import json, math, pathlib, re, subprocess, sys

lash = sys.argv[1] if len(sys.argv) > 1 else "target/release/lash"
work = pathlib.Path(sys.argv[2] if len(sys.argv) > 2 else "bounds-study")
horizon = sys.argv[3] if len(sys.argv) > 3 else "0.2"
realisations = len(sys.argv) > 4
PLANAR = ["A", "A-200um", "A-motor", "B", "B-0.25mm", "B-0.1mm", "B-0.02mm", "B-frictionless", "C",
          "F", "F-0.5mm", "F-0.25mm", "F-0.1mm", "F-flexible-imperfect"]
SPATIAL = ["E-0.25mm-125rpm", "E-0.25mm-250rpm", "E-0.5mm-125rpm", "E-0.5mm-250rpm",
           "E-0.25mm-125rpm-frictionless", "E-0.25mm-250rpm-frictionless",
           "E-0.5mm-125rpm-frictionless", "E-0.5mm-250rpm-frictionless"]
SETTINGS = {"defaults": [], "one-way": ["--coupling", "one-way"],
            "converged steps": ["--coupling", "one-way", "--macro-step", "1e-4", "--micro-step", "1e-6"],
            "two-way": ["--coupling", "two-way"]}


def compared(name, setting):
    out = work / setting.replace(" ", "-") / name
    if not (out / "comparison.json").exists():
        args = [lash, "compare", name, "--out", str(out), "--quiet"] + SETTINGS[setting]
        if name in PLANAR:
            args += ["--horizon", horizon]
        subprocess.run(args, check=True)
    comparison = json.loads((out / "comparison.json").read_text())
    coupling = comparison["reduced_options"]["coupling"]
    return comparison["bounds"], coupling


def tally(bounds):
    """(checks, missed)."""
    checks = bounds.get("checks") or []
    return len(checks), sum(1 for c in checks if not c["met"])


def misses(bounds):
    """'k of n' and the checks not met, briefly."""
    checks = bounds.get("checks")
    if checks is None:
        return "not checked: " + bounds.get("error", "")
    said = []
    for c in (c for c in checks if not c["met"]):
        q, e = c["quantity"], c["error"]
        if "impacts" in q:
            said.append(f"{q.split()[0]} impacts {c['full']:.1f} → {c['reduced']:.1f}")
        elif "power" in q:
            said.append(f"{q.replace(' power', '')} {e:.2f}×")
        else:
            said.append(f"{q} {100 * e:+.1f} %")
    met = len(checks) - len(said)
    return f"{met}/{len(checks)}" + ("" if not said else ": " + "; ".join(said))


print("| scenario | " + " | ".join(SETTINGS) + " |")
print("|---" * (len(SETTINGS) + 1) + "|")
totals = {s: [0, 0, 0] for s in SETTINGS}  # scenarios meeting every bound, checks, missed
for name in PLANAR + SPATIAL:
    cells = []
    for s in SETTINGS:
        bounds, coupling = compared(name, s)
        n, missed = tally(bounds)
        totals[s][0] += missed == 0 and n > 0
        totals[s][1] += n
        totals[s][2] += missed
        two_way = " (two-way)" if s == "defaults" and coupling == "two_way" else ""
        cells.append(misses(bounds) + two_way)
    print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
print()
for s, (every, n, missed) in totals.items():
    print(f"{s}: every bound met on {every} of {len(PLANAR + SPATIAL)}; {missed} of {n} checks missed")


# The converged full model's other realisations: (rtol, atol) beside the scenario's (1e-9, 1e-12).
REALISATIONS = [(1e-9, math.nextafter(1e-12, 1.0)), (1e-10, 1e-13), (1e-11, 1e-14)]


def realised(name, rtol, atol):
    """The defaults' reduced run against the full model at (rtol, atol): comparison.json's checks."""
    defaults = work / "defaults" / name
    options = json.loads((defaults / "comparison.json").read_text())["reduced_options"]
    out = work / "realisations" / f"{name}-rtol{rtol!r}-atol{atol!r}"
    if not (out / "comparison.json").exists():
        shown = subprocess.run([lash, "show", name], check=True, capture_output=True, text=True).stdout
        text = re.sub(r"\nrtol = \S+", f"\nrtol = {rtol!r}", shown)
        text = re.sub(r"\natol = \S+", f"\natol = {atol!r}", text)
        out.mkdir(parents=True, exist_ok=True)
        (out / "scenario-file.toml").write_text(text)
        coupling = options["coupling"].replace("_", "-")
        args = [lash, "compare", str(out / "scenario-file.toml"), "--out", str(out), "--quiet",
                "--coupling", coupling, "--micro-step", repr(options["micro_step"])]
        if name in PLANAR:
            args += ["--horizon", horizon]
        subprocess.run(args, check=True, capture_output=True)
    same = (out / "reduced" / "timeseries.csv").read_bytes() == (defaults / "reduced" / "timeseries.csv").read_bytes()
    if not same:
        print(f"note: {name}'s reduced run against rtol {rtol!r}, atol {atol!r} is not the defaults' run")
    return json.loads((out / "comparison.json").read_text())["bounds"].get("checks") or []


if realisations:
    print()
    print("| scenario | met against all four | some | none |")
    print("|---|---|---|---|")
    counts = [0, 0, 0]
    for name in PLANAR + SPATIAL:
        runs = [compared(name, "defaults")[0].get("checks") or []]
        runs += [realised(name, rtol, atol) for rtol, atol in REALISATIONS]
        verdicts = {}
        for checks in runs:
            for c in checks:
                verdicts.setdefault(c["quantity"], []).append(c)
        every, some, never = [], [], []
        for q, cs in verdicts.items():
            met = sum(c["met"] for c in cs)
            (every if met == len(runs) else some if met > 0 else never).append(misses({"checks": [cs[0]]}).split(": ", 1)[-1])
        counts = [counts[0] + len(every), counts[1] + len(some), counts[2] + len(never)]
        print(f"| {name} | {len(every)} | {len(some)} | {len(never)}" + (": " + "; ".join(never) if never else "") + " |",
              flush=True)
    print()
    print(f"checks met against all four realisations: {counts[0]}, against some: {counts[1]}, against none: {counts[2]}")
