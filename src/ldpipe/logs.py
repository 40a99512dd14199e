"""Where a stage's progress messages go: the terminal from the CLI, a log file under Snakemake."""

from __future__ import annotations

import contextlib
import io
import logging
import sys
import warnings
from pathlib import Path

from .errors import LdpipeError, LdpipeWarning

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


def in_notebook() -> bool:
    """Whether ldpipe runs in a Jupyter kernel (a notebook, JupyterLab, VS Code's notebooks)."""
    return "ipykernel" in sys.modules


def interactive() -> bool:
    """Whether someone is watching: a notebook, or a terminal on standard error."""
    return in_notebook() or sys.stderr.isatty()


def in_a_stage() -> bool:
    """Whether ldpipe's log has a handler: a stage run from the command line or Snakemake (:func:`log_to`)."""
    return bool(logging.getLogger(LOGGER_NAME).handlers)


def _caller_level() -> int:
    """The ``stacklevel`` of the first frame outside ldpipe, from the function calling this one's
    caller: a warning then names the user's line (their ``ldpipe.ld_map(...)``), not ldpipe's."""
    package = str(Path(__file__).resolve().parent)
    frame, level = sys._getframe(2), 2
    while frame is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    return level


def warn_user(logger: logging.Logger, message: str) -> None:
    """Tell the user something they should know: in a stage (:func:`in_a_stage`) as a warning of
    the log; in Python (a notebook, a script) as a :class:`~ldpipe.errors.LdpipeWarning` at the
    user's own line, which Python shows once per place and ``warnings.filterwarnings`` can
    silence, and not also through the log (whose warnings Python prints to standard error)."""
    if in_a_stage():
        logger.warning(message)
    else:
        logger.info(message)
        warnings.warn(message, LdpipeWarning, stacklevel=_caller_level())


def tell_user(logger: logging.Logger, message: str) -> None:
    """A notice someone watching should see (a long wait that is not a fault): in a stage the
    log's information, in a notebook or a terminal standard error, elsewhere the log alone."""
    if not in_a_stage() and interactive():
        print(message, file=sys.stderr, flush=True)
    logger.info(message)


#: Seconds a map's progress bar waits before it shows, when shown because someone is watching:
#: a map done sooner shows none.
PROGRESS_DELAY_S = 2.0


def progress_bar(logger: logging.Logger, *, show: bool | None, **options):
    """A progress bar (``tqdm``'s ``options``: total, unit, desc): ``show`` True always, False
    never, None (the Python API's default) when someone is watching (:func:`interactive`), and
    then only for a long run (:data:`PROGRESS_DELAY_S`). In a notebook it is tqdm's notebook bar
    (``tqdm.auto``), elsewhere text on the terminal or lines in the log (:func:`progress_output`)."""
    if show is None:
        show = interactive()
        options.setdefault("delay", PROGRESS_DELAY_S)
    if show and in_notebook():
        from tqdm.auto import tqdm as auto_tqdm

        return auto_tqdm(**options)
    from tqdm import tqdm

    stream, interval = progress_output(logger)
    return tqdm(disable=not show, file=stream, mininterval=interval, ascii=stream is not sys.stderr, **options)


def progress_output(logger: logging.Logger) -> tuple[io.TextIOBase, float]:
    """Where a progress bar goes, and how often: the terminal (or a notebook's output) when there
    is one, else the log."""
    if sys.stderr.isatty() or "ipykernel" in sys.modules:
        return sys.stderr, 1.0
    return LogStream(logger), 30.0
