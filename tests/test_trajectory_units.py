"""CSV trajectories carry their units: the line after the header is ``#`` and each
column's unit, which readers that skip ``#`` lines (NumPy, pandas) pass over."""

from __future__ import annotations

import contextlib
import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest

from vsw.cli import main
from vsw.dynamics.trajectories import read_csv_units
from vsw.runtime.errors import VswInputError


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[Path, dict]:
    path = tmp_path_factory.mktemp("units") / "walk.csv"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["simulate", "--model", "rimless-wheel", "--steps", "2", "--trajectory",
                     str(path), "--rate", "50", "--json"])  # fmt: skip
    assert code == 0
    return path, json.loads(out.getvalue())["trajectory"]


def test_the_second_line_is_every_columns_unit(written):
    path, report = written
    header, units_line = path.read_text().splitlines()[:2]
    assert units_line.startswith("#")
    units = read_csv_units(path)
    assert list(units) == header.split(",")
    assert units == report["units"]
    assert units["t"] == "s" and units["theta"] == "rad" and units["theta_dot"] == "rad/s"
    assert units["energy"] == "J/kg" and units["step"] == "1" and units["event"] == ""


def test_numpy_reads_the_data_past_the_units(written):
    path, report = written
    data = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding=None)
    assert len(data) == report["rows"]
    body = [r for r in csv.reader(path.read_text().splitlines()[1:]) if not r[0].startswith("#")]
    assert len(body) == report["rows"]
    assert np.array_equal(data["t"], [float(r[0]) for r in body])
    assert np.array_equal(data["theta"], [float(r[3]) for r in body])
    plain = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1), comments="#")
    assert plain.shape == (report["rows"], 2)


def test_pandas_reads_the_data_past_the_units(written):
    pandas = pytest.importorskip("pandas")
    path, report = written
    frame = pandas.read_csv(path, comment="#")
    assert len(frame) == report["rows"] and frame["t"].dtype == float
    assert list(frame.columns) == list(read_csv_units(path))


def test_a_file_without_the_units_line_is_refused(tmp_path):
    path = tmp_path / "plain.csv"
    path.write_text("t,theta\n0.0,0.1\n")
    with pytest.raises(VswInputError, match="units"):
        read_csv_units(path)
