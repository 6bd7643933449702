"""Impact-invariant virtual constraints for RABBIT (``vsw hzd --model rabbit --constraints
examples/hzd/rabbit_walk.py``): the phase the mean of the stance tibia's and femur's
angles (an affine stand-in for the virtual stance leg's angle, hip to stance foot), from
-0.3 rad just after heelstrike to 0.3 rad at the next; four outputs, the stance knee's
flexion ``theta_t - theta_f``, the torso ``phi`` and the swing femur's and tibia's angles
``psi_f``, ``psi_t``, each a Bezier polynomial of degree 5 in the normalised phase whose
first two coefficients the impact map sets (Westervelt, Grizzle & Koditschek 2003, IEEE TAC
48(1), Theorem 4's construction).

How it was obtained. The rough start below (both knees bent 0.4 rad, the torso at 0.15
rad, the swing femur swept at a constant rate from 0.1 to -0.5 rad with its knee flexing
to 1 rad at mid-step; it has a gait on the zero dynamics, 0.52 m/s, but its swing foot
goes under the ground before theta_minus, so the full-order loop has none) was optimised
by ``vsw hzd --model rabbit --constraints START --optimize --speed 0.6 --step-length 0.45
--out examples/hzd/rabbit_walk.py`` (least ``integral |u|^2 dt``, the swing foot above the
ground away from mid-stance and on it at theta_minus; 49 IPOPT iterations), which appended
the optimum's coefficients below, verified on the full-order closed loop (gains 400, 40).
The optimum leans the torso forward (its coefficients 0.23 to 0.45 rad).
"""

import sympy as sm

from derive.hzd import Constraints, InvariantBezier, S, bezier_of, coordinates

theta_t, theta_f, phi, psi_f, psi_t = coordinates("theta_t", "theta_f", "phi", "psi_f", "psi_t")
DEGREE = 5
END = sm.Float(0.3)
KNEE = sm.Float(0.4)

swing_femur = (END - KNEE / 2) * (1 - S) + (-END - KNEE / 2) * S
swing_knee = KNEE + sm.Rational(24, 10) * S * (1 - S)


def _later(expr):
    return InvariantBezier(tuple(bezier_of(expr + 0 * S, DEGREE)[2:]))


CONSTRAINTS = Constraints(
    title="RABBIT at 0.6 m/s, step 0.45 m, least squared torques",
    phase=(theta_t + theta_f) / 2,
    theta_plus=-END,
    theta_minus=END,
    outputs={
        theta_t - theta_f: _later(KNEE + 0 * S),
        phi: _later(sm.Float(0.15) + 0 * S),
        psi_f: _later(swing_femur),
        psi_t: _later(swing_femur + swing_knee),
    },
)

# The optimum of: vsw hzd --model rabbit --constraints START --optimize --speed 0.6
# --step-length 0.45 (START: the text above)
import dataclasses as _dataclasses  # noqa: E402

from derive.hzd import InvariantBezier as _InvariantBezier  # noqa: E402

CONSTRAINTS = _dataclasses.replace(
    CONSTRAINTS,
    outputs=dict(
        zip(
            CONSTRAINTS.outputs,
            (
                _InvariantBezier(
                    (
                        -0.07611292498551114,
                        -0.004372970159865641,
                        0.6244828003798177,
                        0.6240650068399423,
                    )
                ),
                _InvariantBezier(
                    (
                        0.32511755154760485,
                        0.22695799379539702,
                        0.44570033509633744,
                        0.36849822911999885,
                    )
                ),
                _InvariantBezier(
                    (
                        0.09056352000464636,
                        -1.2802705623650341,
                        -1.109104707415815,
                        -0.6120325034199714,
                    )
                ),
                _InvariantBezier(
                    (0.8193293554875326, 1.815539610819129, 0.811146480164351, 0.012032503419971375)
                ),
            ),
        )
    ),
)  # outputs -theta_f + theta_t, phi, psi_f, psi_t
