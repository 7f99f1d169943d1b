"""Builds a co-simulation FMU from a folder holding <name>.c and modelDescription.xml (the folder's
name is the model identifier) with the system C compiler: FMI 2.0 into binaries/linux64, FMI 3.0
into binaries/x86_64-linux, as the description's fmiVersion says.

usage: build_c_fmu.py <folder> <output.fmu>
"""
import os
import re
import subprocess
import sys
import tempfile
import zipfile

folder, out = os.path.abspath(sys.argv[1]), sys.argv[2]
name = os.path.basename(folder)
description = os.path.join(folder, "modelDescription.xml")
with open(description, encoding="utf-8") as f:
    version = re.search(r'fmiVersion="([0-9.]+)"', f.read()).group(1)
platform = "x86_64-linux" if version.startswith("3") else "linux64"
with tempfile.TemporaryDirectory() as tmp:
    so = os.path.join(tmp, name + ".so")
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-Wall", "-Wextra", "-Wno-unused-parameter",
                    "-Wno-strict-prototypes", "-o", so, os.path.join(folder, name + ".c"), "-lm"], check=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(description, "modelDescription.xml")
        z.write(so, f"binaries/{platform}/{name}.so")
print(out)
