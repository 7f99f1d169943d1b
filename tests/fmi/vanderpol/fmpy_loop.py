"""fmpy's own per-step cost on the same FMU, for comparison with `lash bench fmu` in one session.

usage: fmpy_loop.py <file.fmu> [steps]
"""
import shutil
import sys
import time

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

path = sys.argv[1]
steps = int(sys.argv[2]) if len(sys.argv) > 2 else 100_000
md = read_model_description(path)
unzipdir = extract(path)
fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
fmu.instantiate()
fmu.setupExperiment(startTime=0.0)
fmu.enterInitializationMode()
fmu.exitInitializationMode()
vrs = [v.valueReference for v in md.modelVariables if v.causality == "output"]
rounds = []
t = 0.0
for r in range(6):
    start = time.perf_counter()
    for k in range(steps):
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.01)
        t += 0.01
    rounds.append((time.perf_counter() - start) / steps)
rounds = sorted(rounds[1:])
print(f"fmpy FMU2Slave.doStep loop: {rounds[2] * 1e9:.1f} ns per step (median of 5 rounds of {steps})")
fmu.terminate()
fmu.freeInstance()
shutil.rmtree(unzipdir, ignore_errors=True)
