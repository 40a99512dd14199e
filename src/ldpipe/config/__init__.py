"""Configuration: loading, the schema's validation and defaults, and the rules a schema cannot say.

``loading`` reads a file and validates it as a whole; the rules of LD maps and Poincaré
sections live in ``maps``, those of the studies (orbits, NHIM, sampling, saddle flux,
transport, accuracy) in ``studies``, those of figures and their captions in ``figures``.
"""

from .loading import SCHEMA_RESOURCE, load_config, load_schema, validate_config

__all__ = ["SCHEMA_RESOURCE", "load_config", "load_schema", "validate_config"]
