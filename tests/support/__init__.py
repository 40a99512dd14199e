"""What tests in several folders share: closed forms and helpers, one home each.

Importable as ``support`` because pyproject.toml's ``[tool.pytest.ini_options] pythonpath``
puts ``tests/`` on the path; test modules themselves are imported with
``--import-mode=importlib`` and cannot import one another.
"""
