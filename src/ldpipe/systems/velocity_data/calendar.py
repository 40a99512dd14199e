"""Dates and durations on a velocity-data system's time axis.

Data whose time coordinate is a calendar (CF units ``UNIT since DATE``, with its ``calendar``)
are integrated in numbers of UNIT since DATE; a start time may be given as a date
(``"YYYY-MM-DD"``, ``numpy.datetime64``, ``pandas.Timestamp``, ``datetime``) and an
integration time as a duration (``"5D"``, ``numpy.timedelta64``, ``pandas.Timedelta``,
``datetime.timedelta``): :func:`numeric_time` and :func:`numeric_duration` turn them into
those numbers through xarray's CF encoder (the one ``to_netcdf`` uses, every CF calendar);
:func:`numeric_times` does so for an entry's ``t0`` and ``tau`` (the Python API's arguments and a
configuration's keys alike), and :func:`date_text` / :func:`duration_text` give a map's file the
dates back in ISO 8601.
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
        if pd.isna(date):  # '' and 'NaT' read as "no date", which no calendar places
            raise ValueError("no date")
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
        if pd.isna(duration):  # '' and 'NaT' read as "no duration"
            raise ValueError("no duration")
    except (ValueError, TypeError) as error:
        raise ConfigError(f"config key '{key}': {value!r} is not a duration (e.g. '5D', '36h', "
                          f"numpy.timedelta64(5, 'D')): {str(error).splitlines()[0]}") from None
    return duration / pd.Timedelta(seconds=seconds_per_unit)


def numeric_times(entry: dict, source: DataSource | None, system_name: str, key: str) -> dict:
    """``entry`` with a date ``t0`` (one, a list, or a range's ``first`` and ``last``) and a
    duration ``tau`` made numbers in the time units of ``source`` (the system's velocity data;
    None for a system without them), and text that reads as a number made that number; a
    ConfigError naming the key (``key.t0``, ``key.t0.first``, ...) for a date or duration the
    system cannot place. Numbers are left as they are."""
    entry = dict(entry)

    def start(value, where: str):
        if not is_date(value):
            return float(value) if isinstance(value, str) else value
        if source is None:
            if not _reads_as(pd.Timestamp, value):
                raise ConfigError(f"config key '{key}.{where}': {value!r} is not of type 'number'")
            raise ConfigError(f"config key '{key}.{where}': {value!r} is a date, but system {system_name!r} has no "
                              "calendar (only velocity data whose time units read 'UNIT since DATE' have); give "
                              "t0 as a number")
        return numeric_time(value, source, f"{key}.{where}")

    t0 = entry.get("t0")
    if isinstance(t0, dict):
        entry["t0"] = {**t0, **{end: start(t0[end], f"t0.{end}") for end in ("first", "last") if end in t0}}
    elif isinstance(t0, (list, tuple)):
        entry["t0"] = [start(value, f"t0.{i}") for i, value in enumerate(t0)]
    elif t0 is not None:
        entry["t0"] = start(t0, "t0")
    tau = entry.get("tau")
    if is_duration(tau):
        if source is None:
            if not _reads_as(pd.Timedelta, tau):
                raise ConfigError(f"config key '{key}.tau': {tau!r} is not of type 'number'")
            raise ConfigError(f"config key '{key}.tau': {tau!r} is a duration, but system {system_name!r} "
                              "has no time unit (only velocity data have); give tau as a number")
        entry["tau"] = numeric_duration(tau, source, f"{key}.tau")
    elif isinstance(tau, str):
        entry["tau"] = float(tau)
    return entry


def _reads_as(kind, value) -> bool:
    """Whether ``value`` reads as a ``kind`` (pandas' Timestamp or Timedelta), not as nothing: text
    that is neither a number nor a date (or duration) is refused as not a number, as the schema
    refuses it where dates are not taken."""
    try:
        return not pd.isna(kind(value))
    except (ValueError, TypeError, OverflowError):
        return False


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
