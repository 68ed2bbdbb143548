"""Encoder quantisation for any encoder a plant interface declares (pendc.sim.encoders)."""

import math
from pathlib import Path

import numpy as np
import pytest

import pendc
from pendc.errors import PendcError
from plants import THETA_COUNT, X_COUNT
from pendc.sim.encoders import counts, encoder_reading, encoder_resolution, quantize

QUBE = Path(__file__).resolve().parents[1] / "models" / "furuta_qube.toml"


def test_each_declared_encoder_counts_at_its_published_resolution():
    sct, qube = pendc.load_model(), pendc.load_model(QUBE)
    published = {("cart_pendulum", "x"): 5e-3 / 2000,                  # 500 lines x4, 5 mm per turn
                 ("cart_pendulum", "theta"): 2 * math.pi / 20000,      # ROD 420: 5000 lines x4
                 ("furuta", "phi_r"): 2 * math.pi / 2048,              # QUBE: 2048 counts per turn
                 ("furuta", "alpha_p"): 2 * math.pi / 2048}
    got = {(m.interface.name, s.state): encoder_resolution(m, s.state)
           for m in (sct, qube) for s in m.interface.sensors}
    assert got == pytest.approx(published, rel=1e-12)
    # the pre-interface names are the model's values
    assert (X_COUNT, THETA_COUNT) == (got[("cart_pendulum", "x")], got[("cart_pendulum", "theta")])


def test_a_reading_is_whole_counts_from_the_first_sample_and_lags_the_truth():
    qube = pendc.load_model(QUBE)
    step = encoder_resolution(qube, "alpha_p")
    truth = 0.3 + np.sin(np.linspace(0.0, 6.0, 500))
    seen = encoder_reading(qube, "alpha_p", truth)
    assert seen[0] == truth[0]
    n = (seen - truth[0]) / step
    assert np.allclose(n, np.round(n), atol=1e-9)
    assert np.array_equal(counts(truth, step), np.round(n).astype(np.int64))
    assert np.array_equal(seen, quantize(truth, step))
    # bands fixed to the mechanics: the reading is off the truth by less than one count either
    # way (the start's offset within its band, less the present one's), and it moves
    assert np.all(np.abs(truth - seen) < step) and np.ptp(n) > 500


def test_a_position_no_encoder_reads_is_refused():
    with pytest.raises(PendcError, match=r"^no encoder of plant 'furuta' reads 'dphi_r' \(encoders read: phi_r, "
                                         r"alpha_p\)$"):
        encoder_resolution(pendc.load_model(QUBE), "dphi_r")
