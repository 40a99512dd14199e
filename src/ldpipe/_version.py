"""The installed ldpipe's version: a module of its own, so that the files' writer reads it
without importing the package's face (the API and the accessor)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ldpipe")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0+unknown"
