# A fleet of campaigns (config key `campaigns`): each campaign is this same workflow, as a
# Snakemake module with its own config (flidar_uq.workflow.inputs.campaign_configs: the
# shared top-level sections with the campaign's own laid over them) and its paths moved
# from results/ to results/<name>/ (replace_prefix), its rules named <name>_<rule>. The
# campaigns are independent branches of one DAG: under a cluster executor their jobs run
# side by side. The fleet summary (results/fleet/) compares them.
import os
import sys

from flidar_uq.workflow.inputs import FLEET_DIR, campaign_configs, pipeline_preflight


# Before any job: every campaign's config and data checked, a problem's key naming the
# campaign (campaigns.<name>.<key>), one line and exit status 2 or 3.
_status = pipeline_preflight(config, read_data=workflow.is_main_process)
if _status:
    sys.exit(_status)

CAMPAIGNS = campaign_configs(config)
FLEET_SUMMARY = f"results/{FLEET_DIR}/summary"

for _campaign, _campaign_config in CAMPAIGNS.items():
    _rule_prefix = f"{_campaign}_"

    module:
        name:
            _campaign
        snakefile:
            os.path.join(workflow.basedir, "Snakefile")
        config:
            _campaign_config
        replace_prefix:
            {"results/": f"results/{_campaign}/"}

    use rule * from _campaign exclude all as _rule_prefix*


rule fleet_summary:
    input:
        records=expand("results/{campaign}/ti/records.csv", campaign=CAMPAIGNS),
        groups=expand("results/{campaign}/ti/groups.csv", campaign=CAMPAIGNS),
        metrics=expand("results/{campaign}/ti/metrics.csv", campaign=CAMPAIGNS),
        # each campaign's report: its last step, so its whole results/<name>/ tree
        reports=expand("results/{campaign}/report/report.html", campaign=CAMPAIGNS),
    output:
        table=report(f"{FLEET_SUMMARY}.csv", caption="../report/fleet.rst", category="Fleet"),
        html=f"{FLEET_SUMMARY}.html",
        figure=f"{FLEET_SUMMARY}.png",
    params:
        campaigns=list(CAMPAIGNS),
    localrule: True
    conda:
        "../envs/flidar_uq.yaml"
    log:
        f"results/{FLEET_DIR}/logs/fleet_summary.log",
    benchmark:
        f"results/{FLEET_DIR}/benchmarks/fleet_summary.tsv"
    script:
        "../scripts/fleet_summary.py"

