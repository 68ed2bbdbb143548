"""One run of a sweep: a closed-loop scenario against one sampled plant, as one row.

The controller is designed on the *design* model (the nominal file, or ``--design``), the plant is
the *sampled* model: the question a sweep asks is whether a controller tuned on the nominal model
holds on every plant the data allow. :class:`SweepSpec` is what every run shares (the models as
self-contained text, so a remote worker needs no file); :func:`run_row` is the Dask task. It never
raises: a run that fails in any way is a row with ``passed`` False and the message in ``error``.
What a worker builds once (the parsed models, the nominal golden build) lives in a
:class:`WorkerCache` on the Dask worker, keyed by the spec's fingerprint. Imports pendc's model and
HIL modules; :mod:`pendc.robust.golden_retype` for the golden plant.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import PendcError

SCENARIOS = ("swing_up_balance", "balance_step", "swing_up_only")
PLANTS = ("float", "golden")
# the figure a scenario's criterion reads, so the worst runs can be ranked among themselves
CRITERION_FIGURE = {"swing_up_balance": "worst_last_3s_rad", "balance_step": "settle_s",
                    "swing_up_only": "closest_rad"}
FIGURES = ("upright_at_s", "settle_s", "balance_rms_rad", "worst_last_3s_rad", "closest_rad", "travel_ratio",
           "switches")


@dataclass(frozen=True)
class SweepSpec:
    """What every run of a sweep shares. ``model_text`` is the nominal plant (sampled around),
    ``design_text`` the model the controller is designed on; both in pendc's own model format."""

    model_text: str
    design_text: str
    model_source: str
    design_source: str
    controller: str = "builtin"
    scenario: str = "swing_up_balance"
    plant: str = "float"
    seconds: float = 12.0
    period: float = 1e-3

    @property
    def fingerprint(self) -> str:
        """Hash of everything a run depends on but its parameters."""
        return hashlib.sha256(json.dumps(asdict(self), sort_keys=True).encode()).hexdigest()[:20]


def check_spec(spec: SweepSpec) -> None:
    """One-line errors for a scenario, plant or controller the sweep cannot run."""
    if spec.scenario not in SCENARIOS:
        raise PendcError(f"unknown scenario {spec.scenario!r} (choose {', '.join(SCENARIOS)})")
    if spec.plant not in PLANTS:
        raise PendcError(f"--plant {spec.plant}: a sweep runs on {' or '.join(PLANTS)} (the RTL plants take "
                         f"minutes per run; the golden plant is bit-exact with them)")
    if spec.controller != "builtin" and spec.scenario != "swing_up_balance":
        raise PendcError(f"--scenario {spec.scenario} runs the builtin controllers (its set-point step or swing-up "
                         f"alone); --controller {spec.controller} runs with --scenario swing_up_balance")
    nominal, design = WorkerCache().models(spec)
    check_pendulum(design, spec.model_source)
    if nominal is not design:
        check_pendulum(nominal, spec.model_source)


def check_pendulum(model, source: str) -> None:
    """Every scenario judges a pendulum's swing-up and balance by the builtin controllers' constants,
    whatever ``--controller`` runs: a plant with no pendulum is refused here, once, rather than
    in every run with the HIL controllers' advice (which names the --controller lqr already given)."""
    from ..hil.controllers.operating_point_lqr import operating_point_names
    from ..hil.controllers.pendulum_roles import pendulum_roles

    try:
        pendulum_roles(model)
    except PendcError:
        points = operating_point_names(model)
        where = f" --model {source}" if source and not source.startswith("<") else ""
        instead = (f"pendc hil{where} --controller lqr --start {points[0]}" if points else
                   f"pendc hil{where} --controller lqr --start NAME after declaring [operating_points] NAME")
        raise PendcError(f"robust: its scenarios (swing-up and balance, its set-point step, swing-up alone) judge "
                         f"a pendulum, whatever --controller runs, and plant '{model.interface.name}' is not one "
                         f"pendulum on one driven coordinate; to judge a plant without one holding an operating "
                         f"point, run {instead}") from None


class WorkerCache:
    """What one process builds once per sweep: the parsed models and, for the golden plant, the
    nominal build and its retyping template."""

    def __init__(self):
        self._entries: dict = {}

    def models(self, spec: SweepSpec):
        """(nominal model, design model) of ``spec``."""
        key = ("models", spec.fingerprint)
        if key not in self._entries:
            from ..model.modelfile import parse_model
            nominal = parse_model(spec.model_text, source=spec.model_source)
            design = nominal if spec.design_text == spec.model_text else \
                parse_model(spec.design_text, source=spec.design_source)
            self._entries[key] = (nominal, design)
        return self._entries[key]

    def constants(self, spec: SweepSpec):
        """The builtin controllers' constants of ``spec``'s design model (its equations lambdified
        and linearised: a sixth of a 6 s run's time when made per run)."""
        key = ("constants", spec.fingerprint)
        if key not in self._entries:
            from ..hil.controllers.pendulum import PendulumConstants
            self._entries[key] = PendulumConstants.from_model(self.models(spec)[1])
        return self._entries[key]

    def golden_template(self, spec: SweepSpec):
        """The nominal build's retyping template (built or read from the build cache once)."""
        key = ("golden", spec.fingerprint)
        if key not in self._entries:
            from .golden_retype import RetypeTemplate
            self._entries[key] = RetypeTemplate.of(self.models(spec)[0])
        return self._entries[key]


def worker_cache() -> WorkerCache:
    """The cache of the Dask worker this task runs on (a fresh one outside a worker)."""
    try:
        from distributed import get_worker
        worker = get_worker()
    except (ImportError, ValueError):
        return WorkerCache()
    cache = getattr(worker, "pendc_robust_cache", None)
    if cache is None:
        cache = WorkerCache()
        worker.pendc_robust_cache = cache
    return cache


def make_sampled_plant(spec: SweepSpec, params: dict, cache: WorkerCache):
    """The plant of ``spec.plant`` for the nominal model with ``params``."""
    nominal, _ = cache.models(spec)
    if spec.plant == "golden":
        return cache.golden_template(spec).plant(params)
    from ..passes.pipeline import core_step
    from ..hil.plants.plant import make_plant
    return make_plant("float", nominal.with_params(params), dt=core_step(nominal))


def run_scenario(spec: SweepSpec, plant, design, consts=None):
    """The scenario's :class:`~pendc.hil.scenarios.ScenarioResult`, the controller designed on ``design``
    (``consts``: its :class:`~pendc.hil.controllers.pendulum.PendulumConstants`, if already made)."""
    from ..hil import scenarios
    name = spec.plant
    if spec.scenario == "balance_step":
        return scenarios.step_disturbance(plant, design, period=spec.period, plant_name=name, consts=consts)
    if spec.scenario == "swing_up_only":
        return scenarios.swing_up_only(plant, design, seconds=spec.seconds, period=spec.period, plant_name=name,
                                       consts=consts)
    if spec.controller == "builtin":
        return scenarios.swing_up_and_balance(plant, design, spec.seconds, period=spec.period, plant_name=name,
                                              consts=consts)
    from .user_controller import swing_up_balance_with
    return swing_up_balance_with(spec.controller, plant, design, spec.seconds, spec.period, name, consts=consts)


def run_row(spec: SweepSpec, index: int, params: dict, cache: WorkerCache | None = None) -> dict:
    """Run ``index`` of the sweep with plant parameters ``params``: one row (never raises)."""
    cache = cache or worker_cache()
    row = {"index": int(index), **{k: float(v) for k, v in params.items()}}
    try:
        _, design = cache.models(spec)
        result = run_scenario(spec, make_sampled_plant(spec, params, cache), design, cache.constants(spec))
        row.update(figures_of(result))
        row.update(passed=bool(result.passed), failures="; ".join(result.failures), error="")
    except Exception as exc:   # noqa: BLE001 -- any failure of one run is that run's row, not the sweep's end
        row.update({f: None for f in FIGURES})
        row.update(passed=False, failures="", error=f"{type(exc).__name__}: {exc}".splitlines()[0])
    return row


def figures_of(result) -> dict:
    """The row's figures of a scenario result (None where the scenario has no such figure)."""
    fig = result.figures
    out = {}
    for name in FIGURES:
        value = fig.get(name)
        out[name] = None if value is None or not np.isfinite(value) else float(value)
    if out["settle_s"] is None and "settle_s" not in fig:
        out["settle_s"] = out["upright_at_s"]     # a swing-up settles when it stays upright
    for key, value in fig.items():
        if key.startswith("max_abs_"):
            out[key] = None if value is None else float(value)
    return out


def run_alone(spec: SweepSpec, params: dict):
    """One run in this process with its whole record (the replay of a sweep's run): the
    :class:`~pendc.hil.scenarios.ScenarioResult`; errors are raised, not recorded."""
    cache = WorkerCache()
    _, design = cache.models(spec)
    return run_scenario(spec, make_sampled_plant(spec, params, cache), design)
