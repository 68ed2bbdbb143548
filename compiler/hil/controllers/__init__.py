"""Controllers of the HIL loop, and what a controller sees.

* :mod:`.measurement` - :class:`~.measurement.Measurement` (time, encoder counts, converter
  codes), the filtered difference every controller takes velocities with, ``wrap_upright``;
* :mod:`.pendulum` - the reference controllers of a pendulum plant: energy swing-up, LQR
  balance, the supervisor (``builtin``, ``swing-up``, ``balance``);
* :mod:`.operating_point_lqr` - an LQR about any plant file's operating point (``lqr:NAME``);
* :mod:`.start_point` - where ``--start NAME`` starts a run, and how closely a run held the point;
* :mod:`.position_hold` - a PD hold of one measured position, for any plant (``hold``);
* :mod:`.controller_spec` - ``--controller SPEC`` to a controller (also ``package.module:Class``);
* :mod:`.linearize`, :mod:`.numeric_model`, :mod:`.pendulum_roles` - the model's own
  linearisation, its equations as numeric functions, its coordinates by role.

May import model, errors and the plants' port names (:mod:`pendc.hil.plants.core_ports`);
never the loop or a plant. A user's controller (``--controller pkg.mod:Class``) imports what it
needs from here: the names below are re-exported for it (docs/hil.md); pendc's own modules
import the module that defines a name.
"""

from .measurement import FilteredDifference, Measurement, wrap_upright
from .pendulum import EnergySwingUp, LqrBalance, PendulumConstants, Supervisor

__all__ = ["FilteredDifference", "Measurement", "wrap_upright", "EnergySwingUp", "LqrBalance",
           "PendulumConstants", "Supervisor"]
