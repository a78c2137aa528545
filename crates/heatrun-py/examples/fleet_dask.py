"""A fleet on a local Dask cluster: every recording of a folder (or an object-store prefix)
replayed on the cluster's workers, the reports gathered into the fleet table, and the
fleet compared.

    python crates/heatrun-py/examples/fleet_dask.py FOLDER [--workers 2] [--out fleet-summary.csv]
        [--compare] [--timing]

Each task replays one recording (``heatrun.replay``, without traces) and returns its report
as JSON text, a few kB: the workers never send a recording's series back. The table is the
library's reduction (``heatrun.fleet_summary``), the same ``fleet-summary.csv`` that
``heatrun replay FOLDER --out-dir OUT`` and ``heatrun fleet summary OUT`` write for the same
recordings. ``--timing`` also replays the fleet on a cluster of one worker and prints both
wall times and their ratio.

The workers are processes (one thread each): a replay holds no GIL, but one process per
worker is how a Dask deployment on several machines runs, and the same code runs there
with ``Client("scheduler-address")`` in place of the LocalCluster. One replay already
works on every core it may use (the reader's decoders, rc's two starts, the analysis
beside the network's refit), so on a machine of few cores more workers than one add
little; ``--one-core-per-worker`` holds each worker to a core of its own, as a cluster
allots them.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import List, Tuple

import heatrun


def replay_to_json(path: str, one_core: bool = False) -> Tuple[str, str]:
    """One task: the recording's report as JSON text, or the one-line reason it failed
    (a fleet goes on past a bad recording, as ``heatrun replay FOLDER`` does).

    ``one_core``: the task's thread (and the threads the replay starts, which inherit it)
    held to the worker's own core, worker i on core i: a worker is then one core, as a
    cluster's scheduler allots them (Linux only)."""
    if one_core:
        from distributed import get_worker

        cores = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cores[int(get_worker().name) % len(cores)]})
    try:
        return ("ok", heatrun.replay(path, traces=False).to_json())
    except heatrun.HeatrunError as e:
        return ("failed", f"{path}: {e}")


def replay_fleet(
    paths: List[str], workers: int, one_core: bool = False
) -> Tuple[List[Tuple[str, str]], float]:
    """Replays `paths` on a local cluster of `workers` processes; returns the tasks'
    results in the fleet's order and the wall time of the replays (the cluster's start
    not counted)."""
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True) as cluster, Client(
        cluster
    ) as client:
        client.wait_for_workers(workers)
        started = time.perf_counter()
        futures = client.map(replay_to_json, paths, one_core=one_core, pure=False)
        results = client.gather(futures)
        return results, time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", help="a folder of .mcap recordings, or an object-store prefix ending in /")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="fleet-summary.csv", help="the fleet table (CSV)")
    parser.add_argument("--compare", action="store_true", help="also run the fleet comparison")
    parser.add_argument("--timing", action="store_true", help="also time the fleet on one worker")
    parser.add_argument(
        "--one-core-per-worker",
        action="store_true",
        help="hold each worker to a core of its own (a replay otherwise spreads over every core)",
    )
    args = parser.parse_args()

    paths = heatrun.list_recordings(args.folder)
    if not paths:
        print(f"heatrun: {args.folder}: no .mcap recordings there", file=sys.stderr)
        return 2
    results, seconds = replay_fleet(paths, args.workers, args.one_core_per_worker)
    reports = [text for status, text in results if status == "ok"]
    for status, text in results:
        if status != "ok":
            print(f"warning: {text}", file=sys.stderr)
    table = heatrun.fleet_summary(reports)
    with open(args.out, "w", encoding="utf-8") as f:
        f.write(table.attrs["csv"])
    print(table.attrs["text"], end="")
    print(f"{len(paths)} recordings on {args.workers} workers in {seconds:.2f} s; table in {args.out}")
    if args.timing:
        _, one = replay_fleet(paths, 1, args.one_core_per_worker)
        print(
            f"timing: 1 worker {one:.2f} s, {args.workers} workers {seconds:.2f} s, "
            f"ratio {seconds / one:.3f}"
        )
    if args.compare:
        if len(reports) < 3:
            print("fleet compare: needs three reports or more", file=sys.stderr)
        else:
            print(heatrun.fleet_compare(reports, labels=[p for p, (s, _) in zip(paths, results) if s == "ok"])["summary"], end="")
    return 0 if len(reports) == len(paths) else 1


if __name__ == "__main__":
    sys.exit(main())
