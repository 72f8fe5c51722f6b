"""Issue 5, section 3: the stability suite. Each case of tests/stability_cases.py (shared with
`scripts/bench stability`, which prints the table) runs to its end with no NaN or infinity, no rise of the
objective inside a step beyond round-off, and its stated result within its bound."""

import pytest

import stability_cases


@pytest.mark.parametrize("case", stability_cases.CASES, ids=[c.name for c in stability_cases.CASES])
def test_case(case):
    out = case.run(quick=True)
    assert out.finite, f"{case.name}: a step produced NaN or infinity"
    assert out.rise <= 1.0, f"{case.name}: the objective rose inside a step by {out.rise:.3g} x round-off"
    assert out.figure <= out.bound, f"{case.name}: {out.what} = {out.figure:.3g} > {out.bound:g} ({out.notes})"
    for what, figure, bound in out.extra:
        assert figure <= bound, f"{case.name}: {what} = {figure:.3g} > {bound:g}"


def test_case_names_are_unique():
    names = [c.name for c in stability_cases.CASES]
    assert len(names) == len(set(names))
