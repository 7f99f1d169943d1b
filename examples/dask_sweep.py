"""Run a lash sweep on a Dask cluster: one Dask task per shard, then `lash sweep merge`.

    python examples/dask_sweep.py examples/sweep-lhs.toml --out out/lhs --shards 8 \
        [--scheduler tcp://scheduler:8786 | --local-workers 2] [--lash target/release/lash]

Each task runs `lash sweep <file> --shard i/N --out <out>/shards/i-of-N` on a worker (one lash
thread per task: Dask provides the parallelism) and returns the folder; the client merges the
folders into <out>/merged, which equals a single-machine `lash sweep` of the same file. With a
real cluster, <out> must be on a file system every worker and the client see (NFS, Lustre…), and
`lash` must be installed on the workers. A task that dies is resubmitted by Dask; the shard
folder it left behind resumes (lash skips runs already complete).
"""

import argparse
import os
import subprocess
import sys


def run_shard(lash, sweep, out, index, count):
    folder = os.path.join(out, "shards", f"{index}-of-{count}")
    proc = subprocess.run(
        [lash, "sweep", sweep, "--out", folder, "--shard", f"{index}/{count}", "--threads", "1", "--quiet"],
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        raise RuntimeError(f"shard {index}/{count} failed (exit {proc.returncode}): {proc.stderr.strip()}")
    return folder


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", help="the sweep file")
    parser.add_argument("--out", required=True, help="output folder (shards/ and merged/ inside)")
    parser.add_argument("--shards", type=int, default=4, help="number of shards (Dask tasks)")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler")
    parser.add_argument("--local-workers", type=int, default=2, help="workers of a LocalCluster (no --scheduler)")
    parser.add_argument("--lash", default="lash", help="path of the lash binary")
    args = parser.parse_args()
    if args.shards < 1:
        parser.error("--shards must be ≥ 1")

    from dask.distributed import Client, LocalCluster

    sweep = os.path.abspath(args.sweep)
    out = os.path.abspath(args.out)
    lash = os.path.abspath(args.lash) if os.path.sep in args.lash else args.lash
    if args.scheduler:
        client = Client(args.scheduler)
        cluster = None
    else:
        cluster = LocalCluster(n_workers=args.local_workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    try:
        n = args.shards
        futures = client.map(run_shard, [lash] * n, [sweep] * n, [out] * n, range(n), [n] * n, pure=False)
        folders = client.gather(futures)
        workers = len(client.scheduler_info()["workers"])
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    merged = os.path.join(out, "merged")
    proc = subprocess.run([lash, "sweep", "merge", *folders, "--out", merged], capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(f"merge failed: {proc.stderr.strip()}")
    print(f"{n} shards on {workers} Dask workers → {merged}")


if __name__ == "__main__":
    main()
