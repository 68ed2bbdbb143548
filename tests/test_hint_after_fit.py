"""diagnose never proposes freeing what the fit that made its model freed (issue 22): the advice
would loop (`fit --free I`, then diagnose says `--free I`). It proposes what else sets the same
thing (the plant file's hint ``also``), and says the fit freed the first already."""

import pytest

from pendc import load_model
from pendc.errors import PendcError
from pendc.ident.evidence import parameter_hint
from pendc.model.model_writer import dumps_fitted
from pendc.model.modelfile import default_model_path, fitted_parameters, parse_model

PERIOD_OFF = [{"target": "pendulum acceleration", "signal": "theta", "r": -0.58},
              {"target": "pendulum acceleration", "signal": "dtheta", "r": -0.54},
              {"target": "pendulum acceleration", "signal": "cos(theta)", "r": 0.01}]


def test_the_period_hint_frees_i_then_l_never_i_twice():
    model = load_model()
    assert parameter_hint(model, PERIOD_OFF) == ("I,b_theta", "the swing's period is off (free I, or L); "
                                                               "the pivot damping is off")
    params, reason = parameter_hint(model, PERIOD_OFF, fitted=("I",))
    assert params.split(",") == ["L", "b_theta"]
    assert "freed I already: what else sets it is L" in reason
    params, _ = parameter_hint(model, PERIOD_OFF, fitted=("I", "b_theta"))
    assert params == "L"
    assert parameter_hint(model, PERIOD_OFF, fitted=("I", "L", "b_theta")) is None


def test_the_fitted_parameters_come_from_the_fitted_files_meta(tmp_path):
    source = default_model_path().read_text(encoding="utf-8")
    model = parse_model(source)
    text = dumps_fitted(model, source, {"generator": "pendc fit", "fitted": "I, b_theta"}, {})
    path = tmp_path / "fitted.toml"
    path.write_text(text, encoding="utf-8")
    assert fitted_parameters(path) == ("I", "b_theta")
    assert fitted_parameters(default_model_path()) == () and fitted_parameters(None) == ()
    plain = tmp_path / "plain.toml"
    plain.write_text(text.replace('generator = "pendc fit"', 'generator = "by hand"'), encoding="utf-8")
    assert fitted_parameters(plain) == ()


def test_a_hint_naming_an_unknown_also_is_refused(tmp_path):
    text = default_model_path().read_text(encoding="utf-8").replace('also = ["L"]', 'also = "L"')
    with pytest.raises(PendcError, match=r"identification\.hints\[0\].*also.*list of names"):
        parse_model(text, source="bad.toml")
