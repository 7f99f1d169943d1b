"""Runs an SSP (a folder holding SystemStructure.ssd) with libcosim (libcosimpy from PyPI) and
writes the chosen real outputs after every step, at full precision.

usage: libcosim_run.py <ssp folder> <steps> <out.csv> <step in ns> <instance.variable=vr> ...
"""
import sys

from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimObserver import CosimObserver

folder, steps, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
# The step in nanoseconds (libcosim's time unit); given, because libcosimpy 0.0.6 crashes reading it
# from the file.
step_ns = int(sys.argv[4])
probes = [(p.split("=")[0], int(p.split("=")[1])) for p in sys.argv[5:]]
execution = CosimExecution.from_ssp_file(ssp_path=folder, step_size=step_ns)
observer = CosimObserver.create_last_value()
execution.add_observer(observer=observer)
slaves = {name.rsplit(".", 1)[0]: execution.slave_index_from_instance_name(name.split(".")[0]) for name, _ in probes}
with open(out, "w") as f:
    f.write(",".join(['"' + name + '"' for name, _ in probes]) + "\n")
    for _ in range(steps):
        execution.step()
        row = [observer.last_real_values(slave_index=slaves[name.rsplit(".", 1)[0]], variable_references=[vr])[0]
               for name, vr in probes]
        f.write(",".join(repr(v) for v in row) + "\n")
print(out)
