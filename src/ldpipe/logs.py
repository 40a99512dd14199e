"""Where a stage's progress messages go: the terminal from the CLI, a log file under Snakemake."""

from __future__ import annotations

import contextlib
import io
import logging
import sys
from pathlib import Path

from .errors import LdpipeError

LOGGER_NAME = "ldpipe"
FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


def get_logger(name: str) -> logging.Logger:
    """The logger of an ldpipe module (``__name__`` already starts with 'ldpipe')."""
    return logging.getLogger(name)


@contextlib.contextmanager
def log_to(path: str | Path | None = None, level: int = logging.INFO):
    """Send ldpipe's log records to ``path`` (or standard error) while the block runs."""
    logger = logging.getLogger(LOGGER_NAME)
    if path is None:
        handler: logging.Handler = logging.StreamHandler(sys.stderr)
    else:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        handler = logging.FileHandler(path, mode="w")
    handler.setFormatter(logging.Formatter(FORMAT))
    previous_level = logger.level
    logger.addHandler(handler)
    logger.setLevel(level)
    try:
        yield logger
    except LdpipeError as error:
        # A message meant for the user (a bad configuration key, a foreign input file): the
        # command line prints it alone, and a log file gets it alone, without a traceback.
        if path is not None:
            logger.error("stage failed: %s", error)
        raise
    except Exception:
        logger.exception("stage failed")
        raise
    finally:
        logger.removeHandler(handler)
        logger.setLevel(previous_level)
        handler.close()


class LogStream(io.TextIOBase):
    """A text stream that hands each line written to it to a logger (tqdm into a log file)."""

    def __init__(self, logger: logging.Logger):
        self.logger = logger

    def write(self, text: str) -> int:
        line = text.strip("\r\n ")
        if line:
            self.logger.info(line)
        return len(text)


def progress_output(logger: logging.Logger) -> tuple[io.TextIOBase, float]:
    """Where a progress bar goes, and how often: the terminal (or a notebook's output) when there
    is one, else the log."""
    if sys.stderr.isatty() or "ipykernel" in sys.modules:
        return sys.stderr, 1.0
    return LogStream(logger), 30.0
