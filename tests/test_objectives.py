"""One vocabulary of quantities and objectives (:mod:`vsw.dynamics.quantities`): one definition
each, the same names in ``vsw design`` and ``vsw optimize``, the same formula in an NLP and
on the verified orbit."""

from __future__ import annotations

import argparse
import json
import math
from types import SimpleNamespace

import casadi as ca
import numpy as np
import pytest

from vsw import models
from vsw.cli import main
from vsw.cli.app import build_parser
from vsw.dynamics import quantities
from vsw.dynamics.ledger import _kinetic_potential
from vsw.dynamics.quantities import QUANTITIES, Quantity, evaluate, report, resolve
from vsw.runtime.errors import VswInputError
from vsw.synthesis import design, powered
from vsw.synthesis.design.problem import Problem
from vsw.synthesis.design.shooting import build


def _minimize_choices(command: str) -> list[str]:
    """The choices of ``--minimize`` in ``command``'s parser as built now."""
    parser = build_parser(command)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    action = next(a for a in sub.choices[command]._actions if a.dest == "minimize")
    return list(action.choices)


def test_each_alias_names_one_quantity_and_no_name_is_taken_twice():
    spellings = [s.replace("-", "_") for q in QUANTITIES.values() for s in (q.name, *q.aliases)]
    assert len(spellings) == len(set(spellings))
    assert resolve("cot", "optimize")[0] is resolve("cost-of-transport", "design", "min")[0]
    assert resolve("stability", "design", "min")[0] is resolve("eigenvalue", "optimize")[0]
    assert resolve("eigenvalue", "design", "min")[1] is None


def test_an_alias_is_read_with_a_one_line_note_and_a_wrong_name_refused():
    quantity, note = resolve("cot", "optimize")
    assert quantity.name == "cost_of_transport" and quantity.option == "cost-of-transport"
    assert note is not None and "\n" not in note and "cost-of-transport" in note
    refusal = (r"--minimize speed: not an objective of vsw optimize \(one of eigenvalue, "
               r"cost-of-transport, work, torque2\)")  # fmt: skip
    with pytest.raises(VswInputError, match=refusal):
        resolve("speed", "optimize")
    with pytest.raises(VswInputError, match="--maximize eigenvalue"):
        resolve("eigenvalue", "design", "max", "--maximize")


def test_design_and_optimize_take_the_same_names():
    shared = {"eigenvalue", "cost-of-transport", "stability", "cot"}
    assert shared <= set(_minimize_choices("design"))
    assert shared <= set(_minimize_choices("optimize"))
    assert powered.COSTS == ("eigenvalue", "cost_of_transport", "work", "torque2")
    assert design.MAXIMISED == ("step_length", "speed")
    assert design.MINIMISED == ("step_frequency", "eigenvalue", "energy_per_step",
                                "cost_of_transport")  # fmt: skip
    assert powered.Request("cot").minimize == "cost_of_transport"
    assert powered.Request("stability").minimize == "eigenvalue"
    with pytest.raises(VswInputError, match="--minimize speed: one of"):
        powered.Request("speed").check()


def test_a_new_objective_is_one_definition(monkeypatch):
    extra = Quantity("double_period", "time", "twice the period", "min", ("design", "optimize"),
                     ("two-periods",), formula=lambda f: 2 * f["period"])  # fmt: skip
    monkeypatch.setitem(QUANTITIES, extra.name, extra)
    for command in ("design", "optimize"):
        assert {"double-period", "two-periods"} <= set(_minimize_choices(command))
    assert resolve("two-periods", "optimize")[0] is extra
    assert report({"period": 0.5})["double_period"] == 1.0
    model = models.load("compass-gait")
    request = design.DesignRequest(objective={"double_period": 1.0}, targets={"speed": 0.8})
    problem = Problem(model, request)  # the design's checks take it
    nlp = build(model, problem.structure(1))
    assert nlp is not None


def test_the_formulas_are_the_same_in_an_nlp_and_on_an_orbit():
    facts = {"period": 0.75, "step_length": 0.6, "energy_per_step": 8.4, "energy": 8.4,
             "actuator_work": 0.42, "eigenvalue": 0.65, "weight": 196.2}  # fmt: skip
    names = [n for n, q in QUANTITIES.items() if q.formula is not None]
    numbers = evaluate(names, facts)
    symbols = {k: ca.MX.sym(k) for k in facts}
    expressions = evaluate(names, symbols)
    f = ca.Function("q", list(symbols.values()), [expressions[n] for n in names])
    values = [float(v) for v in f(*facts.values())]
    assert values == [numbers[n] for n in names]
    assert numbers["speed"] == 0.6 / 0.75 and numbers["step_frequency"] == 1 / 0.75
    assert numbers["cost_of_transport"] == 8.4 / (196.2 * 0.6)
    assert evaluate(("speed", "cost_of_transport"), {**facts, "step_length": None}) == {
        "speed": None, "cost_of_transport": None}  # fmt: skip


def test_a_report_has_the_quantities_its_facts_give():
    passive = report({"period": 2.0, "step_length": 1.0, "eigenvalue": 0.5,
                      "energy_per_step": 3.0, "energy": 3.0, "weight": 1.5})  # fmt: skip
    assert list(passive) == ["period", "step_frequency", "eigenvalue", "energy_per_step",
                             "step_length", "speed", "cost_of_transport"]  # fmt: skip
    powered_ = report({"period": 2.0, "step_length": 1.0, "eigenvalue": None,
                       "actuator_work": 1.5, "energy": 1.5, "weight": 1.5})  # fmt: skip
    assert set(passive) - {"energy_per_step"} == set(powered_) - {"work"}
    assert powered_["cost_of_transport"] == 1.0 and passive["cost_of_transport"] == 2.0
    assert powered_["eigenvalue"] is None


def test_the_weight_is_one_definition_for_numbers_and_casadi():
    model = models.load("compass-gait")
    params = np.array(model.parameters({}))
    number = quantities.weight(model, params)
    symbol = quantities.weight(model, ca.MX.sym("p", len(params)))
    assert number == pytest.approx((10 + 2 * 5) * 9.81, rel=1e-15)
    assert float(ca.Function("w", [ca.symvar(symbol)[0]], [symbol])(params)) == number
    assert powered.walker_weight is quantities.weight
    assert quantities.weight(models.load("rimless-wheel"), [0.39, 0.08, 1.0, 9.81]) in (1.0, 9.81)


def test_the_kinetic_energy_is_the_ledgers():
    model = models.load("compass-gait")
    params = model.parameters({})
    state = np.array([-0.3, 0.3, 1.1, 0.2])
    phase = model.phases[0]["name"]
    kinetic, _ = _kinetic_potential(model, phase, params, state)
    assert quantities.kinetic_energy(model, phase, list(params), state) == pytest.approx(
        kinetic, rel=1e-14)  # fmt: skip
    assert quantities.kinetic_energy(model, phase, list(params), state * [1, 1, 0, 0]) == 0.0


def test_an_alias_notes_once_on_success_and_a_refusal_stays_one_line(capsys):
    argv = ["design", "--stepper-2d", "--target-speed", "0.8", "--json"]
    assert main([*argv, "--minimize", "cost-of-transport"]) == 0
    canonical = capsys.readouterr()
    assert canonical.err == ""
    assert main([*argv, "--minimize", "cot"]) == 0
    aliased = capsys.readouterr()
    assert aliased.err == ("vsw design: note: --minimize cot is read as cost-of-transport, the "
                           "name vsw design and vsw optimize share\n")  # fmt: skip
    before, after = json.loads(canonical.out), json.loads(aliased.out)
    assert before["cost_of_transport"] == after["cost_of_transport"]
    assert math.isfinite(after["cost_of_transport"])
    for argv in (["design", "--model", "compass-gait", "--minimize", "cot", "--bound", "x=1:2"],
                 ["optimize", "--model", "compass-gait", "--minimize", "stability", "--use",
                  "push_off"]):  # fmt: skip
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "note" not in err, err


def test_optimize_reports_the_quantities_of_design():
    model = models.load("level-compass-gait")
    params = model.parameters({})
    gait = SimpleNamespace(period=0.5, step_length=0.4, extra={"eigenvalues": [0.8 + 0.1j]},
                           work={"a": {"positive": 0.3}, "b": {"positive": 0.1}})  # fmt: skip
    from vsw.cli.optimize import _quantities

    out = _quantities(model, params, gait)
    assert list(out) == ["period", "step_frequency", "eigenvalue", "step_length", "speed",
                         "cost_of_transport", "work"]  # fmt: skip
    assert out["work"] == pytest.approx(0.4) and out["eigenvalue"] == abs(0.8 + 0.1j)
    assert out["cost_of_transport"] == out["work"] / (quantities.weight(model, params) * 0.4)
