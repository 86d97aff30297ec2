"""The tests' helper modules (pytest puts ``tests/`` on ``sys.path``: they import as ``helpers``).

- ``spawn``: the one way to run a function in a fresh spawned process (Geant4 lives there);
- ``g4_*``: the functions those processes run, one module per topic (``g4_limits`` is a script
  run in its own interpreter); they import Geant4 only inside those processes, never in pytest;
- ``bad_inputs``, ``fuzz``: the bad-input cases and the fuzz strategies;
- ``gdml_worlds``, ``datasets_server``: GDML worlds written by Geant4 and a local HTTP server for
  the data-set downloads.

The one base configuration is ``conftest.BASE_CONFIG``.
"""
