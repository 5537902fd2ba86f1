"""rotorid: bearing stiffness, damping and rotor unbalance from measured 1X
bearing vibration, beside ROSS.

The functions mirror the ``rotorid`` command line and its Rust library:

- :class:`Model` -- a rotor model (rotorid or ROSS TOML, or ``"paper"``);
  :meth:`Model.from_ross` takes a ``ross.Rotor``;
- :meth:`Model.simulate` -- bearing responses as ``rotorid simulate``;
- :func:`read_measurements` -- a measurement CSV as numpy arrays;
- :func:`identify` -- bearing coefficients and unbalance
  (:class:`Identification`, :meth:`Identification.to_ross`);
- :func:`diagnose` -- the physical effect the model lacks;
- :func:`campbell` -- natural frequencies and critical speeds;
- :func:`vectors` -- 1X vectors from probe and keyphasor signals (CSV, WAV).

Units and conventions are the command line's: speeds in rpm, phasors in
metres, ``y(t) = Re{Y exp(j Omega t)}``, channels ``b1_y, b1_z, b2_y, ...``.
Errors are :class:`RotorIdError` (a ``ValueError``) with the command
line's one-line message.
"""

from __future__ import annotations

import os
import tempfile

from ._rotorid import (
    Diagnosis,
    Identification,
    Model,
    RotorIdError,
    __version__,
    campbell,
    diagnose,
    identify,
    read_measurements,
    vectors,
)

__all__ = [
    "Diagnosis",
    "Identification",
    "Model",
    "RotorIdError",
    "__version__",
    "campbell",
    "diagnose",
    "identify",
    "read_measurements",
    "vectors",
    "from_ross",
    "to_ross",
]


def _from_ross(rotor) -> Model:
    """A :class:`Model` of a ``ross.Rotor``, through ROSS's own ``save``.

    ROSS's file is the interface both sides keep stable across ROSS
    versions (rotorid reads 2.x and 3.x files); the object's attributes are
    not.
    """
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "rotor.toml")
        rotor.save(path)
        return Model.load(path)


def _to_ross(self: Identification):
    """The model as a ``ross.Rotor`` with the identified bearings (ROSS
    ``BearingElement`` tables, PCHIP interpolation for a law that changes
    with speed), loaded by ROSS from the file of :meth:`ross_toml`."""
    import ross

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "identified.toml")
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.ross_toml())
        return ross.Rotor.load(path)


from_ross = _from_ross
to_ross = _to_ross
Model.from_ross = staticmethod(_from_ross)
Identification.to_ross = _to_ross
