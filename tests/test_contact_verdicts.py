"""The solve's verdicts on each contact: when it lets go or slips ("at the start",
"never", "open at the start"), with the condition as a student states it and a hint
where the file is probably written the wrong way round."""

from __future__ import annotations

import pytest

import lamech

PENDULUM = lamech.problem.example_path("pendulum").read_text(encoding="utf-8")


# ----- "does it roll at all?", "does it leave at once?": answered, not "never" ----------
def _verdicts(text: str):
    s = lamech.solve(lamech.loads(text, "x.toml"))
    return s, lamech.to_text(s)


@pytest.mark.slow
def test_a_disk_that_slips_at_once_says_so_with_the_rolling_condition():
    """tan(alpha) > 3 mu: the friction a rolling disk needs (m g sin(alpha)/3) exceeds
    mu N (N = m g cos(alpha)) from the first instant."""
    base = lamech.problem.example_path("incline_disk").read_text(encoding="utf-8")
    text = base.replace("mu = 0.3", "mu = 0.05")
    assert text != base
    s, report = _verdicts(text)
    v = s.slipping["rolling"]
    assert v.when == "at the start"
    alpha = s.system.parameter_values[s.symbols["alpha"]]
    import math

    assert f"= {math.tan(alpha) / 3:.6g} > mu = 0.05" in v.reason
    assert v.condition == "mu >= tan(alpha)/3"
    assert "rolling: at the start" in report and "never" not in report.split("slip")[1][:80]
    rolls = lamech.solve(lamech.load("incline_disk")).slipping["rolling"]
    assert rolls.when == "never" and rolls.constant  # mu = 0.3 >= tan(alpha)/3


def test_a_string_written_the_wrong_way_round_is_flagged():
    text = PENDULUM.replace('f = "l - r"', 'f = "r - l"')
    assert text != PENDULUM
    s, report = _verdicts(text)
    v = s.lets_go["string"]
    g, m, theta0 = (s.system.parameter_values[s.symbols[n]] for n in ("g", "m", "theta0"))
    import math

    assert v.when == "at the start"
    assert f"= {-m * g * math.cos(theta0):.6g} < 0" in v.reason  # minus the tension
    assert "wrong way round" in v.hint and "wrong way round" in report
    assert "never" not in report.split("lets go")[1][:200]


def test_a_particle_too_fast_on_top_of_the_sphere_leaves_at_once():
    """m v^2/R > m g at the top: the sphere would have to pull; it lets go at t = 0."""
    base = lamech.problem.example_path("sphere_slide").read_text(encoding="utf-8")
    text = base.replace(
        "theta = { initial = 0, velocity = 0 }", "theta = { initial = 0, velocity = 4 }"
    )
    assert text != base
    s, report = _verdicts(text)
    v = s.lets_go["contact"]
    g, m, R = (s.system.parameter_values[s.symbols[n]] for n in ("g", "m", "R"))
    assert v.when == "at the start" and v.hint is None  # moving: no sign suspicion
    assert f"= {m * g - m * R * 16:.6g} < 0" in v.reason
    assert "contact: at the start" in report
    # the condition as a student states it (m R theta'0^2 <= m g, theta'0 = 4): m dropped
    assert v.condition == "g >= 16*R"


@pytest.mark.parametrize(
    "name, constraint, expected",
    [
        pytest.param(
            "wedge",
            "contact",
            lambda p: (
                p["M"]
                * p["m"]
                * p["g"]
                * __import__("math").cos(p["alpha"])
                / (p["M"] + p["m"] * __import__("math").sin(p["alpha"]) ** 2)
            ),
            marks=pytest.mark.slow,
        ),
        ("incline_disk", "contact", lambda p: p["m"] * p["g"] * __import__("math").cos(p["alpha"])),
    ],
)
def test_a_constant_positive_multiplier_never_lets_go(name, constraint, expected):
    """The block on a movable wedge keeps N = M m g cos(a)/(M + m sin^2 a) (textbook); a
    disk rolling down an incline N = m g cos(a): 'never', with the constant, not 'not
    determined'."""
    s = lamech.solve(lamech.load(name))
    v = s.lets_go[constraint]
    p = {k.name: x for k, x in s.system.parameter_values.items()}
    assert v.when == "never" and v.constant
    assert f"= {expected(p):.6g} > 0" in v.reason
    assert f"{constraint}: never (lambda_{constraint} is constant" in lamech.to_text(s)
