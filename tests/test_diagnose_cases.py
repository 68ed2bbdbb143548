"""Hidden-effect cases of the identification workbench, first file: velocity_limit (the full
20 s experiment) and three more. The check and the reasons for its short experiment are in
tests/hidden_effect_cases.py; the other cases are tests/test_diagnose_more_cases.py."""

import pytest

from hidden_effect_cases import check_found_and_fitted, first_file_cases


@pytest.mark.parametrize("effect", first_file_cases())
def test_hidden_effect_is_found_and_fitted(effect):
    check_found_and_fitted(effect)
