"""Raw measurements and printed results from the thesis (spec/plant.md section 3).

Plain named constants only: nothing is computed here, so that
``provenance.py`` can derive every Table 3 parameter from these inputs and
compare against the printed figures (the ``*_PRINTED`` names) without the two
ever being mixed up.  Equation / table numbers refer to the thesis
(``shared/reference/thesis.txt``).  SI units unless the name says otherwise
(``_G`` grams, ``_MM`` millimetres, ``_PCT`` percent), because the thesis
quotes several inputs in those units and keeping them verbatim makes the
comparison with the text easy to audit.
"""

from __future__ import annotations

# --- Pendulum pieces (section 2.5.1, Fig. II.2) -----------------------------
M1_BLOCK_G = 185.155        # piece 1, block (cube), II.65
M2_ROD_G = 69.457           # piece 2, rod, II.65
M3_BOB_G = 326.388          # piece 3, bob (cylinder), II.65
M_CART_G = 514.6            # cart on the scale, II.8 (0.5146 kg)

ROD_VISIBLE_MM = 186.5      # L_2_F, rod length between the pieces (2.5.1)
ROD_IN_BLOCK_MM = 15.0      # rod inserted into piece 1 (2.5.1, II.73)
ROD_IN_BOB_MM = 40.0        # rod inserted into piece 3 (2.5.1)
ROD_TOTAL_MM = 241.5        # whole rod, 186.5 + 15 + 40, used by II.63/II.64
BOB_RADIUS_MM = 30.0        # R_3, II.84
BOB_LENGTH_MM = 40.0        # L_3, II.85
BLOCK_SIDE_MM = 30.0        # L_1, cube side, II.88

# --- Drive: power driver + AC motor + spindle (section 2.2) ----------------
DRIVE_SCALING_PCT = 150.0   # driver scaling, 150 % per ...
DRIVE_SCALING_SPAN_V = 10.0  # ... 10 V, II.1
I_ACTIVE_PEAK_A = 3.534     # max active peak current, Fig. II.6
PREWARN_PCT = 90.0          # continuous-current pre-warning, II.1
K_M_NM_PER_A = 0.54         # motor torque constant K_m, II.1
FEED_K_M = 5e-3             # spindle feed constant k [m/rev], II.1 / II.4
V_OFF = 5.0                 # driver offset voltage V_OFF, II.1

# --- Virtual cart mass (II.3-II.8), CKK 12-90 datasheet, 12x5, 1 carriage --
K1 = 1.454                  # Fig. II.8
K2 = 0.011                  # Fig. II.8 (per mm of module length)
K3 = 0.633                  # Fig. II.8 (per kg of external load)
L_TRACK_MM = 750.0          # compact-module length L, II.6
J_RV = 38e-6                # reduced inertia of belt side drive [kg m^2], II.6
J_BR = 0.0                  # no motor brake fitted, II.7
J_M = 17e-6                 # motor inertia from its datasheet [kg m^2], II.8
M_FR_STATED_KG = 1.096      # m_fr as eq. II.6/II.7 states (cart + rod & bob)

# --- Static friction break-away voltages (II.92, II.93) ---------------------
# V > V_OFF pushes the cart left (+x, spec section 1); thesis: "moving the
# cart to the left (V_in+) and to the right (V_in-)".
V_BREAKAWAY_PLUS = 5.705    # II.92, cart starts moving left (+x)
V_BREAKAWAY_MINUS = 4.248   # II.93, cart starts moving right (-x)

# --- Table 2: steady cart speed at constant input, runs a, b, c -----------
TABLE2_V_IN = (4.2, 6.0, 3.8, 6.4, 3.4, 6.8)            # [V]
TABLE2_RUNS = (                                          # [m/s] (a, b, c)
    (0.1132, 0.1105, 0.1135),
    (0.1669, 0.1682, 0.1745),
    (0.2492, 0.2506, 0.2567),
    (0.3233, 0.3248, 0.3256),
    (0.4083, 0.4136, 0.4201),
    (0.4728, 0.4743, 0.4799),
)
# Printed "Velo_mean" column.  The 4.2 V entry is a misprint: its runs
# average 0.1124, not 0.1119 (spec section 3); kept verbatim here.
TABLE2_MEAN_PRINTED = (0.1119, 0.1699, 0.2522, 0.3246, 0.4140, 0.4757)

# --- Printed results (comparison figures only, never used as inputs) ------
G = 9.80665                 # gravity, Table 3 (a constant, not a result)
L_CM_PRINTED = 0.138867     # II.65 (138.867 mm), Table 3 "L"
I_APPROX_PRINTED = 0.005799  # II.69
I_D1_PRINTED = 0.003571     # I.76
I_D2_PRINTED = 0.000065     # I.77
I_D3_PRINTED = 0.002229     # I.78
I_O2_PRINTED = 0.000201     # II.80
I_O3_PRINTED = 0.000117     # II.82
I_O1_PRINTED = 0.000028     # II.87
I_PRINTED = 6.21034e-3      # II.89, Table 3 "I"
ALPHA_PRINTED = 51.525      # II.2, Table 3 "alpha" [N/V]
J_FR_PRINTED = 48.4e-6      # II.7 [kg m^2]
M_PRINTED = 103.205         # II.8, Table 3 "M" [kg]
M_PENDULUM_PRINTED = 0.581  # Table 3 "m" (sum of all three pieces)
MU_S_PLUS_PRINTED = 0.03589   # II.94
MU_S_MINUS_PRINTED = 0.03828  # II.95
MU_S_PRINTED = 0.03709      # II.96, Table 3 "mu_s"
MU_C_PRINTED = 0.0292       # II.100, Table 3 "mu_c"
B_X_PRINTED = 155.1574      # II.101, Table 3 "b_x" [N s/m]
