"""Hidden-effect cases of the identification workbench, second file: every case that
tests/test_diagnose_cases.py does not run (the check is in tests/hidden_effect_cases.py)."""

import pytest

from hidden_effect_cases import CASES, FIRST_FILE, check_found_and_fitted, other_cases


def test_the_first_file_names_only_existing_cases():
    # a case renamed in the catalogue but not in FIRST_FILE would silently run in neither file
    assert set(FIRST_FILE) <= set(CASES), sorted(set(FIRST_FILE) - set(CASES))


@pytest.mark.parametrize("effect", other_cases())
def test_hidden_effect_is_found_and_fitted(effect):
    check_found_and_fitted(effect)
