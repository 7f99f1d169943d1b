"""Figures of docs/validation.md from lash outputs.

Run from the repository root after producing the outputs (commands in docs/validation.md):
    python docs/figures/make_figures.py
Needs numpy and matplotlib (not needed by lash itself or its tests).
"""
import csv
import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def load(path):
    with open(path) as f:
        r = csv.reader(f)
        header = [h.split(" [")[0] for h in next(r)]
        data = np.array([[float(x) for x in row] for row in r])
    return {h: data[:, i] for i, h in enumerate(header)}


def overlay(full, ideal, title, out, channel="slider.ax"):
    f, i = load(full), load(ideal)
    fig, ax = plt.subplots(figsize=(9, 3.6))
    ax.plot(f["time"] * 1e3, f[channel] / 1e3, lw=0.7, label="full model (clearance)")
    ax.plot(i["time"] * 1e3, i[channel] / 1e3, lw=1.2, label="ideal mechanism")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("slider acceleration [km/s²]")
    ax.set_title(title)
    ax.legend(loc="upper right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


overlay("out/B/timeseries.csv", "out/B-ideal/timeseries.csv", "Scenario B, c = 0.5 mm, 5000 rpm", "docs/figures/B_slider_acceleration.png")
overlay("out/A/timeseries.csv", "out/A-ideal/timeseries.csv", "Scenario A, c = 100 µm at the crank pivot", "docs/figures/A_slider_acceleration.png")
overlay("out/B-0.02mm/timeseries.csv", "out/B-0.02mm-ideal/timeseries.csv", "Scenario B, c = 0.02 mm", "docs/figures/B002_slider_acceleration.png")

fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
for name, label, style in [
    ("conv_rtol11", "DOPRI5 rtol 1e-11", "-"),
    ("conv_rtol9", "DOPRI5 rtol 1e-9 (default)", "--"),
    ("conv_rk4", "RK4 h = 1e-7 s", ":"),
    ("conv_rk4_1e-5", "RK4 h = 1e-5 s", "o-"),
]:
    d = load(f"out/{name}/timeseries.csv")
    for ax, (lo, hi) in zip(axes, [(0.2, 0.3), (0.6, 0.88)]):
        m = (d["time"] >= lo * 1e-3) & (d["time"] <= hi * 1e-3)
        ax.plot(d["time"][m] * 1e3, d["rod_slider.normal_force"][m] / 1e3, style, lw=1, ms=3, label=label)
for ax in axes:
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("normal force [kN]")
    ax.grid(alpha=0.3)
axes[0].set_title("B: first impact")
axes[1].set_title("B: second and third impacts")
axes[1].legend(fontsize=8)
fig.tight_layout()
fig.savefig("docs/figures/B_convergence.png", dpi=110)


# Scenario E (spatial slider-crank, two spherical clearance joints): the vibration study's layout.
def spectrum(t, x):
    x = x - x.mean()
    w = np.hanning(len(x))
    a = 2.0 * np.abs(np.fft.rfft(x * w)) / w.sum()
    return np.fft.rfftfreq(len(x), t[1] - t[0]), a


e, ei = load("out/E-0.5mm-250rpm/timeseries.csv"), load("out/E-250rpm-ideal/timeseries.csv")
fig, axes = plt.subplots(1, 2, figsize=(11, 3.6))
m = e["time"] >= 0.24
for ax, axis in zip(axes, ["y", "z"]):
    ax.plot(e["time"][m] * 1e3, e[f"slider_guide.f{axis}"][m], lw=0.6, label="with clearance (c = 0.5 mm)")
    ax.plot(ei["time"][m] * 1e3, ei[f"slider_guide.f{axis}"][m], lw=1.4, label="without clearance (ideal joints)")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel(f"slider bearing force F{axis} [N]")
    ax.grid(alpha=0.3)
axes[0].set_title("E, 250 rpm: slider bearing force, vertical (Y)")
axes[1].set_title("lateral (Z)")
axes[1].legend(fontsize=8)
fig.tight_layout()
fig.savefig("docs/figures/E_bearing_force.png", dpi=110)

h, hi = load("out/E-0.5mm-250rpm/measurement_housing.csv"), load("out/E-250rpm-ideal/measurement_housing.csv")
fig, axes = plt.subplots(1, 2, figsize=(11, 3.6))
for ax, axis in zip(axes, ["y", "z"]):
    ax.plot(h["time"] * 1e3, h[f"housing.a{axis}"], ".-", lw=0.8, ms=3, label="with clearance (c = 0.5 mm)")
    ax.plot(hi["time"] * 1e3, hi[f"housing.a{axis}"], lw=1.4, label="without clearance (ideal joints)")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel(f"housing acceleration a{axis} [m/s²]")
    ax.grid(alpha=0.3)
axes[0].set_title("E, 250 rpm: bearing housing, logged at 500 Hz, Y")
axes[1].set_title("Z")
axes[1].legend(fontsize=8)
fig.tight_layout()
fig.savefig("docs/figures/E_housing_acceleration.png", dpi=110)

fig, axes = plt.subplots(2, 2, figsize=(11, 6.4), sharex=True, sharey=True)
for row, c in enumerate(["0.25", "0.5"]):
    for col, rpm in enumerate(["125", "250"]):
        ax = axes[row][col]
        h, hi = load(f"out/E-{c}mm-{rpm}rpm/measurement_housing.csv"), load(f"out/E-{rpm}rpm-ideal/measurement_housing.csv")
        for axis, style in [("z", "-"), ("y", "--")]:
            f, a = spectrum(h["time"], h[f"housing.a{axis}"])
            ax.semilogy(f[1:], a[1:], style, lw=1, label=f"{axis.upper()}, with clearance")
        f, a = spectrum(hi["time"], hi["housing.az"])
        ax.semilogy(f[1:], np.maximum(a[1:], 1e-6), ":", color="k", lw=1, label="Z, without clearance")
        ax.set_title(f"c = {c} mm, {rpm} rpm", fontsize=9)
        ax.grid(alpha=0.3)
        if row == 1:
            ax.set_xlabel("frequency [Hz]")
        if col == 0:
            ax.set_ylabel("amplitude [m/s²]")
axes[0][1].legend(fontsize=8)
fig.suptitle("E: housing acceleration spectra (500 Hz logger, Hann window over the second revolution)")
fig.tight_layout()
fig.savefig("docs/figures/E_spectra.png", dpi=110)

# Scenario F (flexible-bush study): crank torque and rod–slider force over the second and third
# revolutions for the four joint configurations.
configs = [
    ("F-rigid-perfect", "rigid, perfect", "-"),
    ("F-flexible-perfect", "flexible (bronze bush), perfect", "--"),
    ("F", "rigid, 1 mm clearance", "-"),
    ("F-flexible-imperfect", "flexible (bronze bush), 1 mm clearance", "-"),
]
fig, axes = plt.subplots(2, 1, figsize=(11, 6.4), sharex=True)
for name, label, style in configs:
    d = load(f"out/{name}/timeseries.csv")
    m = d["time"] >= 0.02
    force = d["rod_slider.force"] if "rod_slider.force" in d else np.hypot(d["rod_slider.fx"], d["rod_slider.fy"])
    axes[0].plot(d["time"][m] * 1e3, d["motor.torque"][m] / 1e3, style, lw=0.7, label=label)
    axes[1].plot(d["time"][m] * 1e3, force[m] / 1e3, style, lw=0.7, label=label)
axes[0].set_ylabel("crank torque [kN m]")
axes[1].set_ylabel("rod–slider joint force [kN]")
axes[1].set_xlabel("time [ms]")
axes[0].set_title("F, 3000 rpm: the four joint configurations (revolutions 2 and 3)")
axes[0].legend(fontsize=8, loc="upper right")
for ax in axes:
    ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig("docs/figures/F_configurations.png", dpi=110)
# The bush-modulus sweep (examples/sweep-bush.toml, written to out/sweep-bush): crank torque peaks
# and RMS over revolutions 2 and 3 against the bush's Young's modulus, and the torque of a few
# moduli over time. Read with pandas/pyarrow (`lash.Dataset` reads it as arrays as well).
import pandas as pd

data = pd.read_parquet("out/sweep-bush/data.parquet")
params = pd.read_parquet("out/sweep-bush/params.parquet")
rigid = load("out/F/timeseries.csv")
modulus = "clearances[0].bush.material.young_modulus"
rows = []
for _, p in params.iterrows():
    if p["status"] != "ok":
        rows.append((p[modulus] / 1e9, np.nan, np.nan))
        continue
    d = data[(data["run_id"] == p["run_id"]) & (data["t"] >= 0.02)]
    torque = d["motor.torque"].to_numpy()
    rows.append((p[modulus] / 1e9, np.abs(torque).max(), np.sqrt((torque**2).mean())))
rows = np.array(sorted(rows))
m = rigid["time"] >= 0.02
# The rigid bearing sampled like the sweep (every 10th sample of its 100 kHz series: 10 kHz).
rt = rigid["motor.torque"][m][::10]
fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
ax = axes[0]
ax.plot(rows[:, 0], rows[:, 1] / 1e3, "o-", label="peak, bush in series")
ax.plot(rows[:, 0], rows[:, 2] / 1e3, "s-", label="RMS, bush in series")
ax.axhline(np.abs(rt).max() / 1e3, color="C0", ls=":", label="peak, rigid bearing")
ax.axhline(np.sqrt((rt**2).mean()) / 1e3, color="C1", ls=":", label="RMS, rigid bearing")
ax.axhline(0.5 * np.abs(rt).max() / 1e3, color="k", ls="--", lw=0.8, label="half the rigid peak")
failed = rows[np.isnan(rows[:, 1]), 0]
for x in failed:
    ax.axvline(x, color="r", lw=0.8, alpha=0.6)
ax.set_xscale("log")
ax.set_xlabel("bush Young's modulus [GPa] (bronze: 110)")
ax.set_ylabel("crank torque [kN m]")
ax.set_title("F, 1 mm: torque over revolutions 2–3 (10 kHz)" + (" — red: run failed" if len(failed) else ""), fontsize=9)
ax.legend(fontsize=7)
ax.grid(alpha=0.3, which="both")
ax = axes[1]
ax.plot(rigid["time"][m][::10] * 1e3, rt / 1e3, lw=0.7, color="k", label="rigid bearing")
for target in [110e9, 30e9, rows[~np.isnan(rows[:, 1]), 0].min() * 1e9]:
    p = params.loc[(params[modulus] - target).abs().idxmin()]
    d = data[(data["run_id"] == p["run_id"]) & (data["t"] >= 0.02)]
    ax.plot(d["t"] * 1e3, d["motor.torque"] / 1e3, lw=0.7, label=f"bush {p[modulus] / 1e9:.0f} GPa")
ax.set_xlabel("time [ms]")
ax.set_ylabel("crank torque [kN m]")
ax.legend(fontsize=7)
ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig("docs/figures/F_bush_modulus.png", dpi=110)
print("figures written to docs/figures/")
