"""Closed loop on a second plant: the rotary (Furuta) pendulum through the golden plant.

The same loop, plants, records and controller loader as the cart-pendulum's; nothing names the
Furuta's states but its plant interface. A PD hold of the arm (pendc.hil.controllers.position_hold, gains
from the model's own response at rest) moves it to 0.5 rad; the bit-exact golden plant and the
float plant (an independent code path: the float simulator) must both get there and agree
within a few encoder counts all the way, and the hanging pendulum must be set swinging by the
arm's motion (the coupling is in the equations, not in the controller).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pendc.errors import PendcError
from pendc.hil.controllers.controller_spec import make_controller
from pendc.hil.loop import run_closed_loop
from pendc.hil.plants.plant import make_plant
from pendc.hil.controllers.position_hold import PositionHold
from pendc.hil.records import read_run, run_csv_text

FURUTA = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"
TARGET = 0.5          # rad
SECONDS = 1.5


@pytest.fixture(scope="module")
def furuta():
    if not FURUTA.is_file():
        pytest.skip("no Furuta model")
    from pendc.model.modelfile import load_model
    return load_model(str(FURUTA))


@pytest.fixture(scope="module")
def runs(furuta):
    out = {}
    for kind in ("golden", "float"):
        plant = make_plant(kind, furuta)
        out[kind] = run_closed_loop(plant, PositionHold(furuta, target=TARGET), SECONDS, plant_name=kind)
    return out


def test_the_arm_is_held_at_its_set_point_on_both_plants(furuta, runs):
    iface = furuta.interface
    arm, pendulum = (s.state for s in iface.sensors)
    count = iface.sensors[0].resolution
    for kind, run in runs.items():
        assert run.stopped is None, f"{kind}: {run.stopped}"
        phi = run.column(arm)
        assert abs(phi[-1] - TARGET) < 0.02, f"{kind}: the arm ends at {phi[-1]:.4f} rad"
        assert np.max(phi) < TARGET + 0.15, f"{kind}: overshoot to {np.max(phi):.3f} rad"
        assert np.max(np.abs(run.column(pendulum))) > 5 * count, f"{kind}: the pendulum never moved"
    diff = np.abs(runs["golden"].column(arm) - runs["float"].column(arm))
    assert np.max(diff) <= 4 * count + 1e-12, f"golden and float arm differ by {np.max(diff) / count:.1f} counts"
    assert runs["golden"].summary()["completed"] and runs["golden"].angle == pendulum


def test_the_run_file_names_the_plants_columns(furuta, runs, tmp_path):
    from pendc.hil.plants.core_ports import CorePorts
    iface = furuta.interface
    text = run_csv_text(runs["golden"])
    header = next(line for line in text.splitlines() if not line.startswith("#"))
    assert header == ",".join(["t", iface.input.name, *(s.state for s in iface.sensors), "mode"])
    path = tmp_path / "run.csv"
    path.write_text(text)
    back = read_run(path, CorePorts.of_interface(iface))
    for state, column in runs["golden"].positions:
        np.testing.assert_allclose(back.column(state), column, atol=1e-6)


def test_the_builtin_and_hold_controllers_are_designed_for_the_second_plant(furuta):
    """The builtin swing-up and balance address the plant by role (the arm, the pendulum), so
    they are designed for the Furuta too (tests/test_hil_pendulum_roles.py runs them); the hold
    drives the first measured position."""
    sup = make_controller("builtin", furuta)
    assert (sup.balance.c.actuated, sup.balance.c.angle) == tuple(s.state for s in furuta.interface.sensors)
    hold = make_controller("hold", furuta)
    assert isinstance(hold, PositionHold) and hold.state == furuta.interface.sensors[0].state
    assert hold.input_range == (-furuta.interface.input.full_scale, furuta.interface.input.full_scale)
    assert math.isfinite(hold.u0) and hold.b > 0


def test_pendulum_controllers_refuse_a_plant_without_a_pendulum(furuta):
    import dataclasses
    with pytest.raises(PendcError, match="one pendulum"):
        make_controller("builtin", dataclasses.replace(furuta, experiment="pendulum_removed"))


def test_the_builtin_swing_up_brings_a_lightly_damped_qube_up(furuta):
    """The energy swing-up turns its pivot acceleration into volts through the model's own
    equations (the pendulum's reaction on the light arm): with a hinge damping of 2e-5 N*m*s/rad
    it swings the QUBE up and the LQR holds it (docs/hil.md: 1.6 s on the float plant). With
    the cited 5e-4 the swing stalls below the horizontal's reach of the top, as docs/hil.md says."""
    light = furuta.with_params({"D_p": 2e-5})
    run = run_closed_loop(make_plant("float", light), make_controller("builtin", light), 5.0, plant_name="float")
    summary = run.summary()
    assert summary["upright_at_s"] is not None and summary["upright_at_s"] < 3.0, summary
    shipped = run_closed_loop(make_plant("float", furuta), make_controller("builtin", furuta), 5.0)
    assert np.max(np.abs(getattr(shipped, shipped.angle))) < 2.0


def test_upright_guides_only_where_the_angle_comes_near_one():
    """run.png marks a pendulum angle's uprights within half a turn of where it goes, and none for
    an angle held near 0 (a helicopter's yaw, drawn flat between guides at -pi and 3 pi: the
    private check)."""
    import math
    import numpy as np
    from pendc.hil.records import upright_guides
    assert upright_guides(np.linspace(-0.05, 0.05, 50)) == []
    assert upright_guides(np.linspace(0.0, math.pi, 50)) == pytest.approx([-math.pi, math.pi])
    assert upright_guides(np.linspace(-0.5, 7.5, 50)) == pytest.approx([-math.pi, math.pi, 3 * math.pi])
    assert upright_guides([]) == []
