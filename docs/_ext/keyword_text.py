"""The API's keyword help, which ``ldpipe.api.keywords`` writes from the schema's descriptions as
plain text for ``help()``, read as plain text by Sphinx too: in its "Other Parameters" section the
characters reStructuredText would take for markup (``|x|`` a substitution, ``phi_`` a reference,
``*`` emphasis) are escaped; the double-backquoted key names the section writes stay literals."""

from __future__ import annotations

import re

#: |...| (a substitution), a word's trailing _ (a reference), * and a lone ` (emphasis, roles).
_MARKUP = re.compile(r"\||(?<=\w)_(?=\W|$)|\*|(?<!`)`(?!`)")


def _escaped(line: str) -> str:
    parts = re.split(r"(``[^`]+``)", line)  # literals first, left as they are
    return "".join(part if part.startswith("``") else _MARKUP.sub(lambda m: "\\" + m.group(0), part)
                   for part in parts)


def escape_keyword_help(app, what, name, obj, options, lines: list[str]) -> None:
    inside = False
    for index, line in enumerate(lines):
        stripped = line.strip()
        if stripped in ("Other Parameters", ".. rubric:: Other Parameters", ":Other Parameters:"):
            inside = True
            continue
        if inside and stripped in ("Returns", "Raises", "Examples", "See Also", "Notes", "-------", "------"):
            if stripped not in ("-------", "------"):
                inside = False
            continue
        if inside and not set(stripped) <= {"-"}:
            lines[index] = _escaped(line)


def setup(app):
    # before napoleon turns the numpydoc sections into fields (its handler has priority 500)
    app.connect("autodoc-process-docstring", escape_keyword_help, priority=400)
    return {"parallel_read_safe": True}
