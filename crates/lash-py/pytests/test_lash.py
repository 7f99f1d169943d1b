"""lash's Python package against the command line and against itself.

Run by tests/python.rs (the test command): a venv in target/py-venv, `pip install` of
crates/lash-py, then pytest here. LASH_BIN is the `lash` binary of the same build, LASH_ROOT the
repository.
"""

import csv
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import lash

ROOT = os.environ.get("LASH_ROOT", os.path.join(os.path.dirname(__file__), "..", "..", ".."))
LASH = os.environ.get("LASH_BIN", "lash")


def cli(*args):
    return subprocess.run([LASH, *args], capture_output=True, text=True)


# Scenarios: load, edit, validate.


def test_builtins_and_files_load_and_round_trip():
    a = lash.load("A")
    assert a.name == "A" and a.space == "planar"
    assert lash.load("E-0.5mm-250rpm").space == "spatial"
    from_file = lash.load(os.path.join(ROOT, "examples", "A.toml"))
    assert from_file.to_dict() == lash.Scenario.from_toml(from_file.to_toml()).to_dict()
    assert lash.Scenario.from_dict(a.to_dict()).to_dict() == a.to_dict()
    assert ("slider.ax", "m/s^2") in a.channels()


def test_edits_by_path_and_by_dict_are_validated_and_name_the_field():
    a = lash.load("A")
    b = a.with_values({"clearances[0].bearing_radius": 0.0100, "simulation.horizon": 0.02})
    assert b.get("clearances[0].bearing_radius") == 0.0100 and b.get("simulation.horizon") == 0.02
    assert a.get("simulation.horizon") != 0.02  # a copy: the original is unchanged
    with pytest.raises(lash.ScenarioError) as e:
        a.with_values({"clearances[0].bearing_radius": -1.0})
    fields = [f for f, _ in e.value.problems]
    assert "clearances[0].bearing_radius" in fields and "must be > 0" in str(e.value)
    with pytest.raises(lash.ScenarioError) as e:
        a.with_values({"clearances[0].journal_radiuz": 0.01})
    assert e.value.problems[0][0] == "clearances[0].journal_radiuz" and "journal_radius" in str(e.value)
    d = a.to_dict()
    del next(j for j in d["joints"] if j["name"] == d["clearances"][0]["joint"])["point1"]
    with pytest.raises(lash.ScenarioError) as e:
        lash.Scenario.from_dict(d)
    assert any("point1" in f for f, _ in e.value.problems)
    with pytest.raises(lash.ScenarioError, match="nor a built-in scenario"):
        lash.load("Z")
    assert isinstance(e.value, ValueError)


def test_validate_takes_scenario_and_sweep_files(tmp_path):
    assert "valid" in lash.validate(os.path.join(ROOT, "examples", "B.toml"))
    assert "valid" in lash.validate(os.path.join(ROOT, "examples", "sweep-grid.toml"))
    bad = tmp_path / "bad.toml"
    with open(os.path.join(ROOT, "examples", "A.toml")) as f:
        bad.write_text(f.read().replace("[simulation]", "[simulation]\nbogus = 1", 1))
    with pytest.raises(lash.ScenarioError) as e:
        lash.validate(bad)
    assert any("bogus" in f or "bogus" in m for f, m in e.value.problems)


# Runs: the same numbers as the command line.


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(v) for v in r] for r in rows[1:]])


@pytest.mark.parametrize("model", ["full", "reduced"])
def test_a_run_equals_the_command_lines_bit_for_bit(tmp_path, model):
    r = lash.run("A", model, horizon=0.01)
    out = tmp_path / model
    done = cli("run", "A", "--model", model, "--horizon", "0.01", "--out", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    header, table = read_csv(out / "timeseries.csv")
    assert [h.split(" [")[0] for h in header] == ["time", *r.channels]
    assert r.samples.shape == table.shape
    assert np.array_equal(r.samples, table)  # CSV written with shortest round-trip floats
    assert r.units["slider.ax"] == "m/s^2" and r.summary["model"] == model
    assert np.shares_memory(r["slider.ax"], r.samples) and np.shares_memory(r.values, r.samples)
    df = r.to_pandas()
    assert df.attrs["units"]["slider.ax"] == "m/s^2" and df.index.name == "time"
    assert np.array_equal(df["slider.ax"].to_numpy(), r["slider.ax"])


def test_a_reduced_run_chooses_its_micro_step_as_the_command_line(tmp_path):
    # B's rod-slider impacts (~50 us) get 5e-6 s, as `lash run` chooses; the runs are equal bit
    # for bit; a micro step given is kept.
    r = lash.run("B", "reduced", horizon=0.012)
    assert r.summary["reduced"]["options"]["micro_step"] == 5e-6
    assert "rod_slider" in r.summary["micro_step_choice"]
    done = cli("run", "B", "--model", "reduced", "--horizon", "0.012", "--out", str(tmp_path / "b"), "--quiet")
    assert done.returncode == 0, done.stderr
    assert np.array_equal(r.samples, read_csv(tmp_path / "b" / "timeseries.csv")[1])
    given = lash.run("B", "reduced", horizon=0.012, micro_step=1e-5)
    assert given.summary["reduced"]["options"]["micro_step"] == 1e-5 and "micro_step_choice" not in given.summary


def test_a_pressed_contact_the_step_does_not_hold_is_run_again_finer_as_the_command_line(tmp_path):
    # F-0.25mm's rod-slider contact chatters at 1e-5 s (its force zero at 2.8 % of the samples in
    # contact): the run is made again at 1e-6 s, as `lash run` does, bit for bit; a step given is
    # kept, with the warning.
    r = lash.run("F-0.25mm", "reduced")
    assert r.summary["reduced"]["options"]["micro_step"] == 1e-6
    assert "rod_slider" in r.summary["micro_step_refined"] and not r.summary["warnings"]
    done = cli("run", "F-0.25mm", "--model", "reduced", "--out", str(tmp_path / "f"), "--quiet")
    assert done.returncode == 0, done.stderr
    assert np.array_equal(r.samples, read_csv(tmp_path / "f" / "timeseries.csv")[1])
    given = lash.run("F-0.25mm", "reduced", micro_step=1e-5)
    assert "micro_step_refined" not in given.summary
    assert any("carries no force" in w for w in given.summary["warnings"])


def test_a_reduced_run_estimates_its_error_as_the_command_line(tmp_path):
    # B over 0.2 s in one-way coupling at a macro step of 1 ms: the error estimate (window term +
    # coupling term) and the coupling warning are those `lash run` writes, to the bit; without
    # error_estimate there is none.
    r = lash.run("B", "reduced", horizon=0.2, error_estimate=True, coupling="one_way", macro_step=1e-3)
    args = ("run", "B", "--model", "reduced", "--horizon", "0.2", "--macro-step", "1e-3", "--quiet")
    done = cli(*args, "--coupling", "one-way", "--out", str(tmp_path / "b"))
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "b" / "summary.json") as f:
        written = json.load(f)
    assert np.array_equal(r.samples, read_csv(tmp_path / "b" / "timeseries.csv")[1])
    ours, theirs = r.summary["error_estimate"], written["error_estimate"]
    assert ours["channels"] == theirs["channels"] and ours["window_s"] == theirs["window_s"]
    for c in ours["channels"]:
        assert c["estimated_error"] == c["rms_level_error"] + c["coupling_error"]
    assert [w for w in r.summary["warnings"] if w.startswith("one-way coupling")] == [
        w for w in written["warnings"] if w.startswith("one-way coupling")
    ] != []
    assert "error_estimate" not in lash.run("B", "reduced", horizon=0.012).summary
    # The default coupling ("auto") takes two-way for F over 0.2 s at a macro step of 1 ms, as
    # `lash run` does: the same samples, choice and estimate (now the two-way run's window term alone).
    auto = lash.run("F", "reduced", horizon=0.2, error_estimate=True, macro_step=1e-3)
    done = cli("run", "F", "--model", "reduced", "--horizon", "0.2", "--macro-step", "1e-3", "--quiet",
               "--out", str(tmp_path / "auto"))
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "auto" / "summary.json") as f:
        written = json.load(f)
    assert auto.summary["reduced"]["options"]["coupling"] == "two_way" == written["reduced"]["options"]["coupling"]
    assert auto.summary["coupling_choice"] == written["coupling_choice"]
    assert np.array_equal(auto.samples, read_csv(tmp_path / "auto" / "timeseries.csv")[1])
    assert auto.summary["error_estimate"]["channels"] == written["error_estimate"]["channels"]
    assert all(c["coupling_error"] is None for c in written["error_estimate"]["channels"])


def test_a_run_records_the_channels_asked_for():
    r = lash.run("A", "reduced", horizon=0.01, channels=["slider.ax", "crank_pivot.force"])
    assert r.channels == ["slider.ax", "crank_pivot.force"] and r.samples.shape[1] == 3
    full = lash.run("A", "reduced", horizon=0.01)
    assert np.array_equal(r["slider.ax"], full["slider.ax"])
    with pytest.raises(lash.ScenarioError) as e:
        lash.run("A", channels=["slider.az"])
    assert any("output.channels" in f for f, _ in e.value.problems)


def test_a_spatial_run_and_its_summary(tmp_path):
    r = lash.run("E-0.5mm-250rpm", "reduced", horizon=0.01)
    assert r.summary["model"] == "reduced" and len(r.summary["clearances"]) == 2
    assert np.all(np.isfinite(r.values))
    # Two-way coupling reaches the spatial model from Python as from the command line: the
    # balls' friction spins the rod, which one-way coupling leaves at the ideal mechanism's rest.
    two = lash.run("E-0.5mm-250rpm", "reduced", horizon=0.05, coupling="two_way")
    one = lash.run("E-0.5mm-250rpm", "reduced", horizon=0.05)
    assert np.max(np.abs(one["rod.wx"])) < 1e-9 < np.max(np.abs(two["rod.wx"]))
    done = cli("run", "E-0.5mm-250rpm", "--model", "reduced", "--coupling", "two-way", "--horizon", "0.05",
               "--out", str(tmp_path / "e"), "--quiet")
    assert done.returncode == 0, done.stderr
    assert np.array_equal(two.samples, read_csv(tmp_path / "e" / "timeseries.csv")[1])


def test_bad_options_and_failing_runs_raise_the_right_errors():
    with pytest.raises(lash.ScenarioError) as e:
        lash.run("A", "medium")
    assert e.value.problems[0][0] == "model"
    with pytest.raises(lash.ScenarioError) as e:
        lash.run("A", "reduced", micro_step=-1e-5)
    assert e.value.problems[0][0] == "micro_step"
    with pytest.raises(lash.ScenarioError, match="memory"):
        lash.run(lash.load("A").with_values({"simulation.horizon": 1.0e6}))
    # A contact far too soft for the load: the journal goes through the bearing, and the run
    # says so instead of returning numbers.
    soft = lash.load("A").with_values({"materials.steel.young_modulus": 1e5, "simulation.horizon": 0.05})
    with pytest.raises(lash.SimulationError, match="penetration"):
        lash.run(soft, "reduced")


def test_a_translational_clearance_joint_runs_and_edits_as_on_the_command_line(tmp_path):
    # Scenario G's slider is a block in a guide: the full and the reduced model run it from Python
    # as `lash run` does, and its guide is edited by path.
    r = lash.run("G-driven", "full", horizon=0.02)
    done = cli("run", "G-driven", "--horizon", "0.02", "--out", str(tmp_path / "g"), "--quiet")
    assert done.returncode == 0, done.stderr
    assert np.array_equal(r.samples, read_csv(tmp_path / "g" / "timeseries.csv")[1])
    assert r.units["slider_guide.offset"] == "m"
    assert [c["name"] for c in r.summary["clearances"]] == [f"slider_guide corner {k}" for k in range(1, 5)]
    wider = lash.run(lash.load("G-driven").with_values({"guides[0].clearance": 2e-3}), "full", horizon=0.02)
    assert np.max(np.abs(wider["slider_guide.offset"])) > 1.01e-3 >= np.max(np.abs(r["slider_guide.offset"])) - 1e-4
    with pytest.raises(lash.ScenarioError) as e:
        lash.load("G").with_values({"guides[0].height": -0.05})
    assert any(f == "guides[0].height" for f, _ in e.value.problems)
    reduced = lash.run("G-driven", "reduced", horizon=0.02, coupling="one_way")
    done = cli(
        "run", "G-driven", "--model", "reduced", "--coupling", "one-way", "--horizon", "0.02",
        "--out", str(tmp_path / "gr"), "--quiet",
    )
    assert done.returncode == 0, done.stderr
    assert np.array_equal(reduced.samples, read_csv(tmp_path / "gr" / "timeseries.csv")[1])
    assert [c["name"] for c in reduced.summary["clearances"]] == [f"slider_guide corner {k}" for k in range(1, 5)]


def test_a_lubricated_joint_runs_and_edits_as_on_the_command_line(tmp_path):
    # A-lubricated's crank pivot carries an oil film: the reduced model runs it from Python as
    # `lash run` does, its film is edited by path, and a meaningless film names its field.
    r = lash.run("A-lubricated", "reduced", horizon=0.01)
    done = cli("run", "A-lubricated", "--model", "reduced", "--horizon", "0.01", "--out", str(tmp_path / "l"), "--quiet")
    assert done.returncode == 0, done.stderr
    assert np.array_equal(r.samples, read_csv(tmp_path / "l" / "timeseries.csv")[1])
    thin = lash.run(lash.load("A-lubricated").with_values({"clearances[0].film.viscosity": 0.02}), "reduced", horizon=0.01)
    assert not np.array_equal(thin["crank_pivot.fx"], r["crank_pivot.fx"])
    with pytest.raises(lash.ScenarioError) as e:
        lash.load("A-lubricated").with_values({"clearances[0].film.viscosity": -1.0})
    assert any(f == "clearances[0].film.viscosity" for f, _ in e.value.problems)


# Sweeps and datasets.

SWEEP = """
base = "A"
model = "reduced"
sampling = "grid"
seed = 11
horizon = 0.01

[output]
channels = ["slider.ax", "crank_pivot.force"]
sample_rate = 20000.0

[[parameters]]
path = "clearances[0].bearing_radius"
values = [0.00992, 0.0100, 0.00980]

[[parameters]]
path = "clearances[0].friction.coefficient"
values = [0.0, 0.1]
"""


def test_a_sweep_gives_a_dataset_whose_runs_equal_single_runs(tmp_path):
    spec = tmp_path / "sweep.toml"
    spec.write_text(SWEEP)
    out = tmp_path / "data"
    # R_B = 9.80 mm is smaller than the journal: those two runs fail, the others are kept.
    seen = []
    with pytest.raises(lash.RunsFailed) as e:
        lash.sweep(spec, out, threads=2, progress=lambda done, total, failed: seen.append((done, total, failed)))
    assert e.value.report["failed"] == 2 and e.value.report["runs"] == 6
    assert seen[-1] == (6, 6, 2) and all(a <= b for a, b in zip(seen, seen[1:]))
    assert [d for d, _, _ in seen] == [1, 2, 3, 4, 5, 6], "once per run, in order"
    data = lash.Dataset(out)
    assert data.values.shape == (4, 201, 2) and data.channels == ["slider.ax", "crank_pivot.force"]
    assert data.units == {"slider.ax": "m/s^2", "crank_pivot.force": "N"}
    assert data.parameter_units == {"clearances[0].bearing_radius": "m", "clearances[0].friction.coefficient": "1"}
    assert sorted(r for r, _ in data.failed) == [4, 5] and all("bearing_radius" in m for _, m in data.failed)
    params = data.params
    assert list(params["status"]) == ["ok"] * 4 + ["failed"] * 2
    assert params.attrs["units"]["clearances[0].bearing_radius"] == "m"
    np.testing.assert_array_equal(data.time, np.arange(201) / 20000.0)
    # Each run of the dataset is the single run of its parameters (no noise: bit for bit).
    for k, run_id in enumerate(data.run_ids):
        values = dict(zip(data.parameters, data.inputs[k]))
        values["simulation.output_interval"] = 1 / 20000.0
        r = lash.run(lash.load("A").with_values(values), "reduced", horizon=0.01)
        np.testing.assert_array_equal(data.values[k, :, 0], r["slider.ax"])
        np.testing.assert_array_equal(data.values[k, :, 1], r["crank_pivot.force"])
    # Batches: every run once per pass, inputs and values of the same runs.
    seen = []
    for x, y in data.batches(3, seed=5, channels=["crank_pivot.force"]):
        assert x.shape[0] == y.shape[0] and y.shape[1:] == (201, 1)
        for row, series in zip(x, y):
            k = int(np.flatnonzero((data.inputs == row).all(axis=1))[0])
            np.testing.assert_array_equal(series[:, 0], data.values[k, :, 1])
            seen.append(k)
    assert sorted(seen) == [0, 1, 2, 3]
    assert [list(x[:, 0]) for x, _ in data.batches(3, seed=5)] == [list(x[:, 0]) for x, _ in data.batches(3, seed=5)]
    # Lazily: the same batches, each read from the file (one row group per run), and the same
    # arrays when asked for all of them.
    lazy = lash.Dataset(out, lazy=True)
    assert list(lazy.run_ids) == list(data.run_ids) and np.array_equal(lazy.inputs, data.inputs)
    for (xa, ya), (xb, yb) in zip(data.batches(3, seed=9), lazy.batches(3, seed=9)):
        assert np.array_equal(xa, xb) and np.array_equal(ya, yb)
    assert lazy._values is None  # nothing but the batches was read
    # Map-style: dataset[i] is run i's (inputs, values), eager or read lazily; a DataLoader takes it.
    for k in range(len(data)):
        for d in (data, lazy):
            x, y = d[k]
            assert np.array_equal(x, data.inputs[k]) and np.array_equal(y, data.values[k])
    assert np.array_equal(data[-1][1], data.values[3])
    with pytest.raises(IndexError):
        data[4]
    with pytest.raises(FileNotFoundError):
        lash.Dataset(tmp_path / "no-such-sweep")
    try:
        import torch
    except ImportError:
        torch = None
    if torch is not None:
        loader = torch.utils.data.DataLoader(data, batch_size=2, shuffle=False)
        batches = list(loader)
        assert len(batches) == 2 and tuple(batches[0][1].shape) == (2, 201, 2)
        assert np.array_equal(batches[1][1].numpy(), data.values[2:4])
    assert np.array_equal(lazy.values, data.values) and np.array_equal(lazy.time, data.time)
    # Run again: everything is complete, nothing runs; the failures are still reported.
    report = lash.sweep(spec, out, allow_failures=True)
    assert report["ran"] == 0 and report["skipped"] == 6 and report["failed"] == 2


def test_the_example_generates_a_dataset_and_fits_a_model(tmp_path):
    env = dict(os.environ, LASH_EXAMPLE_RUNS="16")
    script = os.path.join(ROOT, "examples", "python", "train_surrogate.py")
    done = subprocess.run([sys.executable, script, str(tmp_path)], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    assert "16 runs" in done.stdout and "R² =" in done.stdout


# Ctrl-C: a long run or sweep stops soon after, and a sweep resumes.


def interrupt_after(seconds):
    import _thread
    import signal
    import threading

    # The handler these tests rely on, installed here: a Python started with SIGINT ignored (in the
    # background of a non-interactive shell, under some CI runners) has none, and interrupt_main
    # then does nothing.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(seconds, _thread.interrupt_main)
    timer.start()
    return timer


def test_ctrl_c_stops_a_long_run():
    import time

    # About 2 s of work, 60 001 rows; the signals are checked every 4096 rows (~0.1 s here).
    long = lash.load("A").with_values({"simulation.horizon": 60.0, "simulation.output_interval": 1e-3})
    interrupt_after(0.1)
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        lash.run(long, "reduced")
    assert time.perf_counter() - started < 1.0


def test_ctrl_c_stops_a_sweep_which_then_resumes(tmp_path):
    spec = tmp_path / "sweep.toml"
    spec.write_text(
        SWEEP.replace("horizon = 0.01", "horizon = 1.0").replace("values = [0.00992, 0.0100, 0.00980]",
                                                                 "linspace = { start = 0.00992, stop = 0.0101, count = 12 }")
    )
    out = tmp_path / "data"
    interrupt_after(0.1)
    with pytest.raises(KeyboardInterrupt):
        lash.sweep(spec, out, threads=1)
    assert not (out / "data.parquet").exists()  # an interrupted folder never looks complete
    report = lash.sweep(spec, out, threads=2)
    assert report["skipped"] > 0 and report["skipped"] + report["ran"] == 24 and report["failed"] == 0
    assert lash.Dataset(out).values.shape[0] == 24


# Estimation.


def test_estimate_in_python_equals_the_command_line_and_refuses_bad_files(tmp_path):
    prepared = tmp_path / "A.json"
    lash.prepare_estimator("A", prepared, bank_runs=150, calibration_runs=20, hidden_runs=8)
    measured = tmp_path / "m.csv"
    lash.emulate_measurement(prepared, [200e-6], measured, snr=45.0)
    answer = lash.estimate(measured, prepared)
    out = tmp_path / "cli"
    r = cli("estimate", str(measured), "--prepared", str(prepared), "--out", str(out))
    assert r.returncode == 0, r.stderr
    with open(out / "estimate.json") as f:
        import json

        from_cli = json.load(f)
    assert answer["unknowns"] == from_cli["unknowns"]
    c = answer["unknowns"][0]
    assert c["name"] == "crank_pivot.clearance" and c["low"] <= c["median"] <= c["high"]
    # The hidden signals: numpy arrays over the window, the same as the command line's table.
    force = answer["hidden"]["signals"][0]
    assert force["name"] == "crank_pivot.force" and force["median"].shape == (10_000,)
    assert (force["low"] <= force["median"]).all() and (force["median"] <= force["high"]).all()
    table = np.genfromtxt(out / "hidden.csv", delimiter=",", skip_header=1)
    assert np.array_equal(table[:, 1], force["median"])
    # Impact tracking: the particle filter's summary beside the hidden signals.
    tracked = lash.estimate(measured, prepared, track_impacts=16)
    summary = tracked["hidden"]["tracking"]
    assert summary["particles"] == 16 and summary["innovation"] > 0 and isinstance(summary["follows"], bool)
    assert tracked["unknowns"] == answer["unknowns"]
    with pytest.raises(lash.ScenarioError, match="track_impacts"):
        lash.estimate(measured, prepared, track_impacts=1)
    spread = lash.estimate(measured, prepared, track_impacts=16, track_draws=2)["hidden"]["tracking"]
    assert len(spread["draw_innovations"]) == 2 and spread["draw"] in (0, 1)
    kept = spread["draw_innovations"][spread["draw"]]
    assert kept == spread["innovation"] and all(i is None or i >= kept for i in spread["draw_innovations"])
    with pytest.raises(lash.ScenarioError, match="track_draws"):
        lash.estimate(measured, prepared, track_impacts=16, track_draws=17)
    with pytest.raises(lash.ScenarioError, match="track_draws"):
        lash.estimate(measured, prepared, track_draws=2)
    with pytest.raises(FileNotFoundError):
        lash.estimate(tmp_path / "missing.csv", prepared)
    bad = tmp_path / "bad.csv"
    bad.write_text("time [s],slider.ax [V]\n0,1\n0.0001,2\n")
    with pytest.raises(lash.ScenarioError, match="slider.ax"):
        lash.estimate(bad, prepared)
    with pytest.raises(lash.ScenarioError, match="not a built-in setup"):
        lash.prepare_estimator("Z", tmp_path / "z.json")


# What the command line reaches, Python reaches.


def test_reduced_model_options_and_system_files_run_as_on_the_command_line(tmp_path):
    r = lash.run("A", "reduced", horizon=0.01, interpolation="hermite", coupling="two_way", micro="dopri5")
    out = tmp_path / "options"
    done = cli(
        "run", "A", "--model", "reduced", "--horizon", "0.01", "--interpolation", "hermite",
        "--coupling", "two-way", "--micro", "dopri5", "--out", str(out), "--quiet",
    )
    assert done.returncode == 0, done.stderr
    assert np.array_equal(r.samples, read_csv(out / "timeseries.csv")[1])
    assert not np.array_equal(r.samples, lash.run("A", "reduced", horizon=0.01).samples)
    with pytest.raises(lash.ScenarioError) as e:
        lash.run("A", "reduced", interpolation="spline")
    assert e.value.problems[0][0] == "interpolation"
    # A system file: the built-in mechanism and interface coupled by the interface master.
    system = os.path.join(ROOT, "examples", "systems", "reduced-A.toml")
    s = lash.run(system, horizon=0.01)
    done = cli("run", system, "--horizon", "0.01", "--out", str(tmp_path / "system"), "--quiet")
    assert done.returncode == 0, done.stderr
    header, table = read_csv(tmp_path / "system" / "timeseries.csv")
    assert [h.split(" [")[0] for h in header] == ["time", *s.channels]
    assert np.array_equal(s.samples, table) and s.summary["system"] == "reduced-A"
    with pytest.raises(lash.ScenarioError, match="system file"):
        lash.run(system, channels=["joint.contact_force"])


def test_sweeps_from_a_dict_or_a_design_table_and_merged_shards(tmp_path):
    design = {
        "clearances[0].bearing_radius": np.array([0.01005, 0.0101, 0.01002]),
        "drivers[0].motion.omega": [450.0, 500.0, 523.6],
    }
    output = {"channels": ["slider.ax"], "sample_rate": 10000.0}
    report = lash.design_sweep("A", design, tmp_path / "design", output=output, horizon=0.01)
    assert report["runs"] == 3 and report["failed"] == 0
    data = lash.Dataset(tmp_path / "design")
    np.testing.assert_array_equal(data.inputs, np.column_stack([design[p] for p in data.parameters]))
    # Row i is the run of design row i.
    values = dict(zip(data.parameters, data.inputs[1]))
    values["simulation.output_interval"] = 1e-4
    single = lash.run(lash.load("A").with_values(values), "reduced", horizon=0.01)
    np.testing.assert_array_equal(data.values[1, :, 0], single["slider.ax"])
    # The same sweep as a dict, run as two shards and merged: the one-machine dataset.
    spec = {
        "base": "A",
        "sampling": "rows",
        "horizon": 0.01,
        "output": output,
        "parameters": [{"path": p, "values": list(map(float, v))} for p, v in design.items()],
    }
    for i in (0, 1):
        lash.sweep(spec, tmp_path / f"shard{i}", shard=f"{i}/2")
    rows = lash.merge([tmp_path / "shard0", tmp_path / "shard1"], tmp_path / "merged")
    merged = lash.Dataset(tmp_path / "merged")
    assert rows == 3 * 101 and np.array_equal(merged.values, data.values)
    with pytest.raises(lash.ScenarioError, match="parameters\\[1\\].values"):
        lash.design_sweep("A", {"clearances[0].bearing_radius": [0.0101, 0.0102], "drivers[0].motion.omega": [500.0]},
                          tmp_path / "uneven", output=output)


def test_compare_and_report_equal_the_command_line(tmp_path):
    # lash.compare writes what `lash compare` writes (the comparison's runs bit for bit, timing
    # aside) and its page; lash.report writes a run's page; a missing or empty folder is refused.
    result = lash.compare("A", tmp_path / "py", horizon=0.012, report=True)
    assert result["scenario"] == "A" and result["clearances"][0]["joint"] == "crank_pivot"
    assert cli("compare", "A", "--horizon", "0.012", "--out", str(tmp_path / "cli"), "--quiet").returncode == 0
    for model in ("full", "reduced", "ideal"):
        py_header, py_rows = read_csv(tmp_path / "py" / model / "timeseries.csv")
        cli_header, cli_rows = read_csv(tmp_path / "cli" / model / "timeseries.csv")
        assert py_header == cli_header and np.array_equal(py_rows, cli_rows)
    page = tmp_path / "py" / "report.html"
    text = page.read_text()
    assert "crank_pivot" in text and "<canvas" in text
    assert cli("run", "A", "--horizon", "0.012", "--out", str(tmp_path / "run"), "--quiet").returncode == 0
    written = lash.report(tmp_path / "run", out=tmp_path / "run.html")
    assert written == str(tmp_path / "run.html") and os.path.getsize(written) > 10_000
    with pytest.raises(FileNotFoundError):
        lash.report(tmp_path / "nothing-here")
    (tmp_path / "empty").mkdir()
    with pytest.raises(lash.ScenarioError, match="summary.json"):
        lash.report(tmp_path / "empty")


def test_compare_holds_the_bounds_against_realisations_as_the_command_line(tmp_path):
    # realisations=2: the bounds against two converged realisations of the full model, the same
    # figures as `lash compare --realisations 2`; 0 realisations is refused, naming the field.
    result = lash.compare("B", tmp_path / "py", horizon=0.05, report=False, realisations=2)
    done = cli("compare", "B", "--horizon", "0.05", "--realisations", "2", "--out", str(tmp_path / "cli"), "--quiet")
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "cli" / "comparison.json") as f:
        written = json.load(f)
    assert result["realisations"]["count"] == 2
    assert result["realisations"]["checks"] == written["realisations"]["checks"]
    with pytest.raises(lash.ScenarioError, match="realisations"):
        lash.compare("A", tmp_path / "none", horizon=0.012, report=False, realisations=0)
