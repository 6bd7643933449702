"""Case 11: basins of attraction on a grid (vsw.studies.grid_basin) in-process and on a
Dask cluster, and the `vsw basin` command against the library call it makes."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from harness import ROOT, Row, interleaved, peak_alloc_mb, timed


def _basin_grid(side: int):
    """The simplest walker's basin at gamma = 0.009 over theta x theta_dot just after
    heelstrike (phi and phi_dot from the section), the region around its thin band."""
    return np.linspace(-0.36, -0.1, side), np.linspace(0.1, 0.4, side)


def case_basin_grid(side: int, reps: int) -> list[Row]:
    """Case 11: a side x side basin of the simplest walker at gamma = 0.009, up to 50 steps
    a cell (stopping on convergence or a fall), by ``grid_basin`` as ``vsw basin --grid``
    runs it, its stable gait found before (the gait search is case 12's: about 12 s here):
    in-process threads (every core), and on a Dask LocalCluster of two worker processes
    with one thread each (started before timing; each side warmed up once)."""
    from distributed import LocalCluster

    from vsw.dynamics.batch import simulator
    from vsw.models import load
    from vsw.runtime.threads import default_threads
    from vsw.studies.cluster import runner
    from vsw.studies.grid_basin import grid_basin

    m = load("simplest_walker")
    params = m.parameters({"gamma": 0.009})
    x, y = _basin_grid(side)
    simulator(load("simplest_walker")).library()
    gait = m.stable_gait(params, "no basin")
    found = {}

    def local():
        found["local"] = grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait)

    peak = peak_alloc_mb(local)
    t_local = timed(local, reps)
    counts = found["local"].counts()
    steps = int(found["local"].steps.sum())
    rows = [Row(
        "11", f"basin {side} x {side}, simplest walker (vsw.studies.grid_basin, "
        f"{default_threads()} threads)", "-", t_local, None, "<= 60 s",
        t_local.median <= 60,
        note=f"{steps} steps walked ({t_local.median / steps * 1e6:.1f} us a step); classes "
        f"{counts}", subject_peak_mb=peak,
    )]  # fmt: skip
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:  # fmt: skip
        address = cluster.scheduler_address

        def remote():
            found["remote"] = grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait,
                                         runner=runner(address, m.name))  # fmt: skip

        t_remote, t_local = interleaved(remote, local, reps)
    same = found["remote"].to_dict() == found["local"].to_dict()
    ratio = t_remote.median / t_local.median
    rows.append(Row(
        "11", "the same basin on a Dask LocalCluster (2 workers x 1 thread)",
        f"in-process threads ({default_threads()})", t_remote, t_local, "<= 1.3x the local time",
        ratio <= 1.3, note=f"results identical: {same}; cluster start-up not timed",
    ))  # fmt: skip
    # the CLI's target is for 200 x 200 (the quick mode's 20 x 20 only runs it)
    return rows + _compass_gait_basin(side, reps) + _cli_basin_cost(min(side, 200), reps)


def _compass_gait_basin(side: int, reps: int) -> list[Row]:
    """Case 11: a side x side basin of the compass gait (its section declares
    psi = -theta) around its stable gait at the defaults, over theta x theta_dot just
    after heelstrike (psi_dot the gait's), up to 50 steps a cell, in-process threads."""
    from vsw.models import load
    from vsw.runtime.threads import default_threads
    from vsw.studies.grid_basin import grid_basin

    m = load("compass_gait")
    params = m.parameters()
    gait = m.stable_gait(params, "no basin")
    x, y = np.linspace(-0.5, -0.15, side), np.linspace(0.8, 1.7, side)
    found = {}

    def basin():
        found["basin"] = grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait)

    t = timed(basin, reps)
    steps = int(found["basin"].steps.sum())
    return [Row(
        "11", f"basin {side} x {side}, compass gait (vsw.studies.grid_basin, {default_threads()} "
        "threads)", "-", t, None, "measured", None,
        note=f"{steps} steps walked ({t.median / steps * 1e6:.1f} us a step); classes "
        f"{found['basin'].counts()}",
    )]  # fmt: skip


CLI_BASINS = (
    ("compass_gait", "compass-gait", {}, (-0.5, -0.15), (0.8, 1.7)),
    ("simplest_walker", "simplest-walker", {"gamma": 0.009}, (-0.36, -0.1), (0.1, 0.4)),
)
"""The basins whose `vsw basin` command case 11 times against the library call: model,
CLI name, parameters, theta range, theta_dot range (the grids of the basins above)."""


def _cli_basin_cost(side: int, reps: int) -> list[Row]:
    """Case 11: `vsw basin --grid` (a whole process: start, imports, kernel load,
    gait search, the basin, text output) against the library call it makes
    (``grid_basin`` with the gait known and the kernel loaded, in this process), alternately.
    The target, 1.3x, is for a 200 x 200 basin; on the simplest walker the basin
    itself takes about 0.1 s, less than an interpreter's start with numpy."""
    from vsw.models import load
    from vsw.studies.grid_basin import grid_basin

    rows = []
    for name, cli, values, (x0, x1), (y0, y1) in CLI_BASINS:
        m = load(name)
        params = m.parameters(values)
        gait = m.stable_gait(params, "no basin")
        x, y = np.linspace(x0, x1, side), np.linspace(y0, y1, side)
        command = [sys.executable, "-m", "vsw", "basin", "--model", cli,
                   *(f"--param={k}={v!r}" for k, v in values.items()),
                   f"--grid=theta={x0!r}:{x1!r}:{side}", f"--grid=theta_dot={y0!r}:{y1!r}:{side}",
                   "--steps", "50"]  # fmt: skip

        def process(command=command):
            subprocess.run(command, cwd=ROOT, check=True, capture_output=True)

        def library(m=m, params=params, x=x, y=y, gait=gait):
            grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait)

        t_cli, t_library = interleaved(process, library, reps)
        ratio = t_cli.median / t_library.median
        rows.append(Row(
            "11", f"vsw basin --model {cli}, {side} x {side} (a whole process: start, imports, "
            "kernel load, gait search, text output)",
            "the library call: grid_basin, gait known, kernel loaded", t_cli, t_library,
            "<= 1.3x the library call", ratio <= 1.3,
        ))  # fmt: skip
    return rows
