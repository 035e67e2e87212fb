"""An independent test rig: a second bearing-vibration simulator to benchmark the twin against.

The twin (:mod:`bearingtwin.physics`) integrates a 4-degree-of-freedom Hertz-contact model.
Measuring how well ``bearingtwin-twin`` names the effects a record shows needs records whose
modelling choices are not the twin's own: a twin fitted to its own simulations recovers what it
assumed. This package is such a source. It shares no code with the twin (it imports nothing from
``bearingtwin.physics``, ``twin``, ``signal`` or ``features``) and differs in formulation: a
phenomenological impulse train (McFadden & Smith 1984; Antoni & Randall 2003; Sawalhi & Randall
2011) scaled by a Stribeck/Harris load zone, pushed through a frequency-domain transfer path
(contact ringing, housing and sensor mount as a 2-DOF chain per direction) and projected on a
sensor axis at any angle to the load. Its effects (:data:`RIG_EFFECTS`) carry the twin's effect
names where the twin's library has a counterpart, so a benchmark can score which effect the twin
ranks first; :data:`OUT_OF_LIBRARY` lists those it has none for.

Modules: ``geometry`` (kinematics in shaft orders), ``loadzone`` (ball loads), ``path`` (transfer
path), ``effects`` (the hideable effects), ``rig`` (the simulator).
"""

from bearingtwin.testrig.effects import OUT_OF_LIBRARY, RIG_EFFECTS, build_rig_effects
from bearingtwin.testrig.geometry import RigBearing
from bearingtwin.testrig.rig import FAULTS, RigOperatingPoint, RigSetup, simulate_rig

__all__ = ["FAULTS", "OUT_OF_LIBRARY", "RIG_EFFECTS", "RigBearing", "RigOperatingPoint", "RigSetup",
           "build_rig_effects", "simulate_rig"]
