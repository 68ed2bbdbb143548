"""Command-line conventions (issue 11, point 7): every option says what it does.

Walks the whole argparse tree of ``pendc`` (every subcommand, every option and positional)
and asserts each has a help string; ``fit --help`` and ``diagnose --help`` list the effects.
"""

import argparse

import pytest

from pendc.cli import build_parser, main
from plants import CATALOGUE


def actions(parser, path=()):
    """(command path, option name, action) for every action of every (sub)parser."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from actions(sub, path + (name,))
        elif not isinstance(action, argparse._HelpAction):
            yield path, (action.option_strings[-1] if action.option_strings else action.dest), action


def cases():
    return [pytest.param(action, id=f"{' '.join(path) or 'pendc'} {name}")
            for path, name, action in actions(build_parser())]


def test_the_walk_sees_every_subcommand():
    paths = {path for path, _, _ in actions(build_parser()) if path}
    assert {"simulate", "build", "report", "stimulus", "hil", "animate", "compare", "diagnose",
            "fit"} <= {path[0] for path in paths}
    assert {("report", "qformat"), ("report", "resources"), ("report", "synth")} <= paths


@pytest.mark.parametrize("action", cases())
def test_every_option_has_help(action):
    assert action.help and action.help.strip() and action.help is not argparse.SUPPRESS


@pytest.mark.parametrize("command", ["fit", "diagnose"])
def test_fit_and_diagnose_help_lists_every_effect(command, capsys):
    """Every body's effects, each under its body's heading (the Furuta's too)."""
    from pendc.model.modelfile import shipped_plants

    BODIES = shipped_plants()
    assert set(BODIES["cart_pendulum"].catalogue) == set(CATALOGUE) and len(BODIES) >= 2
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    listed = out[out.index("effects (names for --add"):]
    headings = [listed.index(f"  {name} (") for name in BODIES]
    assert headings == sorted(headings)
    for (name, body), start, end in zip(BODIES.items(), headings, [*headings[1:], len(listed)]):
        section = listed[start:end].splitlines()
        for effect_name, effect in body.catalogue.items():
            line = next(line for line in section if line.split()[:1] == [effect_name])
            assert effect.summary in line and all(p.name in line for p in effect.params), (name, effect_name)


def help_pages(parser, path=()):
    """(command path, help text) of every (sub)parser."""
    yield path, parser.format_help()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from help_pages(sub, path + (name,))


def test_help_examples_are_the_default_models_signals():
    """The examples are filled from the plant interface: no placeholder is left, and the
    words are the default model's states and input (not a copy of them in the CLI)."""
    import pendc
    from pendc.sim.signals import signals_of

    sig = signals_of(pendc.load_model())
    pages = dict(help_pages(build_parser()))
    assert not [path for path, text in pages.items() if "{plant:" in text]
    states = ",".join(sig.mechanical)
    assert states in pages[("simulate",)]
    compare = pages[("compare",)]
    angle = next(p for p in sig.positions if sig.period(p) is not None)
    assert f"--{angle}-unit deg" in compare and f"--{angle}-zero upright" in compare
    assert "--outputs" in compare and ",".join(sig.positions) in compare


def test_help_words_follow_the_plant():
    """The same help text filled for the Furuta names its signals (both periodic: the first
    is the angle, the other the position of the examples)."""
    from pathlib import Path

    import pendc
    from pendc.cli.help import fill, plant_words
    from pendc.sim.signals import signals_of

    furuta = signals_of(pendc.load_model(Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"))
    words = plant_words(furuta)
    first, second = furuta.positions
    assert (words["angle"], words["position"], words["input"]) == (first, second, furuta.input)
    assert fill("--{plant:angle}-unit deg", words) == f"--{first}-unit deg"
    step = furuta.interface.sensor_of(first).resolution
    assert float(words["angle_step"]) == pytest.approx(step, rel=1e-4)


def test_signal_options_are_any_signal_of_any_plant():
    """--<SIGNAL>-unit/-zero/-sign VALUE is --unit/--zero/--sign SIGNAL=VALUE, for a name the CLI
    never heard of; the settings add up, and a missing value is a one-line usage error."""
    from pendc.cli.data import expand_signal_options
    from pendc.errors import PendcError

    args = build_parser().parse_args(["compare", "r.csv", "--arm-angle-unit", "deg", "--unit", "t=ms",
                                      "--arm-angle-zero=upright", "--arm-angle-sign", "-1", "--u-value", "2"])
    assert args.unit == {"arm_angle": "deg", "t": "ms"}
    assert args.zero == {"arm_angle": "upright"} and args.sign == {"arm_angle": -1.0}
    assert args.input_value == ("u", 2.0)     # the input's name is checked when the data are read
    assert expand_signal_options(["--a-unit", "mm", "--", "--b-unit"], {}) == ["--unit", "a=mm", "--", "--b-unit"]
    with pytest.raises(PendcError, match=r"^compare: argument --a-unit: expected one argument$"):
        build_parser().parse_args(["compare", "r.csv", "--a-unit"])
    with pytest.raises(PendcError, match="--sign"):
        build_parser().parse_args(["compare", "r.csv", "--a-sign", "2"])


def test_the_value_of_an_absent_input_names_the_models_input():
    """--<INPUT>-value V is --input-value INPUT=V: the default model's input passes, another name
    is refused naming the model's input, and the Furuta's input is its own interface's."""
    from pathlib import Path

    import pendc
    from pendc.cli.data import read_options
    from pendc.errors import PendcError

    cart = pendc.load_model()
    name = cart.interface.input.name
    args = build_parser().parse_args(["compare", "r.csv", f"--{name}-value", "-2.5"])
    assert read_options(args, plant=cart).u_value == -2.5
    assert read_options(build_parser().parse_args(["compare", "r.csv", "--input-value", "4"])).u_value == 4.0
    wrong = build_parser().parse_args(["compare", "r.csv", "--volts-value", "1"])
    with pytest.raises(PendcError, match=f"'volts' is not the model's input \\(its input is '{name}'\\)"):
        read_options(wrong, plant=cart)
    furuta = pendc.load_model(Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml")
    furuta_input = furuta.interface.input.name
    args = build_parser().parse_args(["compare", "r.csv", f"--{furuta_input}-value", "1"])
    assert read_options(args, plant=furuta).u_value == 1.0


def test_version_is_the_package_version(capsys):
    import pendc

    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out.strip() == f"pendc {pendc.__version__}"


@pytest.mark.parametrize("argv", [["--bogus"], ["build", "--bogus"], ["nosuch"], ["simulate"], ["report"]])
def test_a_usage_error_is_one_line_with_one_prefix(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and err.startswith("pendc: error: ") and err.count("pendc:") == 1, err


def stdin_text(monkeypatch, text):
    import io
    import sys

    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(text.encode()), encoding="utf-8"))


def test_dash_reads_the_input_from_standard_input(monkeypatch, capsys):
    stdin_text(monkeypatch, "t,u\n0,5\n0.001,5\n0.002,5\n")
    assert main(["simulate", "--input", "-", "--dt", "1e-4"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[-1].startswith("0.002,")


def test_dash_reads_the_model_from_standard_input(monkeypatch, capsys, tmp_path):
    """The same model from standard input and from its file builds the same files."""
    from pendc.model.modelfile import default_model_path

    assert main(["build", "-o", str(tmp_path / "from_file")]) == 0
    stdin_text(monkeypatch, default_model_path().read_text())
    assert main(["build", "--model", "-", "-o", str(tmp_path / "from_stdin")]) == 0
    assert "(model <stdin>, sha256:" in capsys.readouterr().err
    one, two = tmp_path / "from_file", tmp_path / "from_stdin"
    assert sorted(p.name for p in one.iterdir()) == sorted(p.name for p in two.iterdir())
    assert all((one / p.name).read_bytes() == (two / p.name).read_bytes() for p in one.iterdir())


def test_a_model_from_standard_input_is_named_stdin_in_errors(monkeypatch, capsys):
    stdin_text(monkeypatch, "[plant]\ng = 9.81\n")
    assert main(["report", "resources", "--model", "-"]) == 2
    assert capsys.readouterr().err.startswith("pendc: error: <stdin>: [plant] lacks")


def test_dash_reads_the_run_for_animate_from_standard_input(monkeypatch, capsys, tmp_path):
    stdin_text(monkeypatch, "t,x,theta\n0,0,0\n0.01,0,0.1\n0.02,0,0.2\n")
    assert main(["animate", "-", "-o", str(tmp_path / "a.html")]) == 0
    page = (tmp_path / "a.html").read_text()
    assert '{"name":"theta","unit":"rad","values":[0.0,0.1,0.2]}' in page   # the read column, named


def test_a_bad_run_from_standard_input_is_named_stdin(monkeypatch, capsys, tmp_path):
    stdin_text(monkeypatch, "t,x\n0,0\n")
    assert main(["animate", "-", "-o", str(tmp_path / "a.html")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pendc: error: <stdin>: line 1: no column 'theta'") and "stdin.csv" not in err, err
    assert not (tmp_path / "a.html").exists()


@pytest.mark.parametrize("argv, kind, takes", [
    (["report", "resources", "--drift"], "report resources", "--model, --target, --json, --no-cache"),
    (["report", "synth", "--model", "m.toml"], "report synth", "--build-dir"),
    (["report", "qformat", "--build-dir", "hdl_out"], "report qformat", "--drift"),
    (["report", "qformat", "--freq", "50"], "report qformat", "--drift"),
])
def test_an_option_of_another_report_kind_is_refused_by_name(argv, kind, takes, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"pendc: error: {kind}: unrecognized arguments: {argv[2]}") and takes in err, err


def test_report_help_lists_only_the_options_of_its_kind(capsys):
    helps = {}
    for kind in ("qformat", "resources", "synth"):
        with pytest.raises(SystemExit):
            main(["report", kind, "--help"])
        helps[kind] = capsys.readouterr().out
    assert "--drift" in helps["qformat"] and "--drift" not in helps["resources"] + helps["synth"]
    assert "--build-dir" in helps["synth"] and "--build-dir" not in helps["qformat"] + helps["resources"]
    assert "--model" not in helps["synth"] and "--freq" not in helps["qformat"]
