"""A Python master co-simulating lash's two FMUs (mechanism = macro, interface = micro) with fmpy's
low-level FMI 3.0 API, with the multirate scheme of lash's InterfaceMaster (one-way coupling,
linear interpolation: at each macro step the micro inputs are the values at the step start and the
slopes to the next node; the slider acceleration is propagated at every micro step as
free + gain . f_c with the maps interpolated linearly).

Compares the slider acceleration with lash's in-process run (a CSV of `lash run A --model reduced`).
Usage: python reduced_cosim.py lash_mechanism.fmu lash_interface.fmu lash_reduced_timeseries.csv
"""

import csv
import shutil
import sys

from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave


def open_fmu(path, name):
    md = read_model_description(path)
    d = extract(path)
    s = FMU3Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    s.instantiate()
    sizes = {}
    for v in md.modelVariables:
        n = 1
        for dim in v.dimensions:
            n *= int(dim.start)
        sizes[v.name] = (v.valueReference, n)
    return s, sizes, d


mech, mv, d1 = open_fmu(sys.argv[1], "mechanism")
micro, uv, d2 = open_fmu(sys.argv[2], "interface")
h_m, h_r, n_micro, n_macro = 1e-3, 1e-5, 100, 36
for s in (mech, micro):
    s.enterInitializationMode(startTime=0.0, stopTime=n_macro * h_m)
    s.exitInitializationMode()

names = ["effective_mass", "effective_force", "journal_angular_velocity", "bearing_angular_velocity",
         "slider.acceleration_free", "slider.acceleration_gain"]


def frame():
    return {n: mech.getFloat64([mv[n][0]], mv[n][1]) for n in names}


inputs = [uv[n][0] for n in ["effective_mass", "effective_mass_rate", "effective_force", "effective_force_rate",
                              "journal_angular_velocity", "journal_angular_acceleration",
                              "bearing_angular_velocity", "bearing_angular_acceleration"]]
force_vr = uv["contact_force"][0]

a = frame()
ax = [a["slider.acceleration_free"][0]]
for k in range(n_macro):
    t_k = k * h_m
    mech.doStep(t_k, h_m)
    b = frame()
    values = []
    for name, count in [("effective_mass", 4), ("effective_force", 2)]:
        value = [a[name][e] + (b[name][e] - a[name][e]) * 0.0 for e in range(count)]
        rate = [(b[name][e] - a[name][e]) / h_m for e in range(count)]
        values += value + rate
    for name in ["journal_angular_velocity", "bearing_angular_velocity"]:
        values += [a[name][0] + (b[name][0] - a[name][0]) * 0.0, (b[name][0] - a[name][0]) / h_m]
    micro.setFloat64(inputs, values)

    def lerp(name, e, s):
        return a[name][e] + (b[name][e] - a[name][e]) * s

    for j in range(n_micro):
        micro.doStep(t_k + j * h_r, h_r)
        fx, fy = micro.getFloat64([force_vr], 2)
        s = (j + 1) / n_micro
        ax.append(lerp("slider.acceleration_free", 0, s) + lerp("slider.acceleration_gain", 0, s) * fx
                  + lerp("slider.acceleration_gain", 1, s) * fy)
    a = b

for s in (mech, micro):
    s.terminate()
    s.freeInstance()
shutil.rmtree(d1, ignore_errors=True)
shutil.rmtree(d2, ignore_errors=True)

with open(sys.argv[3]) as f:
    rows = list(csv.reader(f))
k = [i for i, h in enumerate(rows[0]) if h.startswith("slider.ax [")][0]
lash = [float(r[k]) for r in rows[1:]]
assert len(lash) == len(ax), (len(lash), len(ax))
peak = max(abs(v) for v in lash)
worst = max(abs(p - q) for p, q in zip(ax, lash))
identical = all(p == q for p, q in zip(ax, lash))
print(f"fmpy master vs lash in-process: {len(ax)} samples, peak {peak:.6e} m/s^2, max difference {worst:.3e} "
      f"({worst / peak:.3e} of the peak), bit-identical: {identical}")
assert worst <= 1e-12 * peak, "the FMU co-simulation must reproduce lash's in-process result"
