"""What the Python path costs over the command line, for equal work.

    python crates/lash-py/bench.py [path/to/lash] [rounds]

Runs A's reduced model for 0.1 s (every channel at the scenario's 1e-5 s output interval) by
`lash.run` in this process and by `lash run` as a process, alternating, and prints the best of
each: the Python call (simulation and hand-over of the samples as a numpy array), the command's
own simulation time (its summary's `timing.simulation_s`: the same simulation without the CSV;
the model is built before its clock starts, as the runner's own `wall_time_s` in Python)
and the whole command (process start, simulation and CSV output). Use a release build of both
(`cargo build --release`, `pip install ./crates/lash-py`).
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import lash

binary = sys.argv[1] if len(sys.argv) > 1 else "target/release/lash"
rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 15
scenario = lash.load("A").with_values({"simulation.horizon": 0.1})
out = tempfile.mkdtemp(prefix="lash-bench-py-")
python, python_simulation, cli_simulation, cli_process = [], [], [], []
for _ in range(rounds):
    started = time.perf_counter()
    run = lash.run(scenario, "reduced")
    python.append(time.perf_counter() - started)
    python_simulation.append(run.summary["wall_time_s"])
    started = time.perf_counter()
    subprocess.run([binary, "run", "A", "--model", "reduced", "--horizon", "0.1", "--out", out, "--quiet"], check=True,
                   capture_output=True)
    cli_process.append(time.perf_counter() - started)
    with open(os.path.join(out, "summary.json")) as f:
        cli_simulation.append(json.load(f)["timing"]["simulation_s"])
p, ps, s, w = min(python), min(python_simulation), min(cli_simulation), min(cli_process)
print(f"A reduced, 0.1 s, {run.samples.shape[0]} samples x {run.samples.shape[1]} columns, best of {rounds}:")
print(f"  lash.run (Python, in process)        {p * 1e3:7.2f} ms")
print(f"    of which the runner's execute      {ps * 1e3:7.2f} ms   (its summary's wall_time_s)")
print(f"  lash run: its simulation alone       {s * 1e3:7.2f} ms   Python / this = {p / s:.3f}")
print(f"  lash run: the whole command          {w * 1e3:7.2f} ms   Python / this = {p / w:.3f}")
