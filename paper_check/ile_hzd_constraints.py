"""The ILE's virtual constraints on the point-mass biped (``point_mass_biped_switch``):
the instantaneous leg extension model of Virtual Slope Walking as a hybrid zero dynamics.

The body is the ILE's: a point mass on two massless telescoping legs. Its leg force alone
enforces the constraint (the stance torque idles: ``inputs``), so the walker has one degree
of underactuation and the leg force no moment about the stance foot.

* Phase: the stance leg's angle from the vertical, ``theta = atan2(x, y)`` (the paper's
  theta: negative just after heelstrike, (11)).
* Output: the stance leg's length ``sqrt(x^2 + y^2)`` minus ``h_d(theta)``, ``h_d = r_s``
  before ``theta_II`` and ``r_c`` after: a :class:`~derive.hzd.Step`, the instantaneous
  extension (instants II to III). The configuration is otherwise unchanged and the leg's
  impulse acts along the leg, through the stance foot, so ``sigma`` is continuous while
  ``I(theta) = m r^2`` jumps: (3), ``omega_III = beta^2 omega_II``.
* ``r_c`` is the model's ``l`` and ``r_s = beta r_c`` its ``l_min``.
* The heelstrike: the model's legs exchange where the hip passes ``x = sigma d`` and the new
  foot lands ``d`` ahead. The ILE's, at the inter-leg angle ``phi0`` with the geometry (5)
  (``beta cos theta_I = cos theta_IV``, ``theta_IV = theta_I + phi0``), is that event at
  ``sigma d = r_c sin theta_IV`` and ``(1 - sigma) d = -r_s sin theta_I``: so no other
  model is needed, only those parameter values (:func:`switch_parameters` in
  :mod:`paper_check.hzd_ile`). Just after it the new stance leg is ``r_s`` long (both feet
  are on the ground); its impulse along itself (``heel_strike``, no moment about the new
  foot) removes the hip's velocity along it, as the ILE's rigid leg does.
* ``theta_plus = theta_I = -asin((1 - sigma) d / r_s)``, ``theta_minus = theta_IV =
  asin(sigma d / r_c)``.

``theta_II`` is the constraints' own parameter (value 0: the extension at mid-stance).
"""

import sympy as sm

from derive.hzd import THETA, Constraints, Step, coordinates, value

x, y = coordinates("x", "y")
l, d, l_min, sigma = sm.symbols("l d l_min sigma", positive=True)
theta_II = sm.Symbol("theta_II", real=True)

CONSTRAINTS = Constraints(
    phase=sm.atan2(x, y),
    theta_plus=-sm.asin((1 - sigma) * d / l_min),
    theta_minus=sm.asin(sigma * d / l),
    outputs={sm.sqrt(x**2 + y**2): Step(at=theta_II, before=l_min, after=l)},
    inputs=("leg_force",),
    inverse={x: value(0) * sm.sin(THETA), y: value(0) * sm.cos(THETA)},
    parameters={"theta_II": 0.0},
    title="The ILE: the stance leg r_s long, then r_c from theta_II on",
)
