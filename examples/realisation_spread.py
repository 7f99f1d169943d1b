#!/usr/bin/env python3
"""How far a rattling scenario's statistics move between realisations of the converged full model,
against the reduced model in both couplings. The full model runs at its tolerance (rtol 1e-9,
atol 1e-12), with atol one rounding step above (1.0000000000000002e-12), and at rtol 1e-10 and
1e-11 (atol 1e-3 rtol): each is converged in the sense of docs/validation.md §3 (the
first impacts agree to picoseconds), yet a pin that rattles chaotically takes a different path
after some impacts, and over a finite run its RMS levels are one draw of the run's statistics.
Prints, per model, the RMS of the main channels past the first revolution (the comparison's
steady window), and each reduced figure's distance from the nearest and the farthest full-model
realisation.

    python3 examples/realisation_spread.py [path/to/lash] [work-dir] SCENARIO HORIZON

docs/validation.md §6 quotes B, B-frictionless, F and A-200um over 0.2 s and 2 s.
"""
import csv, math, pathlib, re, subprocess, sys

lash = sys.argv[1] if len(sys.argv) > 1 else "target/release/lash"
work = pathlib.Path(sys.argv[2] if len(sys.argv) > 2 else "realisation-spread")
name = sys.argv[3] if len(sys.argv) > 3 else "B"
horizon = sys.argv[4] if len(sys.argv) > 4 else "2"
TOLERANCES = [(1e-9, 1e-12), (1e-9, math.nextafter(1e-12, 1.0)), (1e-10, 1e-13), (1e-11, 1e-14)]


def main_channels(header):
    """The sensor's axial acceleration, the driver torque, each clearance joint's force."""
    names = [h.split(" [")[0] for h in header]
    return [n for n in names if n == "slider.ax" or n.endswith(".torque")
            or (n.endswith(".force") and not n.endswith("_force"))]


def rms(path, settle):
    """RMS of the main channels over t >= settle."""
    with open(path) as f:
        reader = csv.reader(f)
        header = next(reader)
        chans = main_channels(header)
        cols = [[h.split(" [")[0] for h in header].index(c) for c in chans]
        sums, n = [0.0] * len(cols), 0
        for r in reader:
            if float(r[0]) < settle:
                continue
            n += 1
            for j, k in enumerate(cols):
                sums[j] += float(r[k]) ** 2
    return dict(zip(chans, (math.sqrt(s / n) for s in sums)))


def run(label, args):
    out = work / f"{name}-{horizon}" / label
    if not (out / "summary.json").exists():
        subprocess.run([lash, "run", *args, "--horizon", horizon, "--out", str(out), "--quiet"],
                       check=True, capture_output=True)
    return out / "timeseries.csv"


work.mkdir(parents=True, exist_ok=True)
shown = subprocess.run([lash, "show", name], check=True, capture_output=True, text=True).stdout
settle = 0.012 if name.startswith(("A", "B", "C")) else 0.02  # the first revolution (5000 / 3000 rpm)
full = {}
for rtol, atol in TOLERANCES:
    text = re.sub(r"\nrtol = \S+", f"\nrtol = {rtol!r}", shown)
    text = re.sub(r"\natol = \S+", f"\natol = {atol!r}", text)
    path = work / f"{name}-rtol{rtol!r}-atol{atol!r}.toml"
    path.write_text(text)
    full[(rtol, atol)] = rms(run(f"full-rtol{rtol!r}-atol{atol!r}", [str(path)]), settle)
reduced = {c: rms(run(c, [name, "--model", "reduced", "--coupling", c, "--no-error-estimate"]), settle)
           for c in ["one-way", "two-way"]}
chans = list(full[TOLERANCES[0]])
print(f"{name} over {horizon} s, RMS past t = {settle} s: " + ", ".join(chans))
for (rtol, atol), r in full.items():
    print(f"  full, rtol {rtol!r:6} atol {atol!r:22}: " + ", ".join(f"{r[c]:.4g}" for c in chans))
for c in chans:
    values = [full[t][c] for t in TOLERANCES]
    lo, hi = min(values), max(values)
    print(f"  full-model spread of {c}: {100 * (hi - lo) / lo:.1f} %")
for coupling, r in reduced.items():
    parts = []
    for c in chans:
        d = [100 * (r[c] - full[t][c]) / full[t][c] for t in TOLERANCES]
        parts.append(f"{r[c]:.4g} ({min(d, key=abs):+.1f} … {max(d, key=abs):+.1f} %)")
    print(f"  reduced {coupling:7}: " + ", ".join(parts))
