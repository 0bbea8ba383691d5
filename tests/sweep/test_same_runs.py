"""A sweep point is the single command, bit for bit; a Dask cluster gives the same table.

One small calibrate-bias sweep (2 noise levels x 2 seeds) runs on local processes;
point 3 is rerun as ``inins calibrate-bias BASE --set ... --seed ...`` and must give
the same numbers to the last bit; the same sweep on a real Dask scheduler with two
worker processes on loopback must give the same table, point for point.
"""

import json

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from inins.cli import app
from inins.io.sweep_files import read_table_h5
from inins.sweep.engine import run_sweep
from inins.sweep.plan import load_sweep
from tests.sweep.conftest import TINY_CALIBRATE, write_sweep

ARW = [0.0005, 0.001]
SEEDS = [11, 12]


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory, pool):
    folder = tmp_path_factory.mktemp("cal")
    path = write_sweep(
        folder,
        command="calibrate-bias",
        base=str(TINY_CALIBRATE),
        grid={"simulate.imu.gyro.arw_deg_rth": ARW},
        seeds=SEEDS,
    )
    plan = load_sweep(path)
    outcome = run_sweep(plan, folder / "local", pool, keep_runs=True)
    return path, folder, outcome


def _datasets(path):
    out = {}

    def keep(name, node):
        if isinstance(node, h5py.Dataset):
            out[name] = node[()]

    with h5py.File(path, "r") as h5:
        h5.visititems(keep)
    return out


def test_a_point_is_the_single_command_bit_for_bit(local_sweep, tmp_path):
    _, folder, outcome = local_sweep
    assert outcome.errors == 0 and len(outcome.table.records) == 4
    single = tmp_path / "single"
    args = ["calibrate-bias", str(TINY_CALIBRATE), "-o", str(single)]
    args += ["--set", f"simulate.imu.gyro.arw_deg_rth={ARW[1]}", "--seed", str(SEEDS[1])]
    run = CliRunner().invoke(app, args)
    assert run.exit_code == 0, run.output
    summary = json.loads((single / "summary.json").read_text())
    record = outcome.table.records[3]
    assert record["seed"] == SEEDS[1] and record["results"] == summary["results"]
    # the table: HDF5 float64 and CSV text hold the same doubles
    table = read_table_h5(folder / "local" / "sweep.h5")
    for name, value in summary["results"].items():
        if value is not None:
            assert table[f"results/{name}"][3] == value, name
    header, *rows = (folder / "local" / "sweep.csv").read_text().splitlines()
    cells = dict(zip(header.split(","), rows[3].split(","), strict=False))
    assert float(cells["beta_y_dph"]) == summary["results"]["beta_y_dph"]
    # --keep-runs: the point's own outputs equal the single command's
    kept = folder / "local" / "runs" / "p00003"
    assert (kept / "summary.json").read_text() == (single / "summary.json").read_text()
    mine, theirs = _datasets(kept / "calibrate-bias.h5"), _datasets(single / "calibrate-bias.h5")
    assert mine.keys() == theirs.keys() and len(mine) > 5
    for name, data in theirs.items():
        np.testing.assert_array_equal(mine[name], data, err_msg=name)


def test_seeds_and_noise_change_the_estimates(local_sweep):
    _, _, outcome = local_sweep
    beta = outcome.table.result("beta_y_dph")
    assert len(set(beta.tolist())) == 4  # every point its own noise
    sigma = outcome.table.result("beta_y_sigma_dph")
    # the reported 1-sigma scales with the ARW (sigma_beta ~ ARW / sqrt(T)), not the seed
    assert sigma[2] / sigma[0] == pytest.approx(2.0, rel=1e-3)
    assert sigma[1] == pytest.approx(sigma[0], rel=1e-3)


@pytest.mark.slow
def test_dask_cluster_on_loopback_gives_the_same_table(local_sweep, tmp_path):
    import distributed  # the cluster extra is part of dev: these tests run in make test

    from inins.sweep.executors import DaskExecutor

    path, _, local = local_sweep
    plan = load_sweep(path)
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        silence_logs=50,
    ) as cluster:
        remote = run_sweep(
            plan, tmp_path / "dask", DaskExecutor(cluster.scheduler_address, plan.command)
        )
    assert remote.errors == 0 and len(remote.table.records) == 4
    for mine, theirs in zip(remote.table.records, local.table.records, strict=True):
        assert (mine["key"], mine["seed"], mine["status"]) == (
            theirs["key"],
            theirs["seed"],
            theirs["status"],
        )
        assert mine["results"] == theirs["results"]
        assert mine["checks"] == theirs["checks"]


def test_unreachable_scheduler_is_bad_input():
    from inins.exceptions import InputError
    from inins.sweep.executors import DaskExecutor

    executor = DaskExecutor("tcp://127.0.0.1:9", "calibrate-bias", timeout_s=1.0)
    with pytest.raises(
        InputError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9"
    ):
        executor.__enter__()
