#!/usr/bin/env python3
"""Scenario E's grid (0.25 / 0.5 mm x 125 / 250 rpm, ADAMS friction) in three models: the converged
full model, the reduced model with one-way coupling and with two-way coupling. Prints the table of
docs/validation.md: over the second revolution (the first is the start-up from centred balls),
the rod's mean axial spin, the guide's mean and RMS force across the slide, the housing's logged
RMS acceleration, and each reduced figure's difference from the full model's (for a mean force,
as a share of that force's RMS: the guide's means are small against its swings).

    python3 examples/e_coupling.py [path/to/lash] [work-dir]
"""
import csv, json, math, pathlib, subprocess, sys

lash = sys.argv[1] if len(sys.argv) > 1 else "target/release/lash"
work = pathlib.Path(sys.argv[2] if len(sys.argv) > 2 else "e-coupling")
MODELS = {"full": [], "one-way": ["--model", "reduced", "--coupling", "one-way"],
          "two-way": ["--model", "reduced", "--coupling", "two-way"]}


def columns(path, settle):
    """The file's columns (names without units) over t >= settle."""
    with open(path) as f:
        reader = csv.reader(f)
        header = [h.split(" [")[0] for h in next(reader)]
        rows = [[float(x) for x in r] for r in reader if float(r[0]) >= settle]
    return {h: [r[i] for r in rows] for i, h in enumerate(header)}


def mean(v):
    return sum(v) / len(v)


def rms(v):
    m = mean(v)
    return math.sqrt(sum((x - m) ** 2 for x in v) / len(v))


def figures(out, settle):
    ts = columns(out / "timeseries.csv", settle)
    logged = columns(out / "measurement_housing.csv", settle)
    summary = json.loads((out / "summary.json").read_text())
    return {
        "impacts, crank–rod / rod–slider (2 turns)": "{} / {}".format(*(c["impacts"] for c in summary["clearances"])),
        "rod.wx mean [rad/s]": mean(ts["rod.wx"]),
        "guide fy mean [N]": mean(ts["slider_guide.fy"]),
        "guide fz mean [N]": mean(ts["slider_guide.fz"]),
        "guide fy RMS [N]": rms(ts["slider_guide.fy"]),
        "guide fz RMS [N]": rms(ts["slider_guide.fz"]),
        "housing ay RMS [m/s²]": rms(logged["housing.ay"]),
        "housing az RMS [m/s²]": rms(logged["housing.az"]),
    }


print("| scenario | quantity | full | one-way | two-way |")
print("|---|---|---|---|---|")
for c in ["0.25", "0.5"]:
    for rpm in ["125", "250"]:
        name = f"E-{c}mm-{rpm}rpm"
        settle = 60.0 / float(rpm)
        got = {}
        for model, flags in MODELS.items():
            out = work / name / model
            subprocess.run([lash, "run", name, "--out", str(out), "--quiet"] + flags, check=True)
            got[model] = figures(out, settle)
        for q, full in got["full"].items():
            cells = []
            for model in ["one-way", "two-way"]:
                v = got[model][q]
                if isinstance(v, str):
                    cells.append(v)
                    continue
                if "wx" in q:
                    diff = ""
                elif "mean" in q:
                    scale = got["full"][q.replace("mean", "RMS")]
                    diff = f" ({100 * (v - full) / scale:+.1f} % of RMS)"
                else:
                    diff = f" ({100 * (v - full) / abs(full):+.1f} %)"
                cells.append(f"{v:.3g}{diff}")
            shown = full if isinstance(full, str) else f"{full:.3g}"
            print(f"| {name} | {q} | {shown} | {cells[0]} | {cells[1]} |", flush=True)
