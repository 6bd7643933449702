"""The ``vsw`` command line in a hostile world: closed pipes, unwritable outputs, infinite
and huge arguments, bad ``VSW_*`` settings, work that would not fit, and its words and units.
Each defect such input once found has a test here; tests/test_cli_fuzz.py drives every
subcommand with generated arguments."""

from __future__ import annotations

import io
import json
import math
import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from vsw import cli
from vsw.cli import EXIT_CLOSED_PIPE, main
from vsw.runtime import limits

ROOT = Path(__file__).resolve().parents[1]
ANALYZE = ["analyze", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45"]
SIMULATE = ["simulate", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45", "--q0", "0.3"]
BASIN = ["basin", "--beta", "0.8", "--phi0", "45"]
SMALL_BASIN = [*BASIN, "--theta-step", "10", "--n-q", "51"]


def run_main(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code, out, err, *words):
    assert code == 2, err
    assert out == ""
    assert err.count("\n") == 1 and err.endswith("\n") and "Traceback" not in err, err
    for word in words:
        assert word in err, err


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("VSW_MAX")}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.update(extra)
    return env


def spawn(argv, **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "vsw", *argv], cwd=ROOT, env=_env(), stderr=subprocess.PIPE, **kw
    )


# --- standard output -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv", [[*ANALYZE, "--json"], SMALL_BASIN, ["--help"]], ids=["analyze", "basin", "help"]
)
def test_closed_pipe_is_quiet_and_exits_141(argv):
    # The reader goes away before vsw writes: every write (and the final flush) hits EPIPE.
    proc = spawn(argv, stdout=subprocess.PIPE)
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == EXIT_CLOSED_PIPE == 141
    assert err == b""  # no traceback, no "Exception ignored", no message


def test_closed_pipe_in_the_middle_of_a_long_output_is_quiet():
    # 10000 lines (0.5 MB) of output, a reader that takes one line: `vsw basin ... | head -1`.
    argv = [*BASIN, "--theta-min", "-1", "--theta-max", "1", "--theta-step", "0.0002"]
    proc = spawn([*argv, "--n-q", "3"], stdout=subprocess.PIPE)
    first = proc.stdout.readline()
    proc.stdout.close()
    err = proc.stderr.read()
    assert first.startswith(b"basin of attraction")
    assert proc.wait(timeout=120) == EXIT_CLOSED_PIPE
    assert err == b""


def test_closed_pipe_in_the_middle_of_a_long_json_output_is_quiet():
    # About 0.8 MB of JSON and a reader that takes 100 bytes (`vsw basin ... --json | head
    # -c 100`): exit 141 as the text output, not 0 with the output cut.
    argv = [*BASIN, "--theta-min", "-1", "--theta-max", "1", "--theta-step", "0.0005"]
    proc = spawn([*argv, "--n-q", "3", "--json"], stdout=subprocess.PIPE)
    first = proc.stdout.read(100)
    proc.stdout.close()
    err = proc.stderr.read()
    assert first.startswith(b"{")
    assert proc.wait(timeout=120) == EXIT_CLOSED_PIPE
    assert err == b""


def test_closed_stdout_is_one_line_exit_2():
    proc = subprocess.run(
        ["bash", "-c", f'exec "{sys.executable}" -m vsw "$@" >&-', "vsw", *ANALYZE, "--json"],
        cwd=ROOT,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "standard output is closed" in proc.stderr


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_full_disk_on_stdout_is_one_line_exit_2():
    with open("/dev/full", "w") as full:
        proc = spawn([*ANALYZE, "--json"], stdout=full)
        err = proc.stderr.read().decode()
        assert proc.wait(timeout=120) == 2
    assert err.count("\n") == 1 and "No space left on device" in err, err


class _FailingStdout(io.StringIO):
    def __init__(self, error: OSError) -> None:
        super().__init__()
        self.error = error

    def write(self, text: str) -> int:
        raise self.error


@pytest.mark.parametrize("command", [[*ANALYZE, "--json"], SMALL_BASIN, ["--version"]])
def test_stdout_errors_are_handled_in_main_for_every_command(monkeypatch, capsys, command):
    monkeypatch.setattr(sys, "stdout", _FailingStdout(BrokenPipeError(32, "Broken pipe")))
    assert main(command) == EXIT_CLOSED_PIPE
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(sys, "stdout", _FailingStdout(OSError(28, "No space left on device")))
    assert main(command) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write standard output" in err


def test_stdout_handling_covers_every_command_module(monkeypatch, capsys):
    # A command module added to the CLI gets the same handling.
    import types

    import vsw.cli.app as app

    fake = types.ModuleType("vsw.cli.fake_out")

    def register(subparsers):
        p = subparsers.add_parser("shout")
        p.set_defaults(func=lambda args: print("x" * 100) or 0)

    fake.register = register
    monkeypatch.setitem(sys.modules, fake.__name__, fake)
    monkeypatch.setattr(app, "COMMANDS", {**app.COMMANDS, "shout": fake.__name__})
    stream = _FailingStdout(BrokenPipeError(32, "Broken pipe"))
    monkeypatch.setattr(sys, "stdout", stream)
    assert main(["shout"]) == EXIT_CLOSED_PIPE
    assert sys.stdout is stream  # restored after the run
    assert capsys.readouterr().err == ""


def test_stdout_closed_in_process(monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdout", None)
    assert main(ANALYZE) == 2
    assert "standard output is closed" in capsys.readouterr().err


# --- plot files ------------------------------------------------------------------------------


def _plot_cases(tmp_path: Path) -> list[tuple[str, str]]:
    (tmp_path / "x.png").mkdir(parents=True)
    return [
        ("/proc/fig9.png", "cannot be written"),  # FileNotFoundError at save time before
        ("/sys/sim.png", "cannot be written"),  # PermissionError
        (str(tmp_path / "x.png"), "is a directory"),  # IsADirectoryError
        ("", "plot file name is empty"),
        (" ", "plot file name is empty"),
        (str(tmp_path / "fig.txt"), "must end in one of"),
        (str(tmp_path / "missing" / "fig.png"), "does not exist"),
    ]


@pytest.mark.parametrize("command", [SMALL_BASIN, [*SIMULATE, "--steps", "2"]])
def test_unwritable_plot_is_one_line_exit_2_before_any_work(capsys, tmp_path, command):
    for path, words in _plot_cases(tmp_path / command[0]):
        code, out, err = run_main(capsys, [*command, "--plot", path])
        assert_one_line_error(code, out, err, words)
    assert not (tmp_path / command[0] / "fig.png").exists()


def test_plot_check_leaves_no_file_behind_and_keeps_existing_ones(tmp_path):
    from vsw.plots.figures import check_save_path

    fresh = tmp_path / "new.png"
    check_save_path(fresh)
    assert not fresh.exists()
    old = tmp_path / "old.svg"
    old.write_text("keep")
    check_save_path(old)
    assert old.read_text() == "keep"


def test_plot_write_failure_after_the_check_is_one_line(monkeypatch, capsys, tmp_path):
    import vsw.cli.ile_basin  # the ile's closed-form basin (SMALL_BASIN) saves there

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device", str(tmp_path / "b.png"))

    monkeypatch.setattr(vsw.cli.ile_basin, "save_figure", full)
    code, _, err = run_main(capsys, [*SMALL_BASIN, "--plot", str(tmp_path / "b.png")])
    assert code == 2 and err.count("\n") == 1 and "No space left on device" in err


# --- basin theta arguments ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "extra, words",
    [
        (["--theta-max", "inf"], "--theta-max = inf must be finite"),
        (["--theta-max", "1e999"], "--theta-max = inf must be finite"),
        (["--theta-min=-inf"], "--theta-min = -inf must be finite"),
        (["--theta-step", "inf"], "--theta-step = inf must be finite"),
        (["--theta-step", "nan"], "--theta-step = nan must be finite"),
        (["--theta-step", "5e-324"], "more than 100000 theta_II values"),
        (["--theta-step", "-1"], "must be > 0"),
        (["--theta-min", "10", "--theta-max", "0"], "must not exceed --theta-max"),
        (["--theta-min", "-100"], "(-90, 90) deg"),
        (["--n-q", "2"], "--n-q = 2 must be >= 3"),
        (["--check-edges", "-1"], "--check-edges = -1"),
    ],
)
def test_basin_theta_arguments(capsys, extra, words):
    with np.errstate(all="raise"):  # and no numpy warning on the way
        code, out, err = run_main(capsys, [*BASIN, *extra])
    assert_one_line_error(code, out, err, words)


def test_basin_huge_theta_step_gives_one_row(capsys):
    code, out, err = run_main(capsys, [*BASIN, "--theta-step", "1e300", "--n-q", "11", "--json"])
    assert code == 0 and err == ""
    assert json.loads(out)["theta_II_deg"] == [pytest.approx(-30.0, rel=1e-15)]


# --- VSW_THREADS: one rule everywhere ----------------------------------------------------------


@pytest.mark.parametrize("setting", ["0", "-1", "abc", "2.5", "100000"])
@pytest.mark.parametrize(
    "argv", [ANALYZE, SMALL_BASIN, [*SIMULATE, "--steps", "1"]], ids=["analyze", "basin", "sim"]
)
def test_invalid_vsw_threads_is_rejected_by_every_command(monkeypatch, capsys, setting, argv):
    monkeypatch.setenv("VSW_THREADS", setting)
    code, out, err = run_main(capsys, argv)
    assert_one_line_error(code, out, err, "VSW_THREADS", repr(setting))


@pytest.mark.parametrize("size", [1, 10, 40_000])
def test_invalid_vsw_threads_is_rejected_by_the_library_at_any_size(monkeypatch, size):
    from generated import ile
    from vsw.models.ile.analysis import analyze
    from vsw.runtime.errors import VswInputError
    from vsw.runtime.vectorize import chunked

    monkeypatch.setenv("VSW_THREADS", "0")
    beta = np.full(size, 0.8)
    with pytest.raises(VswInputError, match="VSW_THREADS"):
        analyze(beta, 0.0, math.pi / 4)
    with pytest.raises(VswInputError, match="VSW_THREADS"):
        chunked(ile.q_fixed, beta, 0.0, math.pi / 4)
    from vsw.models.ile import kernels

    with pytest.raises(VswInputError, match="VSW_THREADS"):
        kernels.fixed_point_conditions(beta, 0.0, math.pi / 4)


def test_valid_vsw_threads_still_work(monkeypatch, capsys):
    monkeypatch.setenv("VSW_THREADS", " 1 ")
    code, out, _ = run_main(capsys, [*ANALYZE, "--json"])
    assert code == 0 and json.loads(out)["walks"] is True


# --- limits ----------------------------------------------------------------------------------


def test_simulate_a_billion_steps_is_refused_at_once(monkeypatch, capsys):
    code, out, err = run_main(capsys, [*SIMULATE, "--steps", "1000000000"])
    assert_one_line_error(code, out, err, "simulating 1000000000 steps", "--steps")
    assert "VSW_MAX_MEMORY" in err or "VSW_MAX_SECONDS" in err
    monkeypatch.setenv("VSW_MAX_MEMORY", "inf")  # then the time limit speaks
    code, out, err = run_main(capsys, [*SIMULATE, "--steps", "1000000000"])
    assert_one_line_error(code, out, err, "would take about", "days", "VSW_MAX_SECONDS")


def test_basin_huge_q_grid_is_refused_at_once(monkeypatch, capsys):
    # 141 x 10^8 grid points: 2 bytes each for the result is 28 GB (the issue saw 16 GB in
    # a minute); a memory limit of 1 GiB makes the refusal independent of this machine.
    monkeypatch.setenv("VSW_MAX_MEMORY", "1G")
    code, out, err = run_main(capsys, [*BASIN, "--n-q", "100000000"])
    assert_one_line_error(code, out, err, "141 theta_II x 100000000 q values", "--n-q")
    assert "more than the limit of 1 GiB (VSW_MAX_MEMORY)" in err


def test_basin_edge_checks_count_in_the_estimate(monkeypatch, capsys):
    monkeypatch.setenv("VSW_MAX_SECONDS", "1")
    code, out, err = run_main(capsys, [*SMALL_BASIN, "--check-edges", "5"])
    assert_one_line_error(code, out, err, "with 5 edge checks", "--check-edges")


def test_raising_the_limit_lets_the_work_run(monkeypatch, capsys):
    monkeypatch.setenv("VSW_MAX_SECONDS", "1e-9")
    code, _, err = run_main(capsys, [*SIMULATE, "--steps", "2"])
    assert code == 2 and "VSW_MAX_SECONDS" in err
    monkeypatch.setenv("VSW_MAX_SECONDS", "inf")
    code, out, err = run_main(capsys, [*SIMULATE, "--steps", "2", "--json"])
    assert code == 0 and json.loads(out)["steps_completed"] == 2


@pytest.mark.parametrize(
    "name, value",
    [
        ("VSW_MAX_MEMORY", "1x"),
        ("VSW_MAX_MEMORY", "-1G"),
        ("VSW_MAX_MEMORY", "nan"),
        ("VSW_MAX_SECONDS", "0"),
        ("VSW_MAX_SECONDS", "1G"),
        ("VSW_MAX_SECONDS", "abc"),
    ],
)
def test_invalid_limit_settings_are_bad_input(monkeypatch, capsys, name, value):
    monkeypatch.setenv(name, value)
    code, out, err = run_main(capsys, ANALYZE)
    assert_one_line_error(code, out, err, name, repr(value))


def test_limit_settings_parse(monkeypatch):
    monkeypatch.setenv("VSW_MAX_MEMORY", "16G")
    assert limits.max_memory() == (16 * 2**30, "VSW_MAX_MEMORY")
    monkeypatch.setenv("VSW_MAX_MEMORY", "512m")
    assert limits.max_memory()[0] == 512 * 2**20
    monkeypatch.setenv("VSW_MAX_MEMORY", "1000")
    assert limits.max_memory()[0] == 1000
    monkeypatch.setenv("VSW_MAX_MEMORY", "inf")
    assert limits.max_memory()[0] == math.inf
    monkeypatch.setenv("VSW_MAX_SECONDS", "2.5")
    assert limits.max_seconds() == 2.5
    monkeypatch.delenv("VSW_MAX_SECONDS")
    assert limits.max_seconds() == limits.DEFAULT_MAX_SECONDS


def test_default_memory_limit_follows_proc_meminfo(monkeypatch):
    monkeypatch.delenv("VSW_MAX_MEMORY", raising=False)
    if not os.path.exists("/proc/meminfo"):
        pytest.skip("no /proc/meminfo")
    with open("/proc/meminfo") as f:
        kib = next(int(line.split()[1]) for line in f if line.startswith("MemAvailable:"))
    limit, origin = limits.max_memory()
    # MemAvailable moves between the two reads: compare within 10 %.
    assert limit == pytest.approx(0.8 * kib * 1024, rel=0.1)
    assert "available" in origin


def test_basin_memory_estimate_covers_what_is_allocated():
    # tracemalloc sees every numpy allocation; the estimate must not be below the peak
    # (else the limit lets through what does not fit) nor far above it.
    from vsw.models.ile.basin import basin, basin_cost

    theta = np.radians([-2.0, 0.0, 5.0])
    for n_q in (40_001, 3_000):
        for threads in ("1", "2"):
            os.environ["VSW_THREADS"] = threads
            try:
                tracemalloc.start()
                basin(0.8, math.radians(45), theta, n_q=n_q, refine=False)
                _, peak = tracemalloc.get_traced_memory()
            finally:
                tracemalloc.stop()
                del os.environ["VSW_THREADS"]
            estimate = basin_cost(0.8, math.radians(45), 3, n_q, threads=int(threads)).nbytes
            assert peak <= estimate <= 10 * peak, (n_q, threads, peak, estimate)


def test_simulate_memory_estimate_covers_what_is_allocated():
    from vsw.models.ile.simulate import simulate, simulate_cost

    simulate(0.8, 0.0, math.pi / 4, 0.3, 1)  # imports SciPy outside the measurement
    for record in (False, True):
        tracemalloc.start()
        try:
            simulate(0.8, 0.0, math.pi / 4, 0.3, 30, record=record)
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        estimate = simulate_cost(30, record).nbytes
        assert peak <= estimate <= 10 * peak, (record, peak, estimate)


def test_long_q_rows_are_split_into_blocks(monkeypatch):
    # One row of 3 CHUNKs of q: evaluated blockwise equals one whole-array evaluation.
    from vsw.models.ile import basin as basin_module
    from vsw.runtime.vectorize import CHUNK

    beta, phi0, theta = 0.8, math.pi / 4, np.array([[0.0]])
    q = np.linspace(1e-3, 1.8, 3 * CHUNK + 5)[None, :]
    q_fixed = np.array([[0.465196]])
    ok = np.array([[True]])
    calls = []
    blockwise = basin_module.converges(
        beta, theta, phi0, q, 30, q_fixed, ok, tol=1e-4, progress=lambda d, t: calls.append(d)
    )
    whole = basin_module._converges_block(beta, theta, phi0, q, 30, q_fixed, ok, 1e-4)
    np.testing.assert_array_equal(blockwise, whole)
    assert blockwise.any() and not blockwise.all()
    assert sorted(calls) == [1, 2, 3, 4]  # 4 blocks, each reported once


def test_basin_progress_reaches_the_end_in_order():
    from vsw.models.ile.basin import basin

    calls = []
    theta = np.radians([0.0, 5.0, 10.0])
    basin(0.8, math.pi / 4, theta, n_q=40_001, progress=lambda d, t: calls.append((d, t)))
    done = [d for d, _ in calls]
    assert done == sorted(done) and len(set(t for _, t in calls)) == 1
    assert calls[-1][0] == calls[-1][1] == 9 + 60  # 3 rows x 3 blocks, then 60 bisections


# --- words and units ---------------------------------------------------------------------------


def test_help_lists_every_command_exit_status_and_limit(capsys):
    code, out, _ = run_main(capsys, ["--help"])
    assert code == 0
    for word in ("analyze", "simulate", "basin", "design", "141", "VSW_MAX_MEMORY", "VSW_THREADS"):
        assert word in out
    for status, meaning in cli.EXIT_STATUS.items():
        assert str(status) in out and meaning.split()[0] in out


@pytest.mark.parametrize(
    "command, shown",
    [
        ("basin", ["(default: 0.5)", "(default: 2001)", "(default: -30.0)"]),
        # registered by its own module: inherits it
        ("design", ["(default 2)", "(default 4)", "(default 0)"]),
    ],
)
def test_help_shows_defaults(capsys, command, shown):
    code, out, _ = run_main(capsys, [command, "--help"])
    assert code == 0
    for text in shown:
        assert text in out
    assert "(default: None)" not in out and "(default: False)" not in out


def test_version_from_package_metadata(capsys, monkeypatch):
    import importlib.metadata

    code, out, _ = run_main(capsys, ["--version"])
    assert code == 0 and out == f"vsw {importlib.metadata.version('vsw')}\n"

    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", missing)
    import vsw

    code, out, _ = run_main(capsys, ["--version"])
    assert code == 0 and out == f"vsw {vsw.__version__}\n"


def test_si_values_have_keys_of_their_own(capsys):
    _, out, _ = run_main(capsys, [*ANALYZE, "--json"])
    plain = json.loads(out)
    _, out, _ = run_main(capsys, [*ANALYZE, "--json", "--stepper-2d"])
    si = json.loads(out)
    mgr = 0.78 * 9.81 * 0.25  # the Stepper-2D of the paper: m g r_e in J
    for key in plain:
        if key not in ("conditions", "provenance", "units"):  # every key keeps its value
            assert si[key] == plain[key], key
    # and its unit; the SI keys add theirs
    quantities = si["units"].pop("quantities")
    assert plain["units"].pop("quantities").items() <= quantities.items()
    assert si["units"] == plain["units"]
    assert quantities["energy_added_J"] == "J" and quantities["step_length_m"] == "m"
    assert si["energy_unit"] == plain["energy_unit"] == "m g r_e"
    assert si["energy_added_J"] == pytest.approx(plain["energy_added"] * mgr, rel=1e-14)
    assert si["energy_lost_J"] == pytest.approx(plain["energy_lost"] * mgr, rel=1e-14)
    assert si["step_length_m"] == pytest.approx(plain["step_length"] * 0.25, rel=1e-14)


def test_text_table_shows_angle_margins_in_degrees(capsys):
    code, out, _ = run_main(capsys, [*ANALYZE, "--stepper-2d"])
    assert code == 0
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.strip()}
    # From the input alone: pi/2 - phi0 = 45 deg, phi0/2 - theta_II = 22.5 deg (eq. 16, 17).
    assert rows["phi0_below_right_angle"][2:4] == ["45", "deg"]
    assert rows["extension_before_symmetric_contact"][2:4] == ["22.5", "deg"]
    theta_I = -math.degrees(math.atan((0.8 - math.cos(math.pi / 4)) / math.sin(math.pi / 4)))
    assert float(rows["extension_reached"][2]) == pytest.approx(-theta_I, rel=1e-5)
    assert rows["apex"][3] == "g/r_e" and rows["stance_contact"][3:5] == ["m", "g"]
    assert rows["energy_added"][-1] == "r_e" and rows["energy_added_J"][-1] == "J"


def test_margin_units_match_independent_values():
    from generated import ile
    from vsw.models.ile.analysis import MARGIN_UNITS, analyze

    assert list(MARGIN_UNITS) == [c[0] for c in ile.CONDITIONS]
    beta, theta_II, phi0 = 0.85, math.radians(4.0), math.radians(50.0)
    a = analyze(beta, theta_II, phi0)
    theta_I = -math.atan((beta - math.cos(phi0)) / math.sin(phi0))  # eq. (11)
    independent = {
        "phi0_below_right_angle": math.pi / 2 - phi0,
        "extension_before_symmetric_contact": phi0 / 2 - theta_II,
        "extension_before_heelstrike": theta_I + phi0 - theta_II,
        "extension_reached": theta_II - theta_I,
        "theta_I_negative": beta - math.cos(phi0),
    }
    for name, value in independent.items():
        c = a.condition(name)
        assert c.value == pytest.approx(value, rel=1e-12), name
        assert c.unit == ("" if name == "theta_I_negative" else "rad")
    assert a.condition("q_positive").value == pytest.approx(float(a.q_fixed), rel=1e-12)
    assert a.condition("apex").value == pytest.approx(float(a.q_fixed - a.q_apex_min), rel=1e-9)


def test_basin_json_explains_n_steps(capsys):
    code, out, _ = run_main(capsys, [*SMALL_BASIN, "--json"])
    data = json.loads(out)
    envelope = {"model", "parameters", "units", "provenance"}
    assert code == 0 and set(data) - {"fields"} - envelope <= set(data["fields"])
    assert "stride-map steps" in data["fields"]["n_steps"]
    lam = 0.8**2 * math.cos(math.pi / 4) ** 2  # eq. (19)
    # The smallest n with lam^n * (1.5 / beta) < 1e-12, and one step more for safety.
    n = next(n for n in range(1, 200) if lam**n * 1.5 / 0.8 < 1e-12)
    assert data["n_steps"] == n + 1


def test_fallback_to_scipy_is_one_warning_line(tmp_path):
    """No compiler (a bad CC, an empty kernel cache): the walks take the SciPy route, about
    300 times slower, and the command says so once on stderr, not only inside its JSON."""
    env = {**os.environ, "CC": str(tmp_path / "no-such-cc"), "VSW_CACHE_DIR": str(tmp_path)}
    done = subprocess.run(
        [sys.executable, "-m", "vsw", "basin", "--model", "rimless-wheel", "--grid",
         "theta_dot=0.5:1.5:3", "--steps", "3", "--json"],
        capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("vsw: warning: the compiled batch simulator of rimless-wheel")
    assert "SciPy" in lines[0] and "no-such-cc" in lines[0]
    assert json.loads(done.stdout)["simulator"].startswith("SciPy")
