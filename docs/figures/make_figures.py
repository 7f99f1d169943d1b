"""Figures of docs/validation.md from lash outputs.

Run from the repository root after producing the outputs (commands in docs/validation.md):
    python docs/figures/make_figures.py
(`python docs/figures/make_figures.py lubricated` draws the lubricated joint's figure alone.)
Needs numpy and matplotlib (not needed by lash itself or its tests).
"""
import csv
import sys
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


def lubricated(out="docs/figures/A_lubricated.png"):
    """Dry and lubricated crank pivot of scenario A side by side: journal orbit, slider
    acceleration, crank torque (full model; the lubricated reduced model dashed)."""
    dry, wet, wet_r = (load(f"out/{n}/timeseries.csv") for n in ["A", "A-lubricated-full", "A-lubricated-reduced"])
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    t = np.linspace(0, 2 * np.pi, 200)
    axes[0].plot(100 * np.cos(t), 100 * np.sin(t), "k", lw=0.6, label="clearance (100 µm)")
    for d, label, style in [(dry, "dry (full)", "-"), (wet, "lubricated (full)", "-"), (wet_r, "lubricated (reduced)", "--")]:
        axes[0].plot(d["crank_pivot.ex"] * 1e6, d["crank_pivot.ey"] * 1e6, style, lw=0.7, label=label)
        axes[1].plot(d["time"] * 1e3, d["slider.ax"] / 1e3, style, lw=0.7, label=label)
        axes[2].plot(d["time"] * 1e3, d["motor.torque"], style, lw=0.7, label=label)
    axes[0].set_aspect("equal")
    axes[0].set_xlabel("e_x [µm]")
    axes[0].set_ylabel("e_y [µm]")
    axes[0].set_title("journal orbit")
    axes[1].set_xlabel("time [ms]")
    axes[1].set_ylabel("slider acceleration [km/s²]")
    axes[2].set_xlabel("time [ms]")
    axes[2].set_ylabel("crank torque [N m]")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle("Scenario A: the crank pivot dry and lubricated (SAE 50, short bearing L/D = 0.25), 5000 rpm")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if sys.argv[1:] == ["lubricated"]:
    lubricated()
    sys.exit()

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
# The bush sweep (examples/sweep-bush.toml, written to out/sweep-bush): a grid of the bush's
# Young's modulus and shear viscosity. Crank torque peaks and the slider's acceleration above 1 kHz
# (the vibration) over revolutions 2 and 3 against the modulus, one line per viscosity, and the
# torque of a few bushes over time. Read with pandas/pyarrow (`lash.Dataset` reads it as arrays
# as well). The bush's relaxation time c/k of each run: its damping is linear in the viscosities
# and its stiffness in the modulus (`lash bush` for the study's bush: c = 0.42193 η_s + 0.13963 η_b
# N s/m per Pa s, k = 3.3317e10 N/m at 110 GPa).
import pandas as pd

data = pd.read_parquet("out/sweep-bush/data.parquet")
params = pd.read_parquet("out/sweep-bush/params.parquet")
rigid = load("out/F/timeseries.csv")
modulus = "clearances[0].bush.material.young_modulus"
viscosity = "clearances[0].bush.material.shear_viscosity"


def above(x, fs=1e5, cut=1000.0):
    """RMS of x above `cut` Hz (the vibration beyond the crank's first 20 harmonics)."""
    spectrum = np.fft.rfft(x - x.mean())
    spectrum[np.fft.rfftfreq(len(x), 1 / fs) < cut] = 0
    return np.sqrt(np.mean(np.fft.irfft(spectrum, len(x)) ** 2))


rows = []
for _, p in params.iterrows():
    c_over_k = (0.42193 * p[viscosity] + 0.13963 * 900.0) / (3.3317e10 * p[modulus] / 110e9)
    d = data[(data["run_id"] == p["run_id"]) & (data["t"] >= 0.02)]
    torque, force, ax = (d[c].to_numpy() for c in ["motor.torque", "rod_slider.force", "slider.ax"])
    rows.append(dict(E=p[modulus] / 1e9, eta=p[viscosity], c_over_k=c_over_k, peak=np.abs(torque).max(),
                     rms=np.sqrt((torque**2).mean()), torque_hf=above(torque), force=np.abs(force).max(),
                     approach=d["rod_slider.penetration"].max() * 1e6, ax_hf=above(ax)))
sweep = pd.DataFrame(rows).sort_values(["E", "eta"], ascending=[False, True])
m = rigid["time"] >= 0.02
rt, rax = rigid["motor.torque"][m], rigid["slider.ax"][m]
print("rigid bearing: peak torque %.0f, RMS %.0f, torque >1 kHz %.0f, peak force %.0f, a_x >1 kHz %.0f" % (
    np.abs(rt).max(), np.sqrt((rt**2).mean()), above(rt), np.abs(rigid["rod_slider.force"][m]).max(), above(rax)))
print(sweep.to_string(index=False, float_format=lambda x: f"{x:.6g}"))
fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
for k, (eta, g) in enumerate(sweep.groupby("eta")):
    label = "η_s = %g Pa s (c/k %.0e–%.0e s)" % (eta, g["c_over_k"].min(), g["c_over_k"].max())
    if eta == 300:
        label = "η_s = 300 Pa s (study; damping left out)"
    axes[0].plot(g["E"], g["peak"] / 1e3, "o-", color=f"C{k}", label=label)
    axes[1].plot(g["E"], g["ax_hf"] / 1e3, "o-", color=f"C{k}", label=label)
axes[0].axhline(np.abs(rt).max() / 1e3, color="k", ls=":", label="rigid bearing")
axes[0].axhline(0.5 * np.abs(rt).max() / 1e3, color="k", ls="--", lw=0.8, label="half the rigid peak")
axes[1].axhline(above(rax) / 1e3, color="k", ls=":", label="rigid bearing")
axes[0].set_ylabel("peak crank torque [kN m]")
axes[1].set_ylabel("slider a_x above 1 kHz, RMS [km/s²]")
for ax in axes[:2]:
    ax.set_xscale("log")
    ax.set_xlabel("bush Young's modulus [GPa] (bronze: 110)")
    ax.grid(alpha=0.3, which="both")
axes[0].set_ylim(0, None)
axes[1].set_ylim(0, None)
axes[0].legend(fontsize=6)
axes[0].set_title("F, 1 mm: revolutions 2–3, 100 kHz", fontsize=9)
ax = axes[2]
ax.plot(rigid["time"][m] * 1e3, rt / 1e3, lw=0.6, color="k", label="rigid bearing")
for e_gpa, eta in [(110, 300.0), (20, 300.0), (20, 4e5)]:
    p = params[(params[modulus] == e_gpa * 1e9) & (params[viscosity] == eta)].iloc[0]
    d = data[(data["run_id"] == p["run_id"]) & (data["t"] >= 0.02)]
    ax.plot(d["t"] * 1e3, d["motor.torque"] / 1e3, lw=0.6, label=f"bush {e_gpa} GPa, η_s {eta:g} Pa s")
ax.set_xlabel("time [ms]")
ax.set_ylabel("crank torque [kN m]")
ax.legend(fontsize=7)
ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig("docs/figures/F_bush_modulus.png", dpi=110)
print("figures written to docs/figures/")
