# Figures: one rule per entry under `figures:` in the configuration, named after it, so that
# `snakemake fig3` builds that figure and only the stages it draws. The helpers are library
# functions (ldpipe.stages.figures), tested there.
from ldpipe.stages.figures import (
    figure_animation_output,
    figure_input_files,
    figure_memory_mb,
    figure_outputs,
    figure_parameters,
)


report: "../report/workflow.rst"


# Included last, so every other rule is known here: a figure may not take a rule's name.
_taken = {rule.name for rule in workflow.rules}
for _figure in FIGURES:
    if _figure in _taken:
        raise WorkflowError(
            f"config key 'figures.{_figure}': the name is taken by a rule of the workflow; rename the figure"
        )

    rule:
        name:
            _figure
        input:
            code=library_code("ldpipe.stages.figures"),
            **figure_input_files(config, _figure, RESULTS),
        output:
            png=report(
                figure_outputs(_figure, RESULTS)["png"],
                caption=f"../report/{config['figures'][_figure]['kind']}.rst",
                category="Figures",
                labels={"figure": _figure, "kind": config["figures"][_figure]["kind"]},
            ),
            pdf=figure_outputs(_figure, RESULTS)["pdf"],
            **figure_animation_output(config, _figure, RESULTS),
        params:
            figure=figure_parameters(config, _figure),
        log:
            f"{RESULTS}/logs/figures/{_figure}.log",
        benchmark:
            f"{RESULTS}/benchmarks/figures/{_figure}.tsv"
        conda:
            "../envs/ldpipe.yaml"
        threads: 1
        resources:
            mem_mb=figure_memory_mb(config, _figure),
            runtime=20,
        script:
            "../scripts/figure.py"
