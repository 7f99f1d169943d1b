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
print("figures written to docs/figures/")
