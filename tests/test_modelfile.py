"""Model files: the shipped thesis models, round trips and clear errors."""

from pathlib import Path

import pytest

from pendc.errors import PendcError
from pendc.model.modelfile import default_model_path, load_model, parse_model
from pendc.model.model_writer import dumps_model, save_model

ROOT = Path(__file__).resolve().parents[1]


def test_default_is_table_14():
    m = load_model()
    assert default_model_path() == ROOT / "models" / "sct_thesis_final.toml"
    v = m.parameter_values()
    assert v["b_x"] == 877.31327 and v["alpha"] == 260.78841 and v["V_off"] == 5.264616
    assert v["mu_c"] == 0.1331798 and v["mu_s"] == 0.1035951 and v["gamma"] == 1.0
    assert list(m.effects) == ["drive", "viscous_cart", "stribeck_cart", "viscous_pendulum", "velocity_limit"]


def test_initial_is_table_3():
    v = load_model(ROOT / "models" / "sct_thesis_initial.toml").parameter_values()
    assert v["b_x"] == 155.1574 and v["alpha"] == 51.525 and v["mu_s"] == 0.03709 and v["b_theta"] == 0.01


def test_round_trip_is_exact_and_deterministic(tmp_path):
    m = load_model()
    path = tmp_path / "m.toml"
    save_model(m, path, meta={"note": 'has "quotes"', "fit_x": 97.5})
    again = load_model(path)
    assert again == m
    assert dumps_model(again) == dumps_model(m)


def test_effect_order_in_the_file_does_not_matter():
    a = parse_model('[plant]\ng=9.8\nM=100.0\nm=0.5\nL=0.1\nI=0.006\n[effects.viscous_cart]\nb_x=1.0\n'
                    '[effects.drive]\nalpha=50.0\nV_off=5.0\n')
    b = parse_model('[plant]\ng=9.8\nM=100.0\nm=0.5\nL=0.1\nI=0.006\n[effects.drive]\nalpha=50.0\nV_off=5.0\n'
                    '[effects.viscous_cart]\nb_x=1.0\n')
    assert a == b and list(a.effects) == list(b.effects)


PLANT = "[plant]\ng=9.8\nM=100.0\nm=0.5\nL=0.1\nI=0.006\n"


@pytest.mark.parametrize("text, message", [
    ("this is = = not toml", "not valid TOML"),
    ("[effects.drive]\nalpha=1.0\nV_off=5.0\n", "missing \\[plant\\]"),
    (PLANT.replace("I=0.006\n", ""), "lacks I"),
    (PLANT + "J=1.0\n", "unknown constant"),
    (PLANT.replace("M=100.0", "M=-1.0"), "must be positive"),
    (PLANT + "[effects.frobnicate]\nx=1.0\n", "unknown effect 'frobnicate'"),
    (PLANT + "[effects.drive]\nalpha=1.0\nV_off=5.0\nbeta=2.0\n", "no parameter 'beta'"),
    (PLANT + "[unknown]\n", "unknown top-level"),
    (PLANT + "[fit]\nfree = ['nope']\n", "unknown parameter 'nope'"),
    (PLANT + "[fit]\nfree = 3\n", "list of parameter names"),
])
def test_bad_model_files(text, message):
    with pytest.raises(PendcError, match=message) as info:
        parse_model(text, source="bad.toml")
    assert "\n" not in str(info.value) and "bad.toml" in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(PendcError, match="not found"):
        load_model(tmp_path / "none.toml")


def test_save_into_missing_folder_writes_nothing(tmp_path):
    with pytest.raises(PendcError, match="does not exist"):
        save_model(load_model(), tmp_path / "no" / "m.toml")
    assert not (tmp_path / "no").exists()


def test_fitted_file_keeps_comments_and_intervals_and_reads_back(tmp_path):
    from pendc.model.modelfile import parse_model
    from pendc.model.model_writer import dumps_fitted

    source = "# our rig, measured 2024\n[plant]\ng = 9.81  # local g\nM = 100.0\nm = 0.5\nL = 0.1\nI = 0.005\n" \
             "\n[effects.drive]\nalpha = 250.0\nV_off = 5.0\n[fit]\nfree = ['alpha']\n"
    model = parse_model(source).with_params({"alpha": 260.5}).with_effect("viscous_pendulum", {"b_theta": 0.002})
    text = dumps_fitted(model, source, {"data": "a.csv (sha256 0123)"}, {"alpha": [259.0, 262.0],
                                                                          "b_theta": [float("-inf"), float("inf")]})
    assert "# our rig, measured 2024" in text and "g = 9.81  # local g" in text and "alpha = 260.5" in text
    back = parse_model(text)
    assert back == model
    import tomllib
    doc = tomllib.loads(text)
    assert doc["fit"]["intervals"] == {"alpha": [259.0, 262.0]} and doc["meta"]["data"].startswith("a.csv")
    # a layout the line editor cannot follow (inline table) still gives the exact model
    inline = "[plant]\ng = 9.81\nM = 100.0\nm = 0.5\nL = 0.1\nI = 0.005\n[effects]\ndrive = {alpha = 250.0, V_off = 5.0}\n"
    model2 = parse_model(inline).with_params({"alpha": 255.0})
    assert parse_model(dumps_fitted(model2, inline, {}, {"alpha": [254.0, 256.0]})) == model2


def test_bad_intervals_are_one_line_errors():
    with pytest.raises(PendcError, match=r"fit.intervals.k_c must be \[low, high\]"):
        parse_model(PLANT + "[fit.intervals]\nk_c = 3\n")


def test_a_folder_is_named_as_a_folder(tmp_path):
    with pytest.raises(PendcError, match=r"m\.toml: is a folder, not a model file$"):
        (tmp_path / "m.toml").mkdir() or load_model(tmp_path / "m.toml")


def test_not_utf8_is_one_line_naming_the_file(tmp_path):
    (tmp_path / "m.toml").write_bytes(b"[plant]\n# Gewicht \xe4\ng = 9.81\n")
    with pytest.raises(PendcError, match=r"m\.toml: line 2: not UTF-8 text"):
        load_model(tmp_path / "m.toml")


def stdin_bytes(monkeypatch, data: bytes):
    import io
    import sys

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data), encoding="utf-8"))


def test_dash_is_standard_input_named_stdin(monkeypatch):
    stdin_bytes(monkeypatch, default_model_path().read_bytes())
    m = load_model("-")
    assert m == load_model() and m.source == "<stdin>"
    stdin_bytes(monkeypatch, PLANT.replace("M=100.0", "M=-1.0").encode())
    with pytest.raises(PendcError, match=r"^<stdin>: .*must be positive"):
        load_model("-")


def test_fingerprint_is_the_model_not_its_file():
    from pendc.model.modelfile import build_source, model_fingerprint

    base = parse_model(PLANT + "[effects.drive]\nalpha=50.0\nV_off=5.0\n", source="a.toml")
    same = [
        parse_model("# another layout\n[effects.drive]\nV_off = 5.0\nalpha = 50.0\n[plant]\n"
                    "I=0.006\nL=0.1\nm=0.5\nM=100.0\ng=9.8\n[meta]\nnote = 'x'\n[fit]\nfree = ['alpha']\n",
                    source="elsewhere/b.toml"),
    ]
    other = [
        parse_model(PLANT.replace("M=100.0", "M=100.5") + "[effects.drive]\nalpha=50.0\nV_off=5.0\n"),
        parse_model(PLANT + "[effects.drive]\nalpha=50.0\nV_off=5.0\n[effects.viscous_cart]\nb_x=1.0\n"),
        parse_model(PLANT + "[effects.drive]\nalpha=50.0\nV_off=5.0\n[hardware]\ntraining_scale = 0.5\n"),
    ]
    fp = model_fingerprint(base)
    assert fp.startswith("sha256:") and len(fp) == 7 + 16
    assert [model_fingerprint(m) for m in same] == [fp]
    assert len({fp, *(model_fingerprint(m) for m in other)}) == 1 + len(other)
    assert fp in build_source(base) and "a.toml" not in build_source(base)


def test_fingerprint_and_build_key_ignore_what_no_build_reads():
    """Identification advice, operating points and the drawing are read by diagnose, hil and
    animate, never by the compile: editing them rebuilds nothing (same fingerprint, same cached
    build); a renamed core is another Verilog module, so another build."""
    from pendc.caching.build_cache import build_key
    from pendc.model.modelfile import default_model_path, model_fingerprint
    from pendc.passes.pipeline import BuildOptions

    text = default_model_path().read_text(encoding="utf-8")
    base = parse_model(text, source="a.toml")
    advice = parse_model(text.replace('also = ["L"]', 'also = ["L", "g"]'), source="a.toml")
    assert advice.definition.notes != base.definition.notes
    assert model_fingerprint(advice) == model_fingerprint(base)
    assert build_key(advice, BuildOptions()) == build_key(base, BuildOptions())
    core = base.definition.core
    renamed = parse_model(text.replace(f'core = "{core}"', 'core = "my_core"'), source="a.toml")
    assert renamed.definition.core == "my_core" and model_fingerprint(renamed) != model_fingerprint(base)
    assert build_key(renamed, BuildOptions()) != build_key(base, BuildOptions())
