#!/usr/bin/env python3
"""Scenario E over its 2 x 2 grid (0.25 / 0.5 mm x 125 / 250 rpm), with clearance and ideal:
runs `lash run` for each and prints the table of docs/validation.md (second revolution only: the
first is the start-up, whose peaks are artefacts of the centred balls).

    python3 examples/e_grid.py [path/to/lash] [work-dir]
"""
import csv, json, math, subprocess, sys, pathlib

lash = sys.argv[1] if len(sys.argv) > 1 else "target/release/lash"
work = pathlib.Path(sys.argv[2] if len(sys.argv) > 2 else "e-grid")
rows = []
for c in ["0.25", "0.5"]:
    for rpm in ["125", "250"]:
        for ideal in [False, True]:
            name = f"E-{c}mm-{rpm}rpm"
            out = work / (name + ("-ideal" if ideal else ""))
            subprocess.run([lash, "run", name, "--out", str(out), "--quiet"] + (["--ideal"] if ideal else []), check=True)
            summary = json.loads((out / "summary.json").read_text())
            settle = 60.0 / float(rpm)
            with open(out / "timeseries.csv") as f:
                reader = csv.reader(f)
                header = [h.split(" [")[0] for h in next(reader)]
                ix = [header.index(f"slider_guide.f{a}") for a in "xyz"]
                peak = 0.0
                for r in reader:
                    if float(r[0]) >= settle:
                        peak = max(peak, math.sqrt(sum(float(r[i]) ** 2 for i in ix)))
            axes = {a["channel"].split(".")[1]: a for a in summary["measurements"][0]["axes"]}
            impacts = sum(cl["impacts"] for cl in summary["clearances"])
            rows.append((c, rpm, "ideal" if ideal else "clearance", peak, axes, impacts, summary["wall_time_s"]))

print("| c [mm] | rpm | joints | peak bearing force [N] | a_y peak f [Hz] / amplitude / RMS [m/s²] | a_z peak f [Hz] / amplitude / RMS [m/s²] | impacts (2 turns) |")
print("|---|---|---|---|---|---|---|")
for c, rpm, kind, peak, axes, impacts, wall in rows:
    cell = lambda a: f"{axes[a]['logged']['peak_frequency']:.0f} / {axes[a]['logged']['peak_amplitude']:.3f} / {axes[a]['logged']['rms']:.3f}"
    print(f"| {c} | {rpm} | {kind} | {peak:.1f} | {cell('ay')} | {cell('az')} | {impacts if kind == 'clearance' else '–'} |")
