"""The device families lgvtool knows, and what each one declares.

Each family is a folder ``lgvtool/devices/<family>/`` with a registration module
``<family>_registration.py`` that satisfies :class:`DeviceFamily` (a :class:`typing.Protocol`,
checked by mypy in ``tests/devices/test_device_registry.py``):

- names: ``DEVICE``, ``TITLE`` (in messages), ``RAW_TOPICS``, ``TOPICS``, ``ODOMETRY`` (the
  recorder's odometry source: the other families' speed input);
- decoding: ``log_decoder(metadata)``, ``ABSENT_REPORT``, ``ABSENT_METADATA``;
- ``lgvtool record``: ``RECORD_OPTIONS`` (typed declarations, :class:`RecordOption`, from which
  the command makes its options), ``RECORD_URL_OPTION`` / ``RECORD_URL_PARAM`` (the option
  naming its link), ``recorder_settings(options, *, layout, speed_input, reply_timeout,
  config)`` (takes its options out of ``options``; ``layout``: the shared
  :class:`~lgvtool.devices.layout_plan.LayoutPlan`, which a family refuses in one line where it
  cannot do it; a :class:`~lgvtool.devices.recorder.RecordedDevice` or None),
  ``recorder_link(url)``, ``recorder_worker(...)`` and ``recorder_metadata(device)``.

A family knows neither the simulator nor the command line: no module under ``lgvtool/devices``
imports the simulator or click (``tests/test_layout.py``). Its emulator (``simulate serve``)
and its simulator link are the simulator's, one layer up (``sim/emulate/<family>/``, found
through ``sim/emulate/emulator_registry.py``; ``sim/<family>_simlink.py``); ``lgvtool record``
makes the click options of :attr:`DeviceFamily.RECORD_OPTIONS`.

``lgvtool decode``, ``record``, the recorder, ``simulate serve`` and the simulator's log writer
go through :func:`registration` and :func:`registrations`; adding a family means its folder and
a line in :data:`FAMILIES` (and, to serve it, its folder in ``sim/emulate/``).
Registrations are imported on first use (``lgvtool --help`` stays light).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, TypeAlias, cast

from lgvtool.json_types import JSON, JSONObject

if TYPE_CHECKING:
    import threading

    from lgvtool.config import Config
    from lgvtool.devices.device_links import Link
    from lgvtool.devices.layout_plan import LayoutPlan
    from lgvtool.devices.link_worker import LinkTiming, LinkWorker
    from lgvtool.devices.log_decoding import LogDecoder
    from lgvtool.devices.logsink import LogSink
    from lgvtool.devices.recorder import RecordedDevice

__all__ = ["FAMILIES", "JSON", "ChoiceValue", "DeviceFamily", "IntegerValue", "JSONObject",
           "NumberValue", "OptionValue", "PairValue", "RecordOption", "TextValue", "ValueKind",
           "family_of_topic", "listed", "registration", "registrations"]

#: The device families, in the order their decoders run and their reports are listed.
FAMILIES = ("mcu", "nav200", "nav350")



# ---------------------------------------------------------------- record options, declared
@dataclass(frozen=True)
class TextValue:
    """The option takes a string (a URL, a name)."""


@dataclass(frozen=True)
class NumberValue:
    """The option takes a finite number in [``minimum``, ``maximum``] (``min_open``: above
    ``minimum``), checked by the one coercer (:func:`lgvtool.values.coerce`)."""

    minimum: float
    maximum: float
    min_open: bool = False


@dataclass(frozen=True)
class IntegerValue:
    """The option takes an integer in [``minimum``, ``maximum``]."""

    minimum: int
    maximum: int


@dataclass(frozen=True)
class ChoiceValue:
    """The option takes one of ``choices``."""

    choices: tuple[str, ...]


@dataclass(frozen=True)
class PairValue:
    """The option takes two values of ``item`` (``--action-radii RMIN RMAX``)."""

    item: NumberValue


#: What an option takes.
ValueKind: TypeAlias = "TextValue | NumberValue | IntegerValue | ChoiceValue | PairValue"
#: The value an option of each kind gives (None: not given and no default).
OptionValue: TypeAlias = "str | int | float | tuple[float, float] | None"


@dataclass(frozen=True)
class RecordOption:
    """One ``lgvtool record`` option of a family: the command makes it a click option; its
    value reaches :meth:`DeviceFamily.recorder_settings` as ``options[param]``."""

    flag: str
    """``--poll-period``"""
    param: str
    """``poll_period``: its key in the options"""
    help: str
    value: ValueKind = TextValue()
    default: str | int | float | None = None
    show_default: bool = False
    metavar: str | None = None


# ---------------------------------------------------------------- the family interface
class DeviceFamily(Protocol):
    """What a family's registration module declares (see the module docstring). The names
    are read-only (properties here, module constants in a registration)."""

    @property
    def DEVICE(self) -> str:
        """The family's name, one of :data:`FAMILIES` (``nav200``)."""

    @property
    def TITLE(self) -> str:
        """The device in messages (``the NAV200``)."""

    @property
    def ODOMETRY(self) -> bool:
        """The recorder's odometry source: its worker is the other families' speed input."""

    @property
    def RAW_TOPICS(self) -> tuple[str, ...]:
        """The raw topics the family's traffic is logged on."""

    @property
    def TOPICS(self) -> Mapping[str, str]:
        """Topic -> schema of the family's own topics."""

    @property
    def ABSENT_REPORT(self) -> Mapping[str, JSON] | None:
        """The decode report's section for a log without the family's traffic (None: no
        section)."""

    @property
    def ABSENT_METADATA(self) -> Mapping[str, Mapping[str, int]]:
        """The ``decode`` metadata for a log without the family's traffic."""

    @property
    def RECORD_URL_OPTION(self) -> str:
        """``record``'s option naming the family's link (``--nav``)."""

    @property
    def RECORD_URL_PARAM(self) -> str:
        """Its parameter name (``nav_url``)."""

    @property
    def RECORD_OPTIONS(self) -> tuple[RecordOption, ...]:
        """The family's ``record`` options, in the order ``record --help`` lists them."""

    def log_decoder(self, metadata: Mapping[str, Mapping[str, JSON]]) -> LogDecoder:
        """The family's log decoder (``metadata``: the log's metadata records)."""

    def recorder_settings(self, options: dict[str, OptionValue], *, layout: LayoutPlan,
                          speed_input: bool, reply_timeout: float, config: Config
                          ) -> RecordedDevice | None:
        """Take the family's :attr:`RECORD_OPTIONS` out of ``options``: the device to record,
        None when its link is not given."""

    def recorder_link(self, url: str) -> Link:
        """The family's link at ``url``."""

    def recorder_worker(self, link: Link, sink: LogSink, stop: threading.Event,
                        timing: LinkTiming, settings: object, config: Config, *,
                        mcu: LinkWorker | None = None,
                        warn: Callable[[str], None] | None = None) -> LinkWorker:
        """The recorder thread of one link (``settings``: the family's own, from
        :meth:`recorder_settings`, or None; ``mcu``: the odometry source's worker)."""

    def recorder_metadata(self, device: RecordedDevice | None) -> JSONObject:
        """The family's entries of the log's ``recorder`` metadata (None: not recorded)."""


def registration(family: str) -> DeviceFamily:
    """The registration of ``family`` (one of :data:`FAMILIES`)."""
    if family not in FAMILIES:
        raise KeyError(f"no device family {family!r} (known: {', '.join(FAMILIES)})")
    return cast(DeviceFamily,
                importlib.import_module(f"lgvtool.devices.{family}.{family}_registration"))


def registrations() -> list[DeviceFamily]:
    """The registrations of every family, in :data:`FAMILIES` order."""
    return [registration(f) for f in FAMILIES]


def listed() -> list[DeviceFamily]:
    """The registrations in the order devices are named to people (usage lines, served
    ports): the sensors in :data:`FAMILIES` order, then the odometry sources."""
    regs = registrations()
    return [r for r in regs if not r.ODOMETRY] + [r for r in regs if r.ODOMETRY]


def family_of_topic(topic: str) -> str | None:
    """The family whose raw traffic is logged on ``topic`` (None: no family's)."""
    for reg in registrations():
        if topic in reg.RAW_TOPICS:
            return reg.DEVICE
    return None
