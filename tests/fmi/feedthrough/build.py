"""Builds feedthrough.fmu (FMI 2.0, binaries/linux64) from feedthrough.c with the system C compiler.

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
    so = os.path.join(tmp, "feedthrough.so")
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-Wall", "-Wextra", "-Wno-unused-parameter",
                    "-o", so, os.path.join(here, "feedthrough.c")], check=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(os.path.join(here, "modelDescription.xml"), "modelDescription.xml")
        z.write(so, "binaries/linux64/feedthrough.so")
print(out)
