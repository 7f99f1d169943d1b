#!/usr/bin/env python3
"""The reduced model's stated bounds on the planar built-ins at two macro steps: 1 ms (the
default before lash chose the macro step from the mechanism's speed) and the macro step lash
picks now (the largest step in which the fastest body turns by at most 16°: 0.5 ms at 5000 and
3000 rpm). Everything else at the defaults (micro step and coupling as lash chooses them). Runs
`lash compare` for each (skipping those already in the work folder) over `horizon` seconds and
prints one row per scenario (checks met, and the ones missed with their figures), then the totals:
the table of docs/validation.md §6, "The macro step at the defaults".

    python3 examples/macro_step_study.py [path/to/lash] [work-dir] [horizon]
"""
import json, pathlib, subprocess, sys

lash = sys.argv[1] if len(sys.argv) > 1 else "target/release/lash"
work = pathlib.Path(sys.argv[2] if len(sys.argv) > 2 else "macro-step-study")
horizon = sys.argv[3] if len(sys.argv) > 3 else "2"
PLANAR = ["A", "A-200um", "A-motor", "B", "B-0.25mm", "B-0.1mm", "B-0.02mm", "B-frictionless", "C",
          "F", "F-0.5mm", "F-0.25mm", "F-0.1mm", "F-flexible-imperfect"]
SETTINGS = {"1 ms": ["--macro-step", "1e-3"], "chosen": []}


def compared(name, setting):
    out = work / setting.replace(" ", "-") / name
    if not (out / "comparison.json").exists():
        args = [lash, "compare", name, "--out", str(out), "--quiet", "--horizon", horizon] + SETTINGS[setting]
        subprocess.run(args, check=True)
    return json.loads((out / "comparison.json").read_text())


def missed(check):
    e = check["error"]
    if check["kind"] == "relative":
        figure = f"{100 * e:+.1f} %"
    elif check["kind"] == "ratio":
        figure = f"{e:.2f}×"
    else:
        figure = f"{check['full']:.1f} → {check['reduced']:.1f}"
    return f"{check['quantity']} {figure}"


totals = {s: [0, 0, 0] for s in SETTINGS}
print("| scenario | h_m chosen | " + " | ".join(SETTINGS) + " |")
print("|---" * (len(SETTINGS) + 2) + "|")
for name in PLANAR:
    cells, chosen = [], None
    for setting in SETTINGS:
        c = compared(name, setting)
        if setting == "chosen":
            chosen = c["reduced_options"]["macro_step"]
        checks = c["bounds"].get("checks") or []
        misses = [k for k in checks if not k["met"]]
        totals[setting][0] += len(checks)
        totals[setting][1] += len(misses)
        totals[setting][2] += not misses
        cell = f"{len(checks) - len(misses)}/{len(checks)}"
        if misses:
            cell += ": " + "; ".join(missed(k) for k in misses)
        cells.append(cell)
    print(f"| {name} | {chosen:g} s | " + " | ".join(cells) + " |")
for setting, (n, m, every) in totals.items():
    print(f"{setting}: {n - m} of {n} checks met, {m} missed; every bound on {every} of {len(PLANAR)} scenarios")
