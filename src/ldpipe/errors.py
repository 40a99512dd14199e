"""Errors ldpipe raises for bad input, each naming what was wrong and what was expected."""


class LdpipeError(Exception):
    """Base class: the message is meant for the user, without a traceback."""


class ConfigError(LdpipeError):
    """A configuration value is missing, of the wrong type, or out of range."""


class StageFileError(LdpipeError):
    """A stage's input file is missing, unreadable, foreign, or from another stage."""


class OutputError(LdpipeError, OSError):
    """An output file cannot be written: its folder is missing or not writable, or the disk is
    full. An ``OSError`` too, as the failure it reports was one."""


class LdpipeWarning(UserWarning):
    """Something a user should know about a result that is still right (a map with no allowed
    point, a backward half integrated rather than mirrored): the message says what it means."""
