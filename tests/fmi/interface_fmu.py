"""Drives lash's clearance-interface FMU (FMI 3.0 co-simulation) with fmpy's low-level API.

Checks, independently of lash's own code:
  * free flight follows the closed form e = (f / m) t^2 / 2 (RK4 is exact for it);
  * the journal then hits the bearing: an impact is counted, the penetration stays small, the
    contact force points back towards the centre;
  * getFMUState / setFMUState replay the same steps bit for bit;
  * bad calls (setting an output, a non-finite input, a wrong step start) are refused with fmi3Error.
Usage: python interface_fmu.py lash_interface.fmu
"""

import math
import shutil
import sys

from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave

path = sys.argv[1]
md = read_model_description(path)
vr = {v.name: v.valueReference for v in md.modelVariables}
unzipped = extract(path)
messages = []


def log(env, status, category, message):
    messages.append(message.decode())


fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName="interface")
fmu.instantiate(logMessage=log)
fmu.enterInitializationMode(startTime=0.0, stopTime=0.01)
fmu.exitInitializationMode()

m, f, h = 0.1, 1000.0, 1e-5
fmu.setFloat64([vr["effective_mass"], vr["effective_force"]], [m, 0.0, 0.0, m, f, 0.0])
c = fmu.getFloat64([vr["radial_clearance"]])[0]
t = 0.0


def step():
    global t
    fmu.doStep(t, h)
    t += h


# Free flight: exact closed form while |e| < c.
for k in range(1, 5):
    step()
    ex, ey = fmu.getFloat64([vr["eccentricity"]], 2)
    exact = 0.5 * f / m * t * t
    assert exact < c, "still in free flight"
    assert abs(ex - exact) <= 1e-12 * exact and ey == 0.0, (k, ex, exact)

# Rollback: save, run 60 steps through the impact, restore, run them again.
saved, t_saved = fmu.getFMUState(), t
outputs = [vr["contact_force"], vr["eccentricity"], vr["penetration"]]


def run(n):
    out = []
    for _ in range(n):
        step()
        out.append(fmu.getFloat64(outputs, 5))
    return out


first = run(60)
impacts = fmu.getFloat64([vr["impacts"]])[0] + fmu.getFloat64([vr["in_contact"]])[0]
assert impacts >= 1, "the journal reaches the bearing"
max_penetration = max(r[4] for r in first)
assert 0.0 < max_penetration < c, max_penetration  # positive, and far below a blow-up
assert any(r[0] < -1.0 for r in first), "the contact force pushes the journal back (-x)"
fmu.setFMUState(saved)
t = t_saved
again = run(60)
assert first == again, "setFMUState replays bit for bit"
fmu.freeFMUState(saved)


def refused(call, *args):
    try:
        call(*args)
    except Exception:
        return True
    return False


assert refused(fmu.setFloat64, [vr["contact_force"]], [1.0, 2.0])
assert any("contact_force: is not an input" in msg for msg in messages), messages
assert refused(fmu.setFloat64, [vr["effective_force"]], [math.nan, 0.0])
assert refused(fmu.doStep, t + 1e-3, h)
assert any("currentCommunicationPoint" in msg for msg in messages), messages
fmu.terminate()
fmu.freeInstance()
shutil.rmtree(unzipped, ignore_errors=True)
print("interface FMU: free flight exact, impact, rollback replay, bad calls refused: OK")
