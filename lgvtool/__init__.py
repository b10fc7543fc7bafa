"""lgvtool: log, replay and evaluate the localisation of laser-guided vehicles.

The package is split along the data flow:

- :mod:`lgvtool.wire` the generic codec base (checksums, units, resync stream, events), pure;
- :mod:`lgvtool.log` the MCAP log contract: topics, schemas, writer, reader, salvage;
- :mod:`lgvtool.devices` one folder per device family (codec, session, device model, worker),
  links and the recorder;
- :mod:`lgvtool.sim` the simulator and device emulators;
- :mod:`lgvtool.importers` real datasets into the log contract;
- :mod:`lgvtool.localize` estimators and the replay driver, pure;
- :mod:`lgvtool.evaluate` reference circle, laps, metrics, tables, plots;
- :mod:`lgvtool.fleet` sweeps over many logs on Dask.
"""

__version__ = "0.1.0"


def _register_config_checks() -> None:
    """Give :mod:`lgvtool.config` the checks of its ``[estimators.*]`` and ``[simulator]``
    tables (:mod:`lgvtool.config_checks`, a layer above it). Here, at the package's import,
    because every ``lgvtool.*`` import runs this first: no configuration is ever loaded
    unchecked, whatever the caller imported before (docs/architecture.md)."""
    from lgvtool.config import register_section_check
    from lgvtool.config_checks import check_estimators, check_simulator

    register_section_check("estimators", check_estimators)
    register_section_check("simulator", check_simulator)


_register_config_checks()
