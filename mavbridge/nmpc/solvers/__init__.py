"""The NMPC's solvers behind one backend protocol (``mavbridge.nmpc.backend``): IPOPT (the paper's
reference), RTI with HPIPM, advanced-step RTI (asrti), and nrti (asrti's step in C: condensing and a
dense box-QP), with the Gauss–Newton data they share and the C code generation and cache.

May import ``vessel`` and ``mavbridge.nmpc``'s problem, layout and config; imported by
``mavbridge.nmpc.controller`` and the tests.
"""
