"""Generate a dataset with lash and fit a small model on it — from Python, start to end.

    pip install ./crates/lash-py        # once (builds lash's Python package with maturin)
    python examples/python/train_surrogate.py [out-folder]

The question a state estimator would ask: from the slider's accelerometer alone, how large is the
clearance of the crank–rod joint? A Latin-hypercube sweep of scenario A varies the clearance and
the friction coefficient; each run's accelerometer is sampled at 10 kHz with sensor noise, as a
real logger would. From each run we take a few features of the signal (RMS, peak-to-peak, and
the size and kurtosis of the impacts' ringing above the smooth motion) and fit a ridge
regression of the clearance on them (numpy only), trained on 75 % of the runs and scored on the
rest: with the default 48 runs, R² ≈ 0.65 (RMSE ≈ 30 µm over a 20–200 µm range).

LASH_EXAMPLE_RUNS sets the number of runs (default 48; the test suite runs it with 16).
"""

import os
import sys
import tempfile

import numpy as np

import lash

runs = int(os.environ.get("LASH_EXAMPLE_RUNS", "48"))
out = sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="lash-surrogate-")

# %% The sweep: a file like any other sweep file (`lash sweep` runs it as well).
sweep_file = os.path.join(out, "sweep.toml")
os.makedirs(out, exist_ok=True)
with open(sweep_file, "w", encoding="utf-8") as f:
    f.write(
        f"""
base = "A"
model = "reduced"
sampling = "latin_hypercube"
runs = {runs}
seed = 7
horizon = 0.05

[output]
channels = ["slider.ax"]
sample_rate = 10000.0
noise = {{ "slider.ax" = 20.0 }}

[[parameters]]
# bearing radius: clearance c = R_B - R_J from 20 to 200 µm (R_J = 9.9 mm)
path = "clearances[0].bearing_radius"
uniform = {{ low = 0.00992, high = 0.0101 }}

[[parameters]]
path = "clearances[0].friction.coefficient"
uniform = {{ low = 0.0, high = 0.1 }}
"""
    )
print(lash.validate(sweep_file))
report = lash.sweep(sweep_file, os.path.join(out, "data"))
print(f"{report['runs']} runs in {report['wall_s']:.2f} s ({report['simulated_s']:.2f} s simulated)")

# %% The dataset as arrays: (runs, samples, channels), the parameters as a table.
data = lash.Dataset(os.path.join(out, "data"))
print(data)
print(data.params.head() if hasattr(data.params, "head") else data.params)
acc = data.channel("slider.ax")  # runs × samples, m/s^2
clearance = data.inputs[:, data.parameters.index("clearances[0].bearing_radius")] - 0.0099  # m

# %% Features of each run's signal (the first revolution is left out: start-up). The impacts
# ring above the slider's smooth motion: what a 1 ms moving average does not follow.
steady = acc[:, data.time >= 0.012]
smooth = np.array([np.convolve(r, np.ones(11) / 11, mode="same") for r in steady])
ringing = (steady - smooth)[:, 10:-10]
features = np.column_stack(
    [
        np.log(np.sqrt((steady**2).mean(axis=1))),
        np.log(steady.max(axis=1) - steady.min(axis=1)),
        np.log(np.sqrt((ringing**2).mean(axis=1))),
        np.log(np.abs(ringing).max(axis=1)),
        (ringing**4).mean(axis=1) / (ringing**2).mean(axis=1) ** 2,  # kurtosis: how impulsive
    ]
)

# %% Ridge regression, trained in batches the way a training loop would read the data.
order = np.random.default_rng(0).permutation(len(data))
train, test = order[: int(0.75 * len(order))], order[int(0.75 * len(order)) :]
mean, scale = features[train].mean(axis=0), features[train].std(axis=0) + 1e-12
x = np.column_stack([np.ones(len(features)), (features - mean) / scale])
y = clearance * 1e6  # µm
gram, moment = np.zeros((x.shape[1], x.shape[1])), np.zeros(x.shape[1])
for start in range(0, len(train), 8):  # accumulate the normal equations batch by batch
    rows = train[start : start + 8]
    gram += x[rows].T @ x[rows]
    moment += x[rows].T @ y[rows]
weights = np.linalg.solve(gram + 1e-3 * np.eye(x.shape[1]), moment)
predicted = x[test] @ weights
r2 = 1.0 - ((predicted - y[test]) ** 2).sum() / ((y[test] - y[test].mean()) ** 2).sum()
rmse = np.sqrt(((predicted - y[test]) ** 2).mean())
print(f"clearance from the accelerometer: R² = {r2:.3f}, RMSE = {rmse:.1f} µm on {len(test)} held-out runs")
for x_batch, y_batch in data.batches(8, channels=["slider.ax"]):
    assert x_batch.shape[0] == y_batch.shape[0]  # (batch, parameters), (batch, samples, 1)
