"""The paper's equations (1)-(23), transcribed as printed, in the paper's own notation.

Source: ``../shared/paper/instantaneous_leg_extension_vsw.md`` (Wang et al., *The
instantaneous leg extension model of Virtual Slope Walking*). Each entry keeps the LaTeX
exactly as printed (for the report) and a sympy source string in the paper's symbols,
parsed with :func:`sympy.parsing.sympy_parser.parse_expr` against the explicit symbol
table :data:`PAPER_SYMBOLS`. Nothing here is derived: the derivation lives in
``derive/models/ile/``, and :mod:`paper_check.compare` puts the two side by side.

Notation kept from the paper
----------------------------
- ``theta_1`` / ``omega_1`` are the printed subscripts of eq. (5)-(13); the text and
  eq. (20)-(23) write ``theta_I`` for the same angle (instant I). Both are kept as
  separate symbols so the transcription stays literal.
- ``r_s`` is the short stance leg, ``r_e`` the extended one (the Fig. 4 caption writes
  ``r_c``), ``beta = r_s / r_e``.
- ``*_next`` is the paper's ``(n+1)``; the unsuffixed symbol is step ``n``.
- ``theta_ddot`` is the second derivative of theta with respect to the time variable of
  the equation (``t`` in (1), ``tau`` in (2) and (4)).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import sympy as sm
from sympy.parsing.sympy_parser import parse_expr, standard_transformations

__all__ = ["EQUATIONS", "EQUATION_BY_ID", "PAPER_SYMBOLS", "PaperEquation", "parse_paper"]


def _symbols() -> dict[str, sm.Basic]:
    positive = "beta varphi_0 g m r_s r_e"
    real = (
        "theta theta_ddot theta_1 theta_I theta_II theta_IV theta_1_next q q_f f_q lam "
        "omega_1 omega_1_next omega_II omega_III omega_IV E_r E_c E_Delta C"
    )
    table: dict[str, sm.Basic] = {name: sm.Symbol(name, positive=True) for name in positive.split()}
    table.update({name: sm.Symbol(name, real=True) for name in real.split()})
    table.update(
        {
            "sin": sm.sin,
            "cos": sm.cos,
            "tan": sm.tan,
            "atan": sm.atan,
            "pi": sm.pi,
            "Eq": sm.Eq,
            "Piecewise": sm.Piecewise,
            "Rational": sm.Rational,
        }
    )
    return table


PAPER_SYMBOLS: dict[str, sm.Basic] = _symbols()
"""Explicit local dictionary for parsing: the paper's symbols and the functions used."""


def parse_paper(source: str) -> sm.Basic:
    """Parse sympy source text written in the paper's symbols (no implicit symbols).

    Parameters
    ----------
    source : str
        Sympy source using only names in :data:`PAPER_SYMBOLS`.

    Returns
    -------
    sympy.Basic
        The expression, equation or relation.

    Raises
    ------
    NameError
        When the source uses a name outside :data:`PAPER_SYMBOLS` (a typo would otherwise
        silently create a new symbol).
    """

    def check(tokens, local_dict, global_dict):  # type: ignore[no-untyped-def]
        from tokenize import NAME

        unknown = sorted(
            {v for kind, v in tokens if kind == NAME and v not in local_dict} - {"True", "False"}
        )
        if unknown:
            raise NameError(f"unknown names in paper source {source!r}: {unknown}")
        return tokens

    expr = parse_expr(
        source,
        local_dict=dict(PAPER_SYMBOLS),
        global_dict={"Integer": sm.Integer, "Float": sm.Float, "__builtins__": {}},
        transformations=(check, *standard_transformations),
    )
    return expr


@dataclass(frozen=True)
class PaperEquation:
    """One numbered equation of the paper, as printed.

    Attributes
    ----------
    id : str
        The paper's number, e.g. ``'(10)'``.
    latex : str
        The LaTeX as printed (without the equation number).
    sources : tuple of str
        Sympy source of each line (one for a single equation or relation, two for the
        systems (5) and (23)).
    kind : {'equation', 'definition', 'relation'}
        ``relation`` for the inequalities (12)-(17).
    text : str
        What the paper says the equation is.
    """

    id: str
    latex: str
    sources: tuple[str, ...]
    kind: str
    text: str

    @cached_property
    def parsed(self) -> tuple[sm.Basic, ...]:
        """Each line of :attr:`sources`, parsed in the paper's symbols."""
        return tuple(parse_paper(s) for s in self.sources)

    @property
    def expr(self) -> sm.Basic:
        """The single parsed line (the first line of a system)."""
        return self.parsed[0]


_S = "Piecewise((2*(1 - cos(theta_1))/beta, theta_II >= 0), (2*((1 - cos(theta_II))/beta**4 + (cos(theta_II) - cos(theta_1))/beta), theta_II < 0))"  # noqa: E501

EQUATIONS: tuple[PaperEquation, ...] = (
    PaperEquation(
        "(1)",
        r"\ddot{\theta}(t) = \frac{g}{r_s} \sin \theta(t)",
        ("Eq(theta_ddot, g/r_s*sin(theta))",),
        "equation",
        "swing phase I-II (stance leg r_s) from the Lagrangian equations",
    ),
    PaperEquation(
        "(2)",
        r"\ddot{\theta}(\tau) = \frac{1}{\beta} \sin \theta(\tau)",
        ("Eq(theta_ddot, sin(theta)/beta)",),
        "equation",
        "(1) in dimensionless time tau = sqrt(g/r_e) t",
    ),
    PaperEquation(
        "(3)",
        r"\omega_{\text{III}} = \beta^2 \omega_{\text{II}}",
        ("Eq(omega_III, beta**2*omega_II)",),
        "equation",
        "leg extension: angular momentum about the stance foot conserved",
    ),
    PaperEquation(
        "(4)",
        r"\ddot{\theta}(\tau) = \sin \theta(\tau)",
        ("Eq(theta_ddot, sin(theta))",),
        "equation",
        "swing phase III-IV (stance leg r_e)",
    ),
    PaperEquation(
        "(5)",
        r"\begin{cases} \theta_1(n+1) = -(\varphi_0 - \theta_{\text{IV}}(n)) \\ "
        r"\beta \cos \theta_1(n+1) = \cos \theta_{\text{IV}}(n) \end{cases}",
        ("Eq(theta_1_next, -(varphi_0 - theta_IV))", "Eq(beta*cos(theta_1_next), cos(theta_IV))"),
        "equation",
        "geometric collision condition at heelstrike, with the exchange of legs",
    ),
    PaperEquation(
        "(6)",
        r"\omega_1(n+1) = \frac{\cos \varphi_0}{\beta} \omega_{\text{IV}}(n)",
        ("Eq(omega_1_next, cos(varphi_0)/beta*omega_IV)",),
        "equation",
        "heelstrike: angular momentum about the swing foot contact point conserved",
    ),
    PaperEquation(
        "(7)",
        r"\omega_1^2(n+1) = \beta^2 \cos^2 \varphi_0 \omega_1^2(n) + 2 \cos^2 \varphi_0 "
        r"[\cos \theta_{\text{II}} (\frac{1}{\beta^2} - \beta) - \cos \theta_1 "
        r"(\frac{1}{\beta} - \beta)]",
        (
            "Eq(omega_1_next**2, beta**2*cos(varphi_0)**2*omega_1**2 + 2*cos(varphi_0)**2"
            "*(cos(theta_II)*(1/beta**2 - beta) - cos(theta_1)*(1/beta - beta)))",
        ),
        "equation",
        "walking map in omega_1",
    ),
    PaperEquation(
        "(8)",
        r"q = \omega_1^2",
        ("Eq(q, omega_1**2)",),
        "definition",
        "the state variable",
    ),
    PaperEquation(
        "(9)",
        r"\mathbf{f}(q) = \beta^2 \cos^2 \varphi_0 q + 2 \cos^2 \varphi_0 [\cos "
        r"\theta_{\text{II}} (\frac{1}{\beta^2} - \beta) - \cos \theta_1 (\frac{1}{\beta} "
        r"- \beta)]",
        (
            "Eq(f_q, beta**2*cos(varphi_0)**2*q + 2*cos(varphi_0)**2"
            "*(cos(theta_II)*(1/beta**2 - beta) - cos(theta_1)*(1/beta - beta)))",
        ),
        "equation",
        "Poincare map, linear in q",
    ),
    PaperEquation(
        "(10)",
        r"q^f = \frac{2 \cos^2 \varphi_0 [\cos \theta_{\text{II}} (1 - \beta^3) - \cos "
        r"\theta_1 (\beta - \beta^3)]}{\beta^2 (1 - \cos^2 \varphi_0 \beta^2)}",
        (
            "Eq(q_f, 2*cos(varphi_0)**2*(cos(theta_II)*(1 - beta**3) - cos(theta_1)"
            "*(beta - beta**3))/(beta**2*(1 - cos(varphi_0)**2*beta**2)))",
        ),
        "equation",
        "fixed point",
    ),
    PaperEquation(
        "(11)",
        r"\theta_1 = -\arctan \frac{\beta - \cos \varphi_0}{\sin \varphi_0}",
        ("Eq(theta_1, -atan((beta - cos(varphi_0))/sin(varphi_0)))",),
        "equation",
        "stance leg angle at the Poincare section, from (5)",
    ),
    PaperEquation(
        "(12)",
        r"q^f > 0",
        ("q_f > 0",),
        "relation",
        "existence condition 1: q is positive",
    ),
    PaperEquation(
        "(13)",
        r"\frac{\cos \theta_{II}}{\cos \theta_1} > \frac{\beta - \beta^3}{1 - \beta^3}",
        ("cos(theta_II)/cos(theta_1) > (beta - beta**3)/(1 - beta**3)",),
        "relation",
        "(10) and (12) combined",
    ),
    PaperEquation(
        "(14)",
        r"q > \begin{cases} \frac{2(1 - \cos \theta_1)}{\beta} & \theta_{II} \geq 0 \\ "
        r"2\left[\frac{1 - \cos \theta_{II}}{\beta^4} + \frac{\cos \theta_{II} - \cos "
        r"\theta_1}{\beta}\right] & \theta_{II} < 0 \end{cases}",
        (f"q > {_S}",),
        "relation",
        "existence condition 2: pass the apex at mid-stance (no fall backward)",
    ),
    PaperEquation(
        "(15)",
        r"\beta > \cos \varphi_0",
        ("beta > cos(varphi_0)",),
        "relation",
        "existence condition 3a: theta_1 negative",
    ),
    PaperEquation(
        "(16)",
        r"\varphi_0 < \frac{\pi}{2}",
        ("varphi_0 < pi/2",),
        "relation",
        "existence condition 3b: angular velocity after heelstrike positive",
    ),
    PaperEquation(
        "(17)",
        r"\theta_{II} < \frac{\varphi_0}{2}",
        ("theta_II < varphi_0/2",),
        "relation",
        "existence condition 3c: the stance leg extends before heelstrike",
    ),
    PaperEquation(
        "(18)",
        r"E_r = \frac{1}{2} mgr_e q \tan^2 \varphi_0 \beta^2",
        ("Eq(E_r, Rational(1, 2)*m*g*r_e*q*tan(varphi_0)**2*beta**2)",),
        "equation",
        "dissipation at heelstrike as a function of beta and phi0",
    ),
    PaperEquation(
        "(19)",
        r"\lambda = \left. \frac{d\mathbf{f}}{dq} \right|_{q=q^f} = \beta^2 \cos^2 \varphi_0",
        ("Eq(lam, beta**2*cos(varphi_0)**2)",),
        "equation",
        "eigenvalue of the Jacobian of the map",
    ),
    PaperEquation(
        "(20)",
        r"E_c = -\frac{1}{2}mgr_e(\beta^2 - \beta^4)q + mgr_e[(1 - \beta^3)\cos\theta_{II} "
        r"- (\beta - \beta^3)\cos\theta_I]",
        (
            "Eq(E_c, -Rational(1, 2)*m*g*r_e*(beta**2 - beta**4)*q + m*g*r_e*((1 - beta**3)"
            "*cos(theta_II) - (beta - beta**3)*cos(theta_I)))",
        ),
        "equation",
        "complementary energy of the leg extension",
    ),
    PaperEquation(
        "(21)",
        r"E_r = \frac{1}{2}mgr_e\beta^4(1 - \cos^2\varphi_0)q + mgr_e(1 - \cos^2\varphi_0)"
        r"[(1 - \beta^3)\cos\theta_{II} - (\beta - \beta^3)\cos\theta_I]",
        (
            "Eq(E_r, Rational(1, 2)*m*g*r_e*beta**4*(1 - cos(varphi_0)**2)*q + m*g*r_e"
            "*(1 - cos(varphi_0)**2)*((1 - beta**3)*cos(theta_II) - (beta - beta**3)"
            "*cos(theta_I)))",
        ),
        "equation",
        "dissipation energy at heelstrike",
    ),
    PaperEquation(
        "(22)",
        r"E_\Delta = E_c - E_r",
        ("Eq(E_Delta, E_c - E_r)",),
        "definition",
        "net change of mechanical energy in one step",
    ),
    PaperEquation(
        "(23)",
        r"E_\Delta = -\frac{1}{2}mgr_e\beta^2(1 - \beta^2\cos^2\varphi_0)q + C, \quad "
        r"C = mgr_e\cos^2\varphi_0[(1 - \beta^3)\cos\theta_{II} - (\beta - \beta^3)"
        r"\cos\theta_I]",
        (
            "Eq(E_Delta, -Rational(1, 2)*m*g*r_e*beta**2*(1 - beta**2*cos(varphi_0)**2)*q + C)",
            "Eq(C, m*g*r_e*cos(varphi_0)**2*((1 - beta**3)*cos(theta_II) - (beta - beta**3)"
            "*cos(theta_I)))",
        ),
        "equation",
        "(20) and (21) substituted into (22)",
    ),
)
"""The 23 numbered equations, in order."""

EQUATION_BY_ID: dict[str, PaperEquation] = {e.id: e for e in EQUATIONS}
"""The equations keyed by their number, ``'(1)'`` ... ``'(23)'``."""
