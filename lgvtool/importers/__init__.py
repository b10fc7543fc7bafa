"""Importers: real datasets converted into the lgvtool log contract.

- :mod:`lgvtool.importers.textdata` whitespace-separated text tables with broken-row counting;
- :mod:`lgvtool.importers.mrclam` the UTIAS MRCLAM dataset parser (pure, no log I/O);
- :mod:`lgvtool.importers.mrclam_quirks` cleaning and quirk detection of one robot's run (pure);
- :mod:`lgvtool.importers.mrclam_log` the conversion of a run into an MCAP log;
- :mod:`lgvtool.importers.mrclam_profile` the estimator settings (camera, odometry) a log carries.

Submodules import numpy and pandas; import them where they are used.
"""
