"""Case 18: HZD gait optimisation (vsw hzd --optimize) against full-order collocation
(vsw optimize) on the three-link biped at 0.8 m/s, step 2 r sin(pi/8) = 0.765 m (the
constraints file's theta_plus = -pi/8 and theta_minus = pi/8 fix it), minimising the
inputs' squared integral (torque2, (N m)^2 s), one run each, CPU time (the machine is
shared).

* ``vsw hzd --optimize`` on examples/hzd/three_link_mirror_invariant.py (two Bezier
  outputs of degree 6, ten free coefficients): impact invariant, the swing foot above the
  ground away from mid-stance, verified on the full-order closed loop (its periodic orbit
  and eigenvalues);
* ``vsw optimize --model three-link-biped`` (Hermite-Simpson collocation of the full-order
  step, 80 intervals: at 20 and 40 its re-simulation misses the last knot by 5e-5 and 3e-6
  and it reports not-converged), its default: no clearance, an open-loop gait.

The target: the HZD optimum verified, and its cost not below the full-order optimum's (the
gaits on a surface of this family are a subset of the full-order gaits of that speed and
step; the surface and the clearance cost the rest).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CONSTRAINTS = ROOT / "examples" / "hzd" / "three_link_mirror_invariant.py"
SPEED = 0.8
STEP = 2 * math.sin(math.pi / 8)
COLLOCATION_NODES = 80


def case_hzd_optimize(quick: bool, Row, Timing) -> list:
    """The rows of case 18 (``quick``: the same runs, no target claimed; each is one run)."""
    from vsw.hzd import DEFAULT_GAINS
    from vsw.hzd.optimize import HzdRequest, optimize
    from vsw.models import key, load
    from vsw.powered import Request
    from vsw.powered import optimize as collocate

    model = load("three-link-biped")
    params = model.parameters()
    begin = time.process_time()
    request = HzdRequest(speed=SPEED, minimize="torque2", clearance=0.0)
    hzd = optimize(model, key("three-link-biped"), str(CONSTRAINTS), None, request, DEFAULT_GAINS)
    t_hzd = time.process_time() - begin
    begin = time.process_time()
    against = Request("torque2", target_speed=SPEED, target_step_length=STEP,
                      nodes=COLLOCATION_NODES)  # fmt: skip
    full = collocate(model, params, against)
    t_full = time.process_time() - begin
    loop = None if hzd.report is None else hzd.report.full_order
    eigen = math.nan if loop is None else loop.max_abs_eigenvalue
    met = hzd.optimal and full.status == "optimal" and hzd.objective >= full.cost * (1 - 1e-6)
    met = None if quick else met  # a quick run claims no target
    return [Row(
        "18", f"vsw hzd --optimize --model three-link-biped --constraints "
        f"three_link_mirror_invariant.py --speed {SPEED:g} (step {STEP:.6g} m): "
        f"{'optimal, verified' if hzd.optimal else 'NOT optimal'}, torque2 "
        f"{hzd.objective:.6g} (N m)^2 s",
        f"vsw optimize --model three-link-biped --target-speed {SPEED:g} --target-step-length "
        f"{STEP:.6g} --nodes {COLLOCATION_NODES}: {full.status}, torque2 {full.cost:.6g} "
        "(N m)^2 s",
        Timing.of([t_hzd]), Timing.of([t_full]),
        "HZD optimum verified; its cost >= the full-order optimum's", met,
        note=f"CPU seconds, one run each; cost ratio HZD/full order "
        f"{hzd.objective / full.cost:.4g}; HZD: {hzd.iterations} IPOPT iterations, "
        f"build {hzd.build_seconds:.2f} s, solve {hzd.solve_seconds:.2f} s, the rest the "
        f"runtime's verification; full-order loop max |eigenvalue| {eigen:.4g}; vsw optimize "
        "has no clearance by default and gives an open-loop gait",
        extra={"hzd_cost": hzd.objective, "full_order_cost": full.cost,
               "hzd_failures": hzd.failures, "full_order_status": full.status},
    )]  # fmt: skip
