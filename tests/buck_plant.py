"""The averaged DC-DC buck converter of the private check's round H (its buck.toml, cut to what
the tests read): a 3.4 kHz plant given by state equations, a dimensionless input (the duty
cycle), 12-bit converters on both states, a duty dead zone and a voltage-sense offset in its
catalogue. Shared by the tests of fast plants (resampling, the horizon) and of plant files."""

BUCK_TEMPLATE = """
[plant]
name = "buck"
core = "buck_core"
summary = "averaged DC-DC buck converter, duty-cycle input, resistive load"
V_g = 12.0
L_f = {L}
C_f = {C}
R_L = 0.02
R_o = 2.5

[constants]
V_g = {{ unit = "V", meaning = "input voltage", bounds = [1.0, 60.0] }}
L_f = {{ unit = "H", meaning = "filter inductance", bounds = [1e-7, 1e2] }}
C_f = {{ unit = "F", meaning = "output capacitance", bounds = [1e-7, 1e2] }}
R_L = {{ unit = "ohm", meaning = "winding and switch resistance", bounds = [0.0, 1.0] }}
R_o = {{ unit = "ohm", meaning = "load resistance", bounds = [0.1, 1000.0] }}

[states.i_L]
unit = "A"
meaning = "inductor current (A)"
derivative = "(d*V_g - v_C - R_L*i_L)/L_f"
initial = 2.0
range = [-5.0, 30.0]

[states.v_C]
unit = "V"
meaning = "output capacitor voltage (V)"
derivative = "(i_L - v_C/R_o)/C_f"
initial = 5.0
range = [0.0, 20.0]

[inputs.d]
unit = "-"
meaning = "switch duty cycle (0..1)"
range = [0.0, 1.0]
neutral = 0.42

[sensors.adc_v]
kind = "adc"
state = "v_C"
bits = 12
range = [0.0, 20.0]

[sensors.adc_i]
kind = "adc"
state = "i_L"
bits = 12
range = [-10.0, 30.0]

[catalogue.duty_dead_zone]
kind = "dead_zone"
on = "d"
width = "d_dz"
params.d_dz = {{ unit = "-", meaning = "duty lost to dead time", default = 0.01, bounds = [0.0, 0.2] }}
summary = "dead time eats part of the commanded duty"

[catalogue.v_offset]
kind = "offset"
on = "v_C"
offset = "v_os"
params.v_os = {{ unit = "V", meaning = "output voltage sense offset", default = 0.0, bounds = [-1.0, 1.0] }}
summary = "offset of the output voltage converter"
"""
FAST = dict(L=22e-6, C=100e-6)     # fastest mode 3.4 kHz: 10 time constants are 0.47 ms


def buck_toml(L: float = FAST["L"], C: float = FAST["C"]) -> str:
    """The buck's plant file with inductance ``L`` (H) and capacitance ``C`` (F)."""
    return BUCK_TEMPLATE.format(L=L, C=C)
