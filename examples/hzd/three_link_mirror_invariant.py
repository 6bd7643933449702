"""Impact-invariant virtual constraints for the three-link biped (``vsw hzd --model
three-link-biped --constraints examples/hzd/three_link_mirror_invariant.py``): the
mirror design of ``three_link_mirror.py`` as Bezier polynomials of degree 6 in the
normalised phase s, its last coefficients (the step's second half and its pre-impact
configuration and rates) kept, its first two set by the impact map at run time
(Westervelt, Grizzle & Koditschek 2003, IEEE TAC 48(1), Theorem 4's construction): just
after each impact from the surface the outputs and their rates are zero, so the zero
dynamics are a true hybrid zero dynamics.
"""

import sympy as sm

from derive.hzd import Constraints, InvariantBezier, S, bezier_of, coordinates

theta1, theta2, theta3 = coordinates("theta1", "theta2", "theta3")
END = sm.pi / 8
DEGREE = 6

# The mirror design in s (theta1 = -END + 2 END s): exactly a polynomial of degree two.
theta = -END + 2 * END * S
swing = bezier_of(-theta + (theta**2 - END**2) / 2, DEGREE)
torso = bezier_of(sm.pi / 6 + 0 * S, DEGREE)

CONSTRAINTS = Constraints(
    title="the mirror design, impact invariant",
    phase=theta1,
    theta_plus=-END,
    theta_minus=END,
    outputs={
        theta2: InvariantBezier(swing[2:]),
        theta3: InvariantBezier(torso[2:]),
    },
)
