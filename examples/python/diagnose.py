"""Diagnose a worn pin from a slider's accelerometer (docs/user-guide.md, "Diagnose a worn pin").

    python examples/python/diagnose.py [measured.csv]

Prepares an estimator for scenario A once (prepared-A.json, a few minutes), then answers for the
measured file given — or, without one, for a measurement emulated from the converged full model
at 180 µm of clearance.
"""

import os
import sys

import lash

prepared = "prepared-A.json"
if not os.path.exists(prepared):
    print("preparing the estimator for scenario A (once; a few minutes)…")
    lash.prepare_estimator("A", prepared, quiet=False)

measured = sys.argv[1] if len(sys.argv) > 1 else "measured-180um.csv"
if len(sys.argv) == 1:
    lash.emulate_measurement(prepared, [180e-6], measured, snr=40.0)

answer = lash.estimate(measured, prepared)
for note in answer["notes"]:
    print("note:", note)
for u in answer["unknowns"]:
    scale, unit = (1e6, "µm") if u["unit"] == "m" else (1.0, u["unit"])
    print(f"{u['name']:<24} {u['median'] * scale:10.3f} {unit:5}  90 % interval {u['low'] * scale:.3f} – {u['high'] * scale:.3f}")
for joint, p in answer["worn"]:
    print(f"worn joint {joint}: probability {p:.2f}")

# What the pin sees: the hidden signals, re-simulated from the posterior and aligned with the
# measurement (numpy arrays over the window, median and 5–95 % band).
hidden = answer["hidden"]
for j, force in enumerate(hidden["signals"][0::2]):
    rms, low, high = hidden["force_rms"][j]
    peak = hidden["force_peak"][j]
    print(
        f"{force['name']}: RMS {rms:.0f} N ({low:.0f}–{high:.0f}), peak {peak[0]:.0f} N ({peak[1]:.0f}–{peak[2]:.0f}), "
        f"{len(hidden['onsets'][j])} impact onsets; first samples {force['median'][:3].round(0)} N"
    )
