"""A Python master co-simulating lash's two FMUs (mechanism = macro, interface = micro) with fmpy's
low-level API (FMI 3.0 or FMI 2.0, taken from the archives), with the multirate scheme of lash's InterfaceMaster (one-way coupling,
linear interpolation: at each macro step the micro inputs are the values at the step start and the
slopes to the next node; the slider acceleration is propagated at every micro step as
free + gain . [f_c; F_T] with the maps interpolated linearly), for any number of clearance joints
(sizes read from the mechanism FMU) and either form of the interface terms (the names the
interface FMU takes).

Compares the slider acceleration with lash's in-process run (a CSV of `lash run SCENARIO --model reduced --horizon 0.036`), for planar and spatial scenarios alike.
Usage: python reduced_cosim.py lash_mechanism.fmu lash_interface.fmu lash_reduced_timeseries.csv [name=value,...]

The optional last argument sets parameters of the interface FMU (its clearance joint's radii and
law coefficients) before initialization; the CSV must then come from a scenario with those values.
"""

import csv
import shutil
import sys

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

STOP = 0.036


class Fmu:
    """The same calls over FMI 3.0 (arrays) and FMI 2.0 (one scalar per element)."""

    def __init__(self, path, name, parameters=None):
        md = read_model_description(path)
        self.dir = extract(path)
        self.v3 = md.fmiVersion.startswith("3")
        kind = FMU3Slave if self.v3 else FMU2Slave
        self.s = kind(guid=md.guid, unzipDirectory=self.dir, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
        self.s.instantiate()
        self.refs = {}
        for v in md.modelVariables:
            base = v.name.split("[")[0]
            if self.v3:
                n = 1
                for dim in v.dimensions:
                    n *= int(dim.start)
                self.refs[base] = (v.valueReference, n)
            else:
                self.refs.setdefault(base, []).append(v.valueReference)
        for pname, value in (parameters or {}).items():
            self.set([pname], [value])
        if self.v3:
            self.s.enterInitializationMode(startTime=0.0, stopTime=STOP)
        else:
            self.s.setupExperiment(startTime=0.0, stopTime=STOP)
            self.s.enterInitializationMode()
        self.s.exitInitializationMode()

    def get(self, name):
        if self.v3:
            vr, n = self.refs[name]
            return self.s.getFloat64([vr], n)
        return self.s.getReal(self.refs[name])

    def set(self, names, values):
        if self.v3:
            self.s.setFloat64([self.refs[n][0] for n in names], values)
        else:
            self.s.setReal([vr for n in names for vr in self.refs[n]], values)

    def step(self, t, h):
        self.s.doStep(t, h)

    def close(self):
        self.s.terminate()
        self.s.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


mech = Fmu(sys.argv[1], "mechanism")
parameters = {}
if len(sys.argv) > 4:
    for item in sys.argv[4].split(","):
        pname, value = item.split("=")
        parameters[pname] = float(value)
micro = Fmu(sys.argv[2], "interface", parameters)
h_m, h_r, n_micro, n_macro = 1e-3, 1e-5, 100, 36

# The interface terms the micro FMU takes: effective-mass form (M~, f~, H; planar joints) or
# mobility form (W, a_free, W H; spherical joints), named alike on both FMUs.
if "mobility" in micro.refs:
    terms = ["mobility", "free_acceleration", "friction_mobility"]
else:
    terms = ["effective_mass", "effective_force", "friction_moment_force"]
coupled = terms + ["journal_angular_velocity", "bearing_angular_velocity"]
names = coupled + ["slider.acceleration_free", "slider.acceleration_gain"]


def frame():
    return {name: mech.get(name) for name in names}


inputs = [x for t in terms for x in (t, t + "_rate")] + [
    "journal_angular_velocity", "journal_angular_acceleration", "bearing_angular_velocity",
    "bearing_angular_acceleration"]

a = frame()
ax = [a["slider.acceleration_free"][0]]
for step in range(n_macro):
    t_k = step * h_m
    mech.step(t_k, h_m)
    b = frame()
    values = []
    # Sizes from the mechanism's arrays (n interface coordinates, m friction loads, r angular
    # velocity components: planar revolute or spherical joints alike).
    for name in coupled:
        count = len(a[name])
        value = [a[name][e] + (b[name][e] - a[name][e]) * 0.0 for e in range(count)]
        rate = [(b[name][e] - a[name][e]) / h_m for e in range(count)]
        values += value + rate
    micro.set(inputs, values)

    def lerp(name, e, s):
        return a[name][e] + (b[name][e] - a[name][e]) * s

    for j in range(n_micro):
        micro.step(t_k + j * h_r, h_r)
        # The loads in lash's order: contact forces (n), then friction loads (m: F_T per planar
        # joint, the friction force's and moments' components per spherical joint).
        loads = list(micro.get("contact_force")) + list(micro.get("friction_load"))
        s = (j + 1) / n_micro
        v = lerp("slider.acceleration_free", 0, s)
        for c, load in enumerate(loads):
            v = v + lerp("slider.acceleration_gain", c, s) * load
        ax.append(v)
    a = b

mech.close()
micro.close()

with open(sys.argv[3]) as f:
    rows = list(csv.reader(f))
k = [i for i, h in enumerate(rows[0]) if h.startswith("slider.ax [")][0]
lash = [float(r[k]) for r in rows[1:]]
assert len(lash) == len(ax), (len(lash), len(ax))
peak = max(abs(v) for v in lash)
worst = max(abs(p - q) for p, q in zip(ax, lash))
identical = all(p == q for p, q in zip(ax, lash))
version = "3.0" if mech.v3 else "2.0"
print(f"fmpy master (FMI {version}) vs lash in-process: {len(ax)} samples, peak {peak:.6e} m/s^2, max difference {worst:.3e} "
      f"({worst / peak:.3e} of the peak), bit-identical: {identical}")
assert worst <= 1e-12 * peak, "the FMU co-simulation must reproduce lash's in-process result"
