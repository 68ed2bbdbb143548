"""What identification says about each body's effects and constants, in words.

Diagnose and its reports explain a candidate effect to a control engineer (what it adds to
the unexplained acceleration), say which experiment would tell two tied candidates apart, and
point at constants of the model to free when the residual follows a signal one of them
scales. Those sentences are physics of one body (its effects, its experiments, its
constants), so they live here, next to the effect catalogues, and :mod:`pendc.ident` reads
them through the model's :attr:`~pendc.model.bodies.Body.notes`.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class IdentificationNotes:
    """One body's identification texts.

    ``evidence``: effect -> what it adds to the residual, in words. ``separated_by``: effect ->
    the experiment that shows it on its own (what a rig engineer would run to separate it from
    a rival that explains the same data). ``pair_separated_by``: frozenset of two effects ->
    what separates that pair when their own experiments would not (one mimics the other
    there too). ``parameter_hints``: ``(body, signal kind, parameters, reason)``: when the
    unexplained acceleration of ``body`` follows a signal of that kind ("angle": the angle or
    its sine, "rate": the body's own rate, "input": the input about its centre), the
    comma-separated ``parameters`` are the constants to free; a hint applies only to a model
    that has every parameter it names.
    """

    evidence: dict
    separated_by: dict
    pair_separated_by: dict
    parameter_hints: tuple

    def separating_experiment(self, names: list) -> str:
        """What would separate the tied effects ``names``: the pair's own entry when there is
        one, else each effect's experiment."""
        if len(names) == 2 and frozenset(names) in self.pair_separated_by:
            return self.pair_separated_by[frozenset(names)]
        how = {n: self.separated_by.get(n, f"an experiment that excites {n} alone") for n in names}
        ways = list(dict.fromkeys(how.values()))
        if len(ways) == 1:
            return ways[0]
        return "; ".join(f"for {n}, {how[n]}" for n in names)


# -- the cart-pendulum (pendc.model.effects) ----------------------------------------------------

CART_EVIDENCE = {
    "drive": "the residual force on the cart follows the input about V_off: the servo drive",
    "cart_spring": "the residual force on the cart grows with position and pulls the cart back (a spring or cable)",
    "asymmetric_cart": "the residual force on the cart follows the sign of its velocity with a different size left "
                       "and right",
    "coulomb_cart": "the residual force on the cart follows the sign of its velocity: dry friction",
    "viscous_cart": "the residual force on the cart is proportional to its speed",
    "static_cart": "the cart stays stuck for inputs the model says would move it",
    "stribeck_cart": "the residual force on the cart follows the sign of its velocity and is largest at low "
                     "speeds: Stribeck friction",
    "coulomb_pendulum": "the residual torque at the pivot opposes the sign of the swing's rate: dry friction in the "
                        "pivot",
    "viscous_pendulum": "the residual torque at the pivot is proportional to the swing's rate and opposes it: "
                        "viscous damping of the swing",
    "drive_deadzone": "the cart does not respond to small inputs around V_off: a dead zone in the drive",
    "force_limit": "the drive force stops growing for large inputs: a current limit",
    "motor_lag": "the force builds up with a first-order lag after input changes",
    "input_delay": "the response starts a fixed time after the input changes: a transport delay",
    "velocity_limit": "the cart speed saturates",
    "quadratic_pendulum": "the residual torque at the pivot grows with the square of the swing's rate and opposes "
                          "it: air drag on the swing",
    "theta_offset": "the pendulum rests at an angle the sensor does not call zero: an offset of the angle encoder",
    "x_offset": "the cart's forces look shifted along the track: an offset of the position sensor",
    "end_stops": "the cart is pushed back hard near the ends of the track: end stops",
}

CART_SEPARATED_BY = {
    "x_offset": "a constant-voltage run of the cart into the end stops (with end_stops in the model): the stops "
                "are fixed to the track, so where the cart meets them reads the sensor's zero",
    "theta_offset": "the pendulum left hanging at rest with the cart held: its reading there is the angle "
                    "sensor's zero",
    "asymmetric_cart": "cart-alone runs at the same constant voltage each way: only direction-dependent friction "
                       "gives different speeds left and right",
    "viscous_cart": "cart-alone runs at several constant voltages: the steady speed against the force is a line "
                    "whose slope is the viscous friction",
    "coulomb_cart": "cart-alone runs at several constant voltages: dry friction offsets the steady speed against "
                    "force line by a constant",
    "stribeck_cart": "cart-alone runs at several small constant voltages: the Stribeck dip shows in the steady "
                     "speed at low speeds",
    "static_cart": "a slow voltage ramp from rest: the voltage at which the cart breaks away is the static friction",
    "viscous_pendulum": "a long free swing with the cart held, from a large angle: viscous damping makes the "
                        "amplitude decay exponentially",
    "coulomb_pendulum": "a long free swing with the cart held, from a large angle: dry friction makes the amplitude "
                        "decay linearly and stop",
    "quadratic_pendulum": "a long free swing with the cart held, from a large angle: air drag takes the amplitude "
                          "down fastest while it is large",
    "drive_deadzone": "small constant voltages around V_off: inside a dead zone the cart does not move at all",
    "force_limit": "large voltage steps: a current limit caps the acceleration",
    "motor_lag": "fast voltage steps sampled at 1 kHz or faster: behind a lag the force rises smoothly",
    "input_delay": "fast voltage steps sampled at 1 kHz or faster: a delay is a dead time before any motion",
    "velocity_limit": "long runs at high voltage: a speed limit makes the speed plateau",
    "cart_spring": "the cart released at rest at several positions with zero voltage: a spring pulls it back "
                   "towards one place",
    "end_stops": "a run into the end stops",
}

# Pairs whose own experiments would not separate them, because one mimics the other there
# too. With a centring spring an offset of x is a constant force on the cart, and so is
# direction-dependent friction while the cart moves, in every run each way.
CART_PAIR_SEPARATED_BY = {
    frozenset({"x_offset", "asymmetric_cart"}): "a run of the cart into the end stops (with end_stops in the "
                                                "model): where it meets them reads the sensor's zero, which "
                                                "friction does not move",
    frozenset({"x_offset", "cart_spring"}): "a run of the cart into the end stops (with end_stops in the model): "
                                            "where it meets them reads the sensor's zero",
    frozenset({"viscous_pendulum", "quadratic_pendulum"}): "a free swing with the cart held in which the "
                                                           "amplitude falls several-fold, fitted with the period "
                                                           "right (free I or L as well): air drag takes the "
                                                           "amplitude down fastest while it is large, viscous "
                                                           "damping at a constant rate",
    frozenset({"viscous_pendulum", "coulomb_pendulum"}): "a free swing with the cart held in which the amplitude "
                                                         "falls several-fold, fitted with the period right (free I "
                                                         "or L as well): the amplitude decays exponentially with "
                                                         "viscous damping, linearly to a stop with dry friction",
    frozenset({"input_delay", "motor_lag"}): "fast voltage steps sampled at 1 kHz or faster: a delay is a dead "
                                             "time before any motion, a lag a smooth rise",
}

CART_PARAMETER_HINTS = (
    ("pendulum", "angle", "I", "the swing's period is off (free I, or L)"),
    ("pendulum", "rate", "b_theta", "the pivot damping is off"),
    ("cart", "input", "alpha,V_off", "the drive gain or offset is off"),
    ("cart", "rate", "b_x", "the viscous friction of the cart is off"),
)

CART_NOTES = IdentificationNotes(CART_EVIDENCE, CART_SEPARATED_BY, CART_PAIR_SEPARATED_BY, CART_PARAMETER_HINTS)


# -- the Furuta pendulum (pendc.model.furuta_effects) -------------------------------------------

FURUTA_EVIDENCE = {
    "motor_drive": "the residual torque on the arm follows the input and opposes the arm's rate: the motor and "
                   "its back-EMF",
    "viscous_arm": "the residual torque on the arm is proportional to its rate and opposes it: viscous damping of "
                   "the arm",
    "coulomb_arm": "the residual torque on the arm opposes the sign of its rate: dry friction in the motor and arm",
    "viscous_pivot": "the residual torque at the hinge is proportional to the swing's rate and opposes it: viscous "
                     "damping of the swing",
    "coulomb_pivot": "the residual torque at the hinge opposes the sign of the swing's rate: dry friction in the "
                     "hinge",
    "voltage_limit": "the arm stops answering larger inputs: the amplifier saturates",
    "alpha_offset": "the pendulum rests at an angle the sensor does not call zero: an offset of the angle encoder",
}

FURUTA_SEPARATED_BY = {
    "viscous_arm": "arm-alone runs (pendulum removed) at several constant voltages: the steady speed against the "
                   "voltage is a line whose slope the back-EMF and the viscous damping set",
    "coulomb_arm": "arm-alone runs (pendulum removed) at several constant voltages: dry friction offsets the "
                   "steady speed against voltage line by a constant",
    "viscous_pivot": "a long free swing with the arm held, from a large angle: viscous damping makes the "
                     "amplitude decay exponentially",
    "coulomb_pivot": "a long free swing with the arm held, from a large angle: dry friction makes the amplitude "
                     "decay linearly and stop",
    "voltage_limit": "large voltage steps: a saturated amplifier caps the arm's acceleration",
    "alpha_offset": "the pendulum left hanging at rest with the arm held: its reading there is the encoder's zero",
}
FURUTA_PAIR_SEPARATED_BY = {
    frozenset({"viscous_pivot", "coulomb_pivot"}): "a free swing with the arm held in which the amplitude falls "
                                                   "several-fold: it decays exponentially with viscous damping, "
                                                   "linearly to a stop with dry friction",
}

FURUTA_PARAMETER_HINTS = (
    ("pendulum", "rate", "D_p", "the hinge damping is off"),
    ("arm", "rate", "D_r", "the arm's damping is off"),
    ("arm", "input", "k_t", "the motor's torque constant is off"),
)

FURUTA_NOTES = IdentificationNotes(FURUTA_EVIDENCE, FURUTA_SEPARATED_BY, FURUTA_PAIR_SEPARATED_BY,
                                   FURUTA_PARAMETER_HINTS)
