"""Dates and durations on a velocity-data system's time axis.

Data whose time coordinate is a calendar (CF units ``UNIT since DATE``, with its ``calendar``)
are integrated in numbers of UNIT since DATE; a start time may be given as a date
(``"YYYY-MM-DD"``, ``numpy.datetime64``, ``pandas.Timestamp``, ``datetime``) and an
integration time as a duration (``"5D"``, ``numpy.timedelta64``, ``pandas.Timedelta``,
``datetime.timedelta``): :func:`numeric_time` and :func:`numeric_duration` turn them into
those numbers through xarray's CF encoder (the one ``to_netcdf`` uses, every CF calendar), and
:func:`date_text` / :func:`duration_text` give a map's file the dates back in ISO 8601.
"""

from __future__ import annotations

import datetime

import numpy as np
import pandas as pd
import xarray as xr

from ...errors import ConfigError
from .source import DataSource, open_source, time_unit_seconds


def is_date(value) -> bool:
    """Whether ``value`` is a date rather than a number (a string that is no number counts)."""
    if isinstance(value, (bool, int, float, np.number)):
        return False
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return True
        return False
    return isinstance(value, (np.datetime64, datetime.date, pd.Timestamp)) or hasattr(value, "calendar")


def is_duration(value) -> bool:
    """Whether ``value`` is a duration rather than a number (a string that is no number counts)."""
    if isinstance(value, str):
        return is_date(value)
    return isinstance(value, (np.timedelta64, datetime.timedelta))


def has_calendar(source: DataSource) -> bool:
    return " since " in f" {source.time_reference} "


def numeric_time(value, source: DataSource, key: str) -> float:
    """A date as the data's time coordinate counts it (UNIT since DATE in its calendar); a
    ConfigError naming ``key`` if the data have no calendar or the text is no date."""
    if not has_calendar(source):
        raise ConfigError(f"config key '{key}': {value!r} is a date, but the time coordinate {source.time!r} of "
                          f"{source.label} is no calendar (units {source.time_reference or source.time_units!r}, not "
                          "'UNIT since DATE'); give the start time as a number in the data's time units")
    try:
        date = value if hasattr(value, "calendar") else pd.Timestamp(value).to_datetime64()
        # floats asked for: a date between whole units (06:00 on a days axis) is a fraction, not a warning
        numbers, _, _ = xr.coding.times.encode_cf_datetime(np.asarray([date]), source.time_reference,
                                                           source.calendar or "standard", dtype=np.dtype(float))
    except (ValueError, TypeError, OverflowError) as error:
        raise ConfigError(f"config key '{key}': {value!r} is not a date the data's calendar "
                          f"({source.calendar or 'standard'}, {source.time_reference!r}) can place: "
                          f"{str(error).splitlines()[0]}") from None
    return float(np.asarray(numbers).ravel()[0])


def numeric_duration(value, source: DataSource, key: str) -> float:
    """A duration in the data's time unit; a ConfigError naming ``key`` if the data name none or
    the text is no duration."""
    seconds_per_unit = time_unit_seconds(source.time_units)
    if not seconds_per_unit:
        raise ConfigError(f"config key '{key}': {value!r} is a duration, but the time unit of {source.label} is not "
                          f"known ({source.time_units!r}); give it as a number in the data's time units")
    try:
        duration = pd.Timedelta(value)
    except (ValueError, TypeError) as error:
        raise ConfigError(f"config key '{key}': {value!r} is not a duration (e.g. '5D', '36h', "
                          f"numpy.timedelta64(5, 'D')): {str(error).splitlines()[0]}") from None
    return duration / pd.Timedelta(seconds=seconds_per_unit)


def date_text(number: float, source: DataSource) -> str:
    """The date of a time on the data's calendar, ISO 8601."""
    dates = xr.coding.times.decode_cf_datetime(np.asarray([number]), source.time_reference,
                                               source.calendar or "standard")
    date = np.asarray(dates).ravel()[0]
    return date.isoformat() if hasattr(date, "isoformat") else str(np.datetime_as_string(date, unit="s"))


def duration_text(number: float, source: DataSource) -> str:
    """A duration in the data's time unit, ISO 8601 (``P5DT0H0M0S``)."""
    return pd.Timedelta(seconds=number * time_unit_seconds(source.time_units)).isoformat()


def calendar_attributes(system_spec: dict, key: str, starts, tau: float) -> dict[str, str]:
    """What a map's file says of its times in dates, besides the numbers: ``t0_date`` (or
    ``t0_dates``, one per start time, for a map with a t0 dimension) and ``tau_duration``, ISO 8601;
    nothing unless the system's data have a calendar."""
    if "velocity_data" not in system_spec:
        return {}
    source = open_source(system_spec["velocity_data"], f"{key}.velocity_data")  # its coordinates alone are read
    if not has_calendar(source):
        return {}
    dates = [date_text(float(start), source) for start in np.atleast_1d(starts)]
    attributes = {"t0_date": dates[0]} if np.ndim(starts) == 0 else {"t0_dates": ", ".join(dates)}
    return {**attributes, "tau_duration": duration_text(float(tau), source)}
