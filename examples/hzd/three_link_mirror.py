"""Virtual constraints for the three-link biped (``vsw hzd --model three-link-biped
--constraints examples/hzd/three_link_mirror.py``): the torso held at pi/6 (leaning
forward), the swing leg mirroring the stance leg with a bump, the phase the stance leg's
angle from -pi/8 just after heelstrike to pi/8 at the next.

``theta2 = -theta1 + (theta1^2 - (pi/8)^2)/2``: the bump is zero at both ends of the step,
so the configuration after the impact is on the surface, but the rates are not (the
outputs' rates jump at every impact: not impact invariant, Westervelt, Grizzle & Koditschek
2003, Section V-B). The step is 2 r sin(pi/8) long; the swing foot scuffing the ground near
mid-stance is ignored.
"""

import sympy as sm

from derive.hzd import THETA, Constraints, coordinates

theta1, theta2, theta3 = coordinates("theta1", "theta2", "theta3")
END = sm.pi / 8

CONSTRAINTS = Constraints(
    title="torso at pi/6, the swing leg mirroring the stance leg",
    phase=theta1,
    theta_plus=-END,
    theta_minus=END,
    outputs={
        theta2: -THETA + (THETA**2 - END**2) / 2,
        theta3: sm.pi / 6,
    },
)
