"""The transport and saddle-flux captions are Jinja templates over a study's parameters: rendered
with the shipped configuration's studies, they must be clean reStructuredText (no docutils
message: e.g. |x| is read as a substitution). The report test renders them only in a full run."""

import io
from types import SimpleNamespace

import jinja2
import pytest
from docutils.core import publish_parts

from ldpipe.config import load_config
from ldpipe.config.parameters import parameters_from_config
from support.workflow import ROOT


@pytest.mark.parametrize("caption, section", [("transport.rst", "transport"), ("saddle_flux.rst", "saddle_flux")])
def test_caption_renders_without_docutils_messages(caption, section):
    config = load_config(ROOT / "config.yaml")
    template = jinja2.Template((ROOT / "workflow/report" / caption).read_text())
    for study in config[section]:
        parameters = parameters_from_config(config, section, study)
        rst = template.render(snakemake=SimpleNamespace(params=SimpleNamespace(study=parameters)))
        stream = io.StringIO()
        html = publish_parts(rst, writer="html", settings_overrides={"report_level": 1, "warning_stream": stream})
        assert stream.getvalue() == "" and "System Message" not in html["body"], stream.getvalue()
        assert study in rst
