"""The model-mismatch scenario's figure and table for docs/hil.md.

    .venv/bin/python -m pendc.hil.mismatch_report DESIGN.toml TRUTH.toml [out.png] [--plant float|golden]

Runs :func:`pendc.hil.scenarios.model_mismatch` (the builtin controller designed on the
DESIGN model, run against DESIGN itself and against the TRUTH plant, beside the design on
TRUTH), writes the figure and prints a Markdown table of the results.
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np

from ..model.modelfile import load_model
from .controllers.measurement import wrap_upright
from .plants.plant import make_plant
from .records import write_bytes_atomic
from .scenarios import balance_activity, model_mismatch

LABELS = {
    "predicted": "designed on Table 3, run on Table 3 (the designer's simulation)",
    "hil": "designed on Table 3, run on Table 14 (HIL)",
    "matched": "designed on Table 14, run on Table 14",
}


def figure_png(results: dict) -> bytes:
    """Angle from the upright, cart position and input of the three runs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    colours = {"predicted": "tab:grey", "hil": "tab:red", "matched": "tab:blue"}
    for name, res in results.items():
        run = res.run
        angle, cart = _angle_and_cart(run)
        phi = np.array([wrap_upright(v) for v in run.column(angle)])
        axes[0].plot(run.t, np.abs(phi), lw=0.8, color=colours[name], label=LABELS[name])
        axes[1].plot(run.t, run.column(cart), lw=0.8, color=colours[name])
        axes[2].plot(run.t, run.u, lw=0.4, color=colours[name], alpha=0.8)
    axes[0].axhline(0.05, color="black", lw=0.5, ls=":")
    axes[0].set_ylabel(f"|{angle} - pi| (rad)")
    axes[0].legend(fontsize=8, loc="upper right")
    axes[1].set_ylabel(f"{cart} (m)")
    axes[2].set_ylabel(f"{run.input_name} (V)")
    axes[2].set_xlabel("t (s)")
    axes[0].set_title("Controller designed on the Table 3 model, against the Table 14 plant")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    return buf.getvalue()


def _angle_and_cart(run) -> tuple[str, str]:
    """The run's upright angle and its other measured position (the cart-pendulum's cart)."""
    return run.angle, next(s for s, _ in run.positions if s != run.angle)


def table(results: dict) -> str:
    """Markdown table of the three runs."""
    cart = _angle_and_cart(next(iter(results.values())).run)[1]
    rows = [f"| run | upright from (s) | max abs {cart} (m) | switches | balancing u std (V) | passes |",
            "|---|---|---|---|---|---|"]
    for name, res in results.items():
        f = res.figures
        act = balance_activity(res.run)
        up = f"{f['upright_at_s']:.2f}" if f["upright_at_s"] is not None else "never"
        std = f"{act['u_std_v']:.2f}" if act["u_std_v"] is not None else "-"
        span = float(np.max(np.abs(res.run.column(cart))))
        rows.append(f"| {LABELS[name]} | {up} | {span:.3f} | {f['switches']} | {std} | "
                    f"{'yes' if res.passed else 'no'} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    """Run the scenario, write the figure, print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("design", help="the model the controller is designed on")
    ap.add_argument("truth", help="the model standing in for the real plant")
    ap.add_argument("output", nargs="?", default="hil_mismatch.png", help="figure (PNG)")
    ap.add_argument("--plant", default="float", choices=("float", "golden"))
    args = ap.parse_args(argv)
    design, truth = load_model(args.design), load_model(args.truth)
    results = model_mismatch(lambda m: make_plant(args.plant, m), design, truth, plant_name=args.plant)
    write_bytes_atomic(Path(args.output), figure_png(results))
    print(table(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
