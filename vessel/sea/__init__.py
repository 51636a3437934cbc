"""The sea: wave fields behind one interface (calm, the paper's regular wave, irregular sums of components),
their spectra and NATO sea states, the ``sea``/``start`` sections of a world, and ``vessel sea``'s record
and analysis. Pure numbers and CasADi expressions, no MAVLink, no I/O beyond ``vessel sea``'s files.

May import: ``vessel`` (its config, maths and geometry modules). Imported by ``vessel.world`` and everything
above ``vessel`` that needs a sea; ``vessel``'s own ``__init__`` re-exports the common names.
"""
