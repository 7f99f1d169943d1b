"""Builds oscillator.fmu (FMI 3.0, binaries/x86_64-linux) from oscillator.c with the system C compiler.

usage: build.py <output.fmu>
"""
import os
import subprocess
import sys
import tempfile
import zipfile

here = os.path.dirname(os.path.abspath(__file__))
out = sys.argv[1]
with tempfile.TemporaryDirectory() as tmp:
    so = os.path.join(tmp, "oscillator.so")
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-Wall", "-Wno-unused-parameter", "-Wno-strict-prototypes",
                    "-o", so, os.path.join(here, "oscillator.c"), "-lm"], check=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(os.path.join(here, "modelDescription.xml"), "modelDescription.xml")
        z.write(so, "binaries/x86_64-linux/oscillator.so")
print(out)
