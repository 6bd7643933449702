"""``vsw hzd`` on constraints whose step cannot close: a surface whose swing foot is not on
the ground at theta_minus, outputs that do not vanish after the impact (an impact moves no
coordinate), and a model whose phase holds a coordinate (the level compass gait's leg
length) derived with it put in. Each a one-line verdict, exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from vsw.cli import main

pytest.importorskip("casadi")

HEADER = (
    "import sympy as sm\nfrom derive.hzd import THETA, Constraints, coordinates\nEND = sm.pi / 8\n"
)
THREE_LINK = HEADER + 'theta1, theta2, theta3 = coordinates("theta1", "theta2", "theta3")\n'


def _run(capsys, tmp_path: Path, model: str, text: str) -> tuple[int, str]:
    path = tmp_path / "constraints.py"
    path.write_text(text)
    code = main(["hzd", "--model", model, "--constraints", str(path)])
    _, err = capsys.readouterr()
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return code, err


def test_a_swing_foot_off_the_ground_at_the_step_end_is_refused(capsys, tmp_path):
    # Legs at 0.4 and -0.3 rad: the swing foot is r (cos 0.3 - cos 0.4) = 0.034 m from the
    # ground, by hand; the phase after the impact (the legs swapped) is -0.3 = theta_plus.
    code, err = _run(capsys, tmp_path, "three-link-biped", THREE_LINK + (
        "CONSTRAINTS = Constraints(phase=theta1, theta_plus=-0.3, theta_minus=0.4, "
        "outputs={theta2: 0.1 - THETA, theta3: sm.pi / 6})\n"))  # fmt: skip
    assert code == 2 and "does not end at theta_minus" in err


def test_outputs_that_do_not_vanish_after_the_impact_are_refused(capsys, tmp_path):
    # The torso's desired angle rises by 1/5 rad over the step; the impact keeps the torso
    # where it was, so after it the output is 0.2 rad.
    code, err = _run(capsys, tmp_path, "three-link-biped", THREE_LINK + (
        "S = (THETA + END) / (2 * END)\n"
        "CONSTRAINTS = Constraints(phase=theta1, theta_plus=-END, theta_minus=END, "
        "outputs={theta2: -THETA + (THETA**2 - END**2) / 2, "
        "theta3: sm.pi / 6 + S / 5})\n"))  # fmt: skip
    assert code == 2 and "off the constraint surface" in err and "0.2" in err


@pytest.mark.slow  # a derivation of the level compass gait's constraints (about 10 s)
def test_a_held_coordinate_is_put_in(capsys, tmp_path):
    # The level compass gait holds its stance leg's length r at a + b: the derivation must
    # substitute it; with the swing leg mirroring the stance leg and no push-off the zero
    # dynamics stop before the step ends (level ground gives no energy back).
    code, err = _run(capsys, tmp_path, "level-compass-gait", HEADER + (
        'theta, psi = coordinates("theta", "psi")\n'
        "CONSTRAINTS = Constraints(phase=theta, theta_plus=-END, theta_minus=END, "
        "outputs={psi: -THETA + (THETA**2 - END**2) / 2})\n"))  # fmt: skip
    assert code == 2 and "zeta reaches 0" in err
