"""Reads a lash sweep dataset back with pyarrow and pandas and checks it; optionally compares it
with a second dataset (which must hold the same table values).

    python check_dataset.py <dir> [<other dir>]
"""

import json
import os
import sys

import pandas as pd
import pyarrow.parquet as pq


def check(folder):
    manifest = json.load(open(os.path.join(folder, "manifest.json")))
    assert manifest["status"] == "complete", manifest["status"]
    data = pq.read_table(os.path.join(folder, "data.parquet"))
    params = pq.read_table(os.path.join(folder, "params.parquet"))
    channels = [c["name"] for c in manifest["channels"]]
    assert data.column_names == ["run_id", "t"] + channels, data.column_names
    for c in manifest["channels"]:
        unit = data.schema.field(c["name"]).metadata[b"unit"].decode()
        assert unit == c["unit"], (c, unit)
    assert params.column_names == ["run_id", "seed", "status"] + manifest["parameters"] + ["error"], params.column_names
    for path in manifest["parameters"]:
        assert b"unit" in (params.schema.field(path).metadata or {}), f"{path} has no unit"
    df = pd.read_parquet(os.path.join(folder, "data.parquet"))
    rows = df.groupby("run_id").size().to_dict()
    for r in manifest["runs"]:
        assert rows.get(r["run_id"], 0) == r["rows"], (r, rows.get(r["run_id"]))
    p = pd.read_parquet(os.path.join(folder, "params.parquet"))
    assert list(p["run_id"]) == sorted(p["run_id"]), "params not in run order"
    assert list(df["run_id"]) == sorted(df["run_id"]), "data not in run order"
    ok = set(p.loc[p["status"] == "ok", "run_id"])
    assert ok == set(rows), (ok, set(rows))
    failed = p[p["status"] == "failed"]
    assert (failed["error"] != "").all() and (p.loc[p["status"] == "ok", "error"] == "").all(), "errors"
    errors = {r["run_id"]: r.get("error") or "" for r in manifest["runs"]}
    assert all(errors[i] == e for i, e in zip(p["run_id"], p["error"])), "params errors differ from the manifest's"
    assert df[channels].notna().all().all(), "NaN in the data"
    return data, params, df


if __name__ == "__main__":
    a = check(sys.argv[1])
    print(f"{sys.argv[1]}: {a[2].shape[0]} rows, {a[1].num_rows} runs, channels {a[0].column_names[2:]}")
    if len(sys.argv) > 2:
        b = check(sys.argv[2])
        assert a[0].equals(b[0]), "data tables differ"
        assert a[1].equals(b[1]), "params tables differ"
        print(f"{sys.argv[2]}: equal tables")
