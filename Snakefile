# The pipeline's entry point: `snakemake --cores 2` runs the embedded default.
# The workflow itself lives in workflow/ (rules per stage in workflow/rules/).


include: "workflow/Snakefile"


rule default:
    default_target: True
    input:
        rules.all.input,
