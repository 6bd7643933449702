"""Property-based test of the ``vsw`` command line: every subcommand, generated arguments.

Arguments mix plausible values with non-numbers, NaN, infinities, huge and tiny values,
missing and repeated options and contradictory flags. Whatever the arguments:

* the exit status is 0, 2 or 3;
* a non-zero exit prints exactly one line on stderr and never a traceback;
* exit 0 prints nothing on stderr (no warning, no log line) but the one-line note that an
  objective's old spelling is read under its shared name, and, with ``--json``, one
  strict JSON document (no NaN) on stdout;
* no warning is raised that Python's default filters would print on stderr (numpy
  RuntimeWarnings included; pytest would otherwise swallow them).

The commands run in process through ``vsw.cli.main`` with stdout and stderr captured. The
work stays small and bounded: a fixed number of examples per subcommand and small
``VSW_MAX_SECONDS`` / ``VSW_MAX_MEMORY``, so that huge grids and step counts are refused by
the limits instead of run (which is itself a behaviour under test). ``derandomize=True``
makes the examples the same from run to run of the same command (CI runs the whole
suite); Hypothesis also draws constants from the project modules already imported, so a
different selection of tests can see different examples.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import math
import os
import warnings
from unittest import mock

import pytest

hypothesis = pytest.importorskip("hypothesis")
import numpy as np  # noqa: E402

# The commands run in this one process under a 0.5 s limit: a stop that lands inside a
# first import of Matplotlib (or of a module it loads lazily) leaves its submodules bound
# to a module object Python has dropped, and every later use in the process fails. A
# command line run ends its process there; here the imports are done once up front.
for _module in ("matplotlib", "matplotlib.pyplot", "matplotlib.collections",
                "matplotlib.animation", "matplotlib.backends.backend_agg",
                "matplotlib.backends.backend_svg", "matplotlib.backends.backend_pdf"):  # fmt: skip
    importlib.import_module(_module)
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from tests.loopback import server  # noqa: E402
from vsw.cli import main  # noqa: E402
from vsw.models import keys as model_keys  # noqa: E402
from vsw.models import load  # noqa: E402

# Default warning filters hide these from users; every other category would print.
_HIDDEN_BY_DEFAULT = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)

GARBAGE = st.sampled_from(
    [
        "nan", "NaN", "-nan", "inf", "-inf", "+inf", "infinity", "1e999", "-1e999", "abc", "",
        " ", "1,5", "0x10", "1e-320", "5e-324", "-5e-324", "1e308", "-1e308", "-0", "0", "1_0",
        "--", "None", "1/2", "\u0663", "1e", ".", "-",
    ]
)  # fmt: skip


def _weighted(plausible: st.SearchStrategy, wild: st.SearchStrategy) -> st.SearchStrategy:
    """Mostly plausible values (so the commands get past parsing), sometimes anything."""
    return st.integers(0, 9).flatmap(lambda k: plausible if k < 9 else wild)


def number(lo: float, hi: float) -> st.SearchStrategy[str]:
    plausible = st.floats(lo, hi).map(repr)
    wild = st.one_of(
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.floats(-1e-300, 1e-300).map(repr),
        st.integers(-(10**30), 10**30).map(str),
        GARBAGE,
    )
    return _weighted(plausible, wild)


def integer(lo: int, hi: int) -> st.SearchStrategy[str]:
    plausible = st.integers(lo, hi).map(str)
    wild = st.one_of(
        st.integers(-(10**20), 10**20).map(str),
        st.sampled_from(["2.5", "1e3", "10**9", "1000000000000", "-1", "0", "99999999"]),
        GARBAGE,
    )
    return _weighted(plausible, wild)


def plot_path(tmp: str) -> st.SearchStrategy[str]:
    return st.sampled_from(
        [
            "",
            "/proc/fig9.png",
            "/sys/sim.png",
            tmp,  # an existing directory
            os.path.join(tmp, "dir.png"),  # made a directory below
            os.path.join(tmp, "missing", "x.png"),
            os.path.join(tmp, "x.txt"),
            os.path.join(tmp, "ok.svg"),
        ]
    )


@st.composite
def command_line(draw, command: str, options: dict, flags: tuple[str, ...], required=()):
    """``[command, ...]`` with a random subset of options in random order and form."""
    parts: list[list[str]] = []
    for name, values in options.items():
        # Required options are mostly there once, sometimes missing or repeated.
        counts = [1] * 20 + [0, 2] if name in required else [0, 0, 0, 0, 1, 2]
        for _ in range(draw(st.sampled_from(counts))):
            value = draw(values)
            if draw(st.booleans()):
                parts.append([f"{name}={value}"])
            else:
                parts.append([name, value])
    for flag in flags:
        if draw(st.booleans()):
            parts.append([flag])
    parts = draw(st.permutations(parts))
    return [command, *(token for part in parts for token in part)]


# Plausible ranges around walking gaits, so that many runs get through to the end.
GAIT = {
    "--beta": number(0.75, 0.95),
    "--theta-ii": number(2.0, 15.0),
    "--phi0": number(40.0, 55.0),
}
SCALE = {
    "--leg-length": number(0.05, 2.0),
    "--mass": number(0.1, 100.0),
    "--gravity": number(1.0, 30.0),
}


def _run(argv: list[str], env: dict[str, str]) -> tuple[int, str, str, list]:
    out, err = io.StringIO(), io.StringIO()
    with (
        mock.patch.dict(os.environ, env),
        warnings.catch_warnings(record=True) as caught,
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
    ):
        warnings.simplefilter("always")
        code = main(argv)
    shown = [w for w in caught if not issubclass(w.category, _HIDDEN_BY_DEFAULT)]
    return code, out.getvalue(), err.getvalue(), shown


def _check(argv: list[str], env: dict[str, str]) -> None:
    code, out, err, shown = _run(argv, env)
    where = f"vsw {' '.join(argv)!r}"
    assert code in (0, 2, 3), f"{where}: exit {code}, stderr {err!r}"
    assert "Traceback" not in err, f"{where}: {err}"
    assert not shown, f"{where}: warnings {[str(w.message) for w in shown]}"
    if code != 0:
        assert err.count("\n") == 1 and err.endswith("\n") and err.strip(), f"{where}: {err!r}"
        return
    notes = [line for line in err.splitlines() if ": note: " in line and " is read as " in line]
    assert len(notes) <= 1 and err == "".join(f"{n}\n" for n in notes), (
        f"{where}: exit 0 but stderr {err!r}"
    )
    asked_help = any(t in ("-h", "--help", "--version") for t in argv)
    if "--json" in argv and not asked_help:

        def no_constant(name: str) -> None:
            raise AssertionError(f"{where}: {name} in JSON")

        json.loads(out, parse_constant=no_constant)


COMMON = settings(
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


FUZZ_SCALE = int(os.environ.get("VSW_FUZZ_SCALE", "1") or 1)
"""``VSW_FUZZ_SCALE=K`` runs K times the examples, drawn afresh (not derandomized): a
longer fuzz campaign by hand, ``VSW_FUZZ_SCALE=3 python -m pytest tests/test_cli_fuzz.py``
(about 1,500 runs); the test suite runs the fixed examples."""


def budget(examples: int) -> settings:
    """The common settings with a number of examples (times :data:`FUZZ_SCALE`)."""
    if FUZZ_SCALE > 1:
        return settings(COMMON, max_examples=examples * FUZZ_SCALE, derandomize=False)
    return settings(COMMON, max_examples=examples)


# Small limits: what would exceed them is refused (exit 2) in microseconds instead of run.
FAST = {"VSW_MAX_SECONDS": "0.5", "VSW_MAX_MEMORY": "256M"}


@pytest.fixture(scope="module")
def plot_dir(tmp_path_factory) -> str:
    tmp = tmp_path_factory.mktemp("plots")
    (tmp / "dir.png").mkdir()
    return str(tmp)


def test_analyze_any_arguments(plot_dir):
    options = {**GAIT, **SCALE}

    @budget(150)
    @given(command_line("analyze", options, ("--json", "--stepper-2d"), required=tuple(GAIT)))
    def run(argv):
        _check(argv, FAST)

    run()


def test_simulate_any_arguments(plot_dir):
    options = {
        **GAIT,
        "--q0": number(0.1, 0.9),
        "--steps": integer(1, 4),
        "--plot": plot_path(plot_dir),
    }

    @budget(40)
    @given(command_line("simulate", options, ("--json",), required=(*GAIT, "--q0", "--steps")))
    def run(argv):
        # 0.05 s: about 6 simulated steps; more steps are refused by the limit.
        _check(argv, {**FAST, "VSW_MAX_SECONDS": "0.05"})

    run()


@pytest.mark.slow
def test_basin_any_arguments(plot_dir):
    options = {
        "--beta": GAIT["--beta"],
        "--phi0": GAIT["--phi0"],
        "--theta-min": number(-60.0, 30.0),
        "--theta-max": number(-30.0, 60.0),
        "--theta-step": number(4.0, 80.0),
        "--n-q": integer(3, 200),
        "--check-edges": integer(0, 1),
        "--plot": plot_path(plot_dir),
    }

    @budget(60)
    @given(
        command_line(
            "basin", options, ("--json",), required=("--beta", "--phi0", "--theta-step", "--n-q")
        )
    )
    def run(argv):
        _check(argv, FAST)

    run()


def test_design_any_arguments():
    pytest.importorskip("casadi")
    options = {
        "--target-speed": number(0.1, 1.0),
        "--beta-min": number(0.3, 0.8),
        "--beta-max": number(0.6, 0.99),
        "--theta-ii-min": number(-20.0, 0.0),
        "--theta-ii-max": number(0.0, 20.0),
        "--phi0-min": number(10.0, 40.0),
        "--phi0-max": number(30.0, 80.0),
        "--fix": st.sampled_from(
            ["beta=0.8", "phi0=45deg", "theta_II=0", "beta=abc", "x=1", "beta"]
        ),
        "--min-contact-margin": number(0.0, 0.2),
        "--max-eigenvalue": number(0.1, 1.0),
        "--starts": st.just("1"),
        **SCALE,
    }

    # Each design solve takes 50 ms to 1 s: few examples, one start each (--starts is only
    # ever 1 here: a huge start count is the design command's own limit to set).
    @budget(8)
    @given(
        command_line(
            "design", options, ("--json", "--stepper-2d"), required=("--starts", "--target-speed")
        ).filter(lambda argv: "--starts" in " ".join(argv))
    )
    def run(argv):
        _check(argv, FAST)

    run()


def test_design_of_any_model_any_arguments():
    """``vsw design --model rimless-wheel`` (the design on the periodic orbit; a solve takes
    0.3-1 s there) with random objectives, targets, fixes and bounds, sane or not."""
    pytest.importorskip("casadi")
    options = {
        "--maximize": st.sampled_from(["speed", "step-length", "eigenvalue"]),
        "--minimize": st.sampled_from(["eigenvalue", "cost-of-transport", "energy-per-step",
                                       "step-frequency", "speed"]),
        "--target-speed": number(0.5, 3.0),
        "--target-period": number(0.1, 2.0),
        "--fix": st.sampled_from(["gamma=0.15", "alpha=22.5deg", "alpha=2", "l=0", "x=1",
                                  "gamma"]),
        "--bound": st.sampled_from(["gamma=0.1:0.25", "alpha=0.2:0.5", "speed=:2",
                                    "gamma=0.3:0.1", "alpha=nan:1", "l=0.5:2", "g=:"]),
        "--max-eigenvalue": number(0.1, 1.0),
        "--weight": st.sampled_from(["eigenvalue=2", "speed=-1", "x=1"]),
        "--min-margin": number(0.0, 0.5),
        "--starts": st.just("1"),
    }  # fmt: skip

    @budget(12)
    @given(command_line("design", {"--model": st.just("rimless-wheel"), **options}, ("--json",),
                        required=("--model", "--starts")))  # fmt: skip
    def run(argv):
        _check(argv, {"VSW_MAX_SECONDS": "30", "VSW_MAX_MEMORY": "2G"})

    run()


TOKENS = st.sampled_from(
    [
        "analyze", "simulate", "basin", "design", "fly", "--help", "-h", "--version", "--json",
        "--beta", "0.8", "--theta-ii", "0", "--phi0", "45", "--q0", "0.3", "--steps", "2",
        "--n-q", "5", "--theta-step", "20", "nan", "-inf", "1e999", "abc", "", "--", "-x",
    ]
)  # fmt: skip


def test_any_tokens():
    @budget(60)
    @given(st.lists(TOKENS, max_size=9))
    def run(argv):
        _check(argv, FAST)

    run()


# --- models: vsw models, --model, --param, --state, sweep ---------------------------------------


def assignment(names: list[str], value: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    """``NAME=VALUE`` items: mostly a known name with a drawn value, sometimes anything."""
    plausible = st.tuples(st.sampled_from(names), value).map("=".join)
    wild = st.one_of(
        st.tuples(st.sampled_from(["x", "", "beta", "theta_II", "Alpha", " "]), value).map(
            "=".join
        ),
        GARBAGE,
    )
    return _weighted(plausible, wild)


# Plausible values where the rimless wheel rolls (a gait scan without a gait takes longer).
RIMLESS_PARAM = st.one_of(
    assignment(["alpha"], number(0.3, 0.4)),
    assignment(["gamma"], number(0.08, 0.2)),
    assignment(["l"], number(0.5, 2.0)),
    assignment(["g"], number(5.0, 15.0)),
)
MODEL = st.sampled_from(["rimless-wheel"] * 8 + ["rimless_wheel", "ile", "walker", ""])


def test_models_any_arguments():
    @budget(10)
    @given(st.lists(st.sampled_from(["models", "--json", "--help", "-x", "ile", "--model"])))
    def run(argv):
        _check(["models", *argv], FAST)

    run()


_COMMON = {"--model": MODEL, "--param": RIMLESS_PARAM}
MODEL_COMMANDS = {
    "analyze": ({**_COMMON, "--beta": GAIT["--beta"]}, ("--json", "--stepper-2d"), ()),
    "simulate": (
        {
            **_COMMON,
            "--steps": integer(1, 4),
            "--state": assignment(["theta", "theta_dot"], number(-0.5, 2.0)),
            "--q0": number(0.1, 0.9),
        },
        ("--json",),
        ("--steps",),
    ),
    "basin": (
        {
            **_COMMON,
            "--grid": st.tuples(number(-0.5, 1.0), number(1.5, 4.0), integer(2, 5)).map(
                lambda t: "theta_dot=" + ":".join(t)
            ),
            "--steps": integer(1, 30),
            "--tol": number(1e-9, 1e-3),
            "--n-q": integer(3, 10),
        },
        ("--json",),
        ("--grid", "--steps"),
    ),
    "sweep": (
        {
            **_COMMON,
            "--over": st.one_of(
                st.tuples(number(0.08, 0.12), number(0.1, 0.2), integer(1, 3)).map(
                    lambda t: "gamma=" + ":".join(t)
                ),
                assignment(["alpha", "theta_II"], st.sampled_from(["0.3:0.4:2", "1:2", ""])),
            ),
        },
        ("--json",),
        ("--over",),
    ),
    "continue": (
        {
            **_COMMON,
            "--over": st.one_of(
                st.tuples(number(0.08, 0.12), number(0.1, 0.2)).map(
                    lambda t: "gamma=" + ":".join(t)
                ),
                assignment(["alpha", "theta_II"], st.sampled_from(["0.3:0.4", "1:2:3", ""])),
            ),
            "--max-points": integer(-1, 12),
            "--period": integer(-1, 2),
            "--max-period": integer(0, 4),
        },
        ("--json", "--no-switch"),
        ("--over",),
    ),
    "rough": (
        {
            **_COMMON,
            "--sigma": number(-0.01, 0.05),
            "--walks": integer(-1, 40),
            "--max-steps": integer(-1, 40),
            "--seed": st.sampled_from(["0", "7", "-1", "1.5", "x", ""]),
            "--terrain": st.sampled_from(["slope", "height", ""]),
        },
        ("--json",),
        ("--sigma",),
    ),
    "optimize": (
        {
            "--model": st.sampled_from(["compass-gait"] * 6 + ["rimless-wheel", "ile", ""]),
            "--param": RIMLESS_PARAM,
            "--minimize": st.sampled_from(["torque2", "work", "cot", "speed", ""]),
            "--target-speed": number(-0.5, 3.0),
            "--target-step-length": number(-0.5, 2.0),
            "--nodes": integer(-1, 6),
        },
        ("--json",),
        (),
    ),
}


@pytest.mark.parametrize("command", sorted(MODEL_COMMANDS))
def test_model_commands_any_arguments(command):
    options, flags, required = MODEL_COMMANDS[command]

    # Each gait scan takes 1-3 s: few examples, and a limit that lets small work run.
    @budget(5)
    @given(command_line(command, options, flags, required=("--model", *required)))
    def run(argv):
        _check(argv, {**FAST, "VSW_MAX_SECONDS": "20"})

    run()


# --- the parameter edges of every model ----------------------------------------------------


def _edge_values(p) -> list[float]:
    """A parameter's edges: its open bounds, just inside and outside them, the ends of what
    vsw computes and just beyond, and the extremes of double precision."""
    low, high = p.computed or (p.lower, p.upper)
    values = {5e-324, -5e-324, 1e300, -1e300, 1e-300, 0.0, -0.0}
    for v in (p.lower, p.upper, low, high):
        if math.isfinite(v):
            values |= {v, float(np.nextafter(v, math.inf)), float(np.nextafter(v, -math.inf)),
                       v * (1 + 1e-12), v * (1 - 1e-12)}  # fmt: skip
    return sorted(values)


EDGES = [
    (load(key).cli_name, p.name, value)
    for key in model_keys()
    for p in load(key).parameter_table
    for value in _edge_values(p)
]


@st.composite
def edge_command(draw) -> list[str]:
    """analyze, simulate or sweep of any model with one parameter at one of its edges."""
    model, name, value = draw(st.sampled_from(EDGES))
    command = draw(st.sampled_from(["analyze", "simulate", "sweep"]))
    argv = [command, "--model", model]
    if command == "sweep":
        other = draw(st.sampled_from([e for e in EDGES if e[:2] == (model, name)]))[2]
        argv += ["--over", f"{name}={value!r}:{other!r}:2"]
    else:
        argv += ["--param", f"{name}={value!r}"]
    if command == "simulate":
        argv += ["--steps", "1"]
    return argv + ["--json"] * draw(st.booleans())


@pytest.mark.slow
def test_parameter_edges_of_every_model():
    """Every model's parameters at their edges: a result, exit 3 or one line,
    never a traceback or a warning. The slow ones stop at a 2 s limit (one line)."""

    @budget(120)
    @given(edge_command())
    def run(argv):
        _check(argv, {**FAST, "VSW_MAX_SECONDS": "2"})

    run()


# --- the environment: the run-time limit, the threads, Dask endpoints ----------------------

MAX_SECONDS = st.one_of(
    st.sampled_from(["9.3e9", "1e10", "1e308", "1.7976931348623157e308", "inf", "1e400",
                     "nan", "-1", "0", "-inf", "abc", "", "1e5s", "30"]),
    st.floats(30.0, 1.7976931348623157e308).map(repr),
)  # fmt: skip
THREADS = st.sampled_from(["1", "2", "0", "-1", "abc", "1e3", "nan", "", "64", "100000"])


def test_environment_values_and_scheduler_addresses(monkeypatch):
    """Any ``VSW_MAX_SECONDS`` (up to 1e308 and beyond), ``VSW_THREADS``, and ``--scheduler``
    addresses of every scheme (a refused port, a server that answers with other bytes, one
    that stays silent, TLS without certificates, in-process, garbage): a result or one
    line, never a traceback. Dask's waits shortened so that an example takes a second."""
    pytest.importorskip("distributed")
    import vsw.studies.cluster

    monkeypatch.setattr(vsw.studies.cluster, "CONNECT_TIMEOUT", 0.5)
    monkeypatch.setattr(vsw.studies.cluster, "HANDSHAKE_TIMEOUT", 1.0, raising=False)
    with server(b"HTTP/1.1 400 Bad Request\r\n\r\n" * 4) as other, server(None) as silent:
        addresses = st.sampled_from([
            f"tcp://127.0.0.1:{other}", f"tcp://127.0.0.1:{silent}", f"ws://127.0.0.1:{other}",
            "tcp://127.0.0.1:1", "tls://127.0.0.1:1", "wss://127.0.0.1:1", "inproc://x",
            "ucx://127.0.0.1:2", "tcp://", "tcp://127.0.0.1:0", "tcp://[::1", "garbage", "",
            "tcp://127.0.0.1:99999", "tcp://:8786",
        ])  # fmt: skip
        commands = st.one_of(
            st.just(["models"]),
            st.just(["analyze", "--model", "rimless-wheel", "--json"]),
            st.just(["simulate", "--model", "rimless-wheel", "--steps", "2"]),
            addresses.map(lambda address: ["basin", "--model", "rimless-wheel", "--grid",
                                           "theta_dot=0.5:2:3", "--steps", "3",
                                           "--scheduler", address]),
        )  # fmt: skip

        @budget(24)
        @given(commands, MAX_SECONDS, THREADS)
        def run(argv, seconds, threads):
            _check(argv, {"VSW_MAX_SECONDS": seconds, "VSW_THREADS": threads,
                          "VSW_MAX_MEMORY": "256M"})  # fmt: skip

        run()


@st.composite
def falling_start(draw, tmp: str) -> list[str]:
    """simulate from a start that falls at once, or nearly, with a trajectory file and a
    plot, either of them in any of their forms."""
    if draw(st.booleans()):
        model = "compass-gait"
        state = {"theta": number(0.4, 0.6), "psi": number(0.2, 0.4),
                 "theta_dot": number(-1.5, -0.8), "psi_dot": number(-3.5, -2.5)}  # fmt: skip
    else:
        model = "rimless-wheel"
        state = {"theta": number(0.3, 0.6), "theta_dot": number(-6.0, -2.0)}
    argv = ["simulate", "--model", model, "--steps", draw(integer(1, 3))]
    for name, value in state.items():
        argv += ["--state", f"{name}={draw(value)}"]
    trajectory = draw(st.sampled_from(["walk.csv", "walk.npz", "walk.mat", "walk.txt", None]))
    if trajectory is not None:
        argv += ["--trajectory", os.path.join(tmp, trajectory)]
    if draw(st.booleans()):
        argv += ["--plot", draw(plot_path(tmp))]
    return argv + ["--json"] * draw(st.booleans())


def test_falling_starts_with_a_trajectory_and_a_plot(plot_dir):
    @budget(10)
    @given(falling_start(plot_dir))
    def run(argv):
        _check(argv, {**FAST, "VSW_MAX_SECONDS": "20"})

    run()
