"""One vocabulary of a gait's quantities and the objectives made of them.

Each quantity is defined once (:data:`QUANTITIES`): its name (the key of the JSON), the
spellings accepted for it on the command line, its dimension (a unit of the model's, see
:func:`vsw.cli.output.dimension_unit`), whether an objective minimises or maximises it, the
commands whose objective it may be, and its formula over the facts of a step (``period``,
``step_length``, ``energy_per_step``, ``actuator_work``, ``weight``, ...). A formula is
plain arithmetic, so the same one builds the CasADi expression of an NLP (``vsw design``,
``vsw optimize``) and the number on the verified orbit.

The facts are the commands': ``energy_per_step`` is the kinetic energy a step's impacts
dissipate (:func:`kinetic_energy` on either side of each impact), which a passive gait gets
back from gravity; ``actuator_work`` the positive work of the inputs and impulses over a
step (a powered gait); ``energy`` whichever of the two a step takes in, the numerator of
the cost of transport. The walker's weight is :func:`weight`, numpy or CasADi.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.runtime.errors import VswInputError

__all__ = [
    "QUANTITIES",
    "Quantity",
    "alias_names",
    "evaluate",
    "kinetic_energy",
    "maximised",
    "objective_names",
    "report",
    "resolve",
    "weight",
]


@dataclass(frozen=True)
class Quantity:
    """A quantity of a step: ``name`` (the JSON's key), ``dimension``, ``sense`` (``min``
    or ``max`` where an objective may name it, else None), ``commands`` (those whose
    objective it may be), ``aliases`` (other spellings, accepted with a note), ``meaning``
    and ``formula`` (the facts of a step -> its value; None where a command computes it
    itself, as the eigenvalue bound's radius and the squared inputs' integral)."""

    name: str
    dimension: str
    meaning: str
    sense: str | None = None
    commands: tuple[str, ...] = ()
    aliases: tuple[str, ...] = ()
    formula: Callable[[Mapping[str, Any]], Any] | None = None

    @property
    def option(self) -> str:
        """The spelling of the command line: ``cost_of_transport`` -> ``cost-of-transport``."""
        return self.name.replace("_", "-")


def _fact(name: str) -> Callable[[Mapping[str, Any]], Any]:
    return lambda facts: facts[name]


def _per_length(facts: Mapping[str, Any]) -> Any:
    """The energy a step takes in, per weight and step length."""
    return facts["energy"] / (facts["weight"] * facts["step_length"])


QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        Quantity("period", "time", "the step's period", formula=_fact("period")),
        Quantity("step_frequency", "frequency", "steps per time unit", "min", ("design",),
                 formula=lambda f: 1.0 / f["period"]),
        Quantity("eigenvalue", "1", "the largest |eigenvalue| of the step map", "min",
                 ("design", "optimize"), ("stability",), formula=_fact("eigenvalue")),
        Quantity("energy_per_step", "energy", "the kinetic energy the impacts dissipate", "min",
                 ("design",), formula=_fact("energy_per_step")),
        Quantity("step_length", "length", "the step's length", "max", ("design",),
                 formula=_fact("step_length")),
        Quantity("speed", "speed", "step length over period", "max", ("design",),
                 formula=lambda f: f["step_length"] / f["period"]),
        Quantity("cost_of_transport", "1", "the energy a step takes in over weight x step "
                 "length", "min", ("design", "optimize"), ("cot",), formula=_per_length),
        Quantity("work", "energy", "the inputs' and impulses' positive work per step", "min",
                 ("optimize",), ("actuator-work",), formula=_fact("actuator_work")),
        Quantity("torque2", "1", "the integral of the squared inputs over the step", "min",
                 ("optimize",)),
    )
}  # fmt: skip
"""Every quantity, by name, in the order a result reports them."""


def objective_names(command: str, sense: str | None = None) -> tuple[str, ...]:
    """The command-line spellings of the objectives of ``command`` (of one ``sense``)."""
    return tuple(q.option for q in QUANTITIES.values()
                 if command in q.commands and sense in (None, q.sense))  # fmt: skip


def alias_names(command: str, sense: str | None = None) -> tuple[str, ...]:
    """The other spellings accepted for those objectives."""
    return tuple(a for q in QUANTITIES.values() if command in q.commands
                 and sense in (None, q.sense) for a in q.aliases)  # fmt: skip


def resolve(
    name: str, command: str, sense: str | None = None, option: str = "--minimize"
) -> tuple[Quantity, str | None]:
    """The objective ``option NAME`` means for ``command``, and a one-line note where the
    name is an alias (read as its one spelling, shared by ``vsw design`` and ``vsw
    optimize``); a name no objective of ``command`` has is refused in one line."""
    key = name.strip().replace("-", "_")
    for q in QUANTITIES.values():
        if command not in q.commands or sense not in (None, q.sense):
            continue
        if key == q.name:
            return q, None
        if key in (a.replace("-", "_") for a in q.aliases):
            return q, (f"{option} {name} is read as {q.option}, the name vsw design and vsw "
                       "optimize share")  # fmt: skip
    names = ", ".join(objective_names(command, sense))
    raise VswInputError(f"{option} {name}: not an objective of vsw {command} (one of {names})")


def evaluate(names: Sequence[str], facts: Mapping[str, Any]) -> dict[str, Any]:
    """The quantities ``names`` from a step's facts (numbers or CasADi expressions); None
    where a fact they need is None (a model without a step length has no speed)."""
    out: dict[str, Any] = {}
    for name in names:
        formula = QUANTITIES[name].formula
        if formula is None:
            raise ValueError(f"{name} has no formula over a step's facts")
        try:
            out[name] = formula(facts)
        except TypeError:  # arithmetic on a fact that is None
            if not any(v is None for v in facts.values()):
                raise
            out[name] = None
    return out


def report(facts: Mapping[str, Any]) -> dict[str, Any]:
    """Every quantity with a formula that a result's facts give (those needing a fact it has
    left out are left out: ``vsw design``'s passive gait has no actuator work, ``vsw
    optimize``'s powered one no impact losses of its own), in :data:`QUANTITIES`' order."""
    out: dict[str, Any] = {}
    for name, quantity in QUANTITIES.items():
        if quantity.formula is None:
            continue
        try:
            out.update(evaluate((name,), facts))
        except KeyError:
            continue
    return out


def maximised(name: str) -> bool:
    """Whether an objective maximises the quantity (it enters a sum as minus its weight)."""
    return QUANTITIES[name].sense == "max"


def weight(model: Any, params: Any) -> Any:
    """The walker's weight in the model's force unit (the cost of transport's scale): the
    generated ``weight`` where the derivation gives one, else 1 (a model whose units are
    already scaled by its weight). ``params``: numbers, or a CasADi column."""
    if not hasattr(model.module, "weight"):
        return 1.0
    zeros = [0.0] * (2 * model.n)
    if isinstance(params, (np.ndarray, list, tuple)):
        return float(model.module.weight(*params, *zeros))
    import casadi as ca

    return model.module.weight(*ca.vertsplit(params), *zeros)


def kinetic_energy(model: Any, phase: str, params: Any, state: Any) -> Any:
    """The kinetic energy of a state in ``phase``: ``E(q, rates) - E(q, 0)`` (the energy is
    quadratic in the rates, and with them at zero it is the potential). ``params`` a
    sequence of numbers or CasADi scalars; ``state`` numpy or CasADi."""
    n = model.n
    energy = model.function(f"{phase}_energy")
    coords = [state[i] for i in range(n)]
    moving = energy(*params, *coords, *[state[n + i] for i in range(n)])
    return moving - energy(*params, *coords, *([0 * state[0]] * n))
