"""The report stage: summary.json, report.html, report.md and the map."""

from __future__ import annotations

from mound.jsonio import write_json
from mound.survey.context import Context, run_stage


def stage_report(ctx: Context) -> str:
    from mound.survey import report

    def work() -> tuple[list[str], str, bool]:
        summary = report.build_summary(ctx.tree, ctx.args, ctx.stages, ctx.started)
        summary = report.write_reports(ctx.tree, summary)  # with the map page's name
        write_json(ctx.tree.summary, summary.to_doc())
        m = summary.metrics
        fmt = (lambda v: "n/a" if v is None else f"{v:.3f}")  # noqa: E731
        return (["summary.json", "report.html", "report.md"]
                + (["map.html"] if summary.map else []),
                f"eps_MD {fmt(m.survey.eps_md)}, eps_FA {fmt(m.survey.eps_fa)} (classifier "
                f"alone: {fmt(m.classifier_only.eps_md)}, "
                f"{fmt(m.classifier_only.eps_fa)}) -> {ctx.tree.report_html}", True)

    # The report always reflects this run's stage table, so it is rebuilt every time
    # (a few seconds); its key still records what it was built from.
    return run_stage(ctx, "report", {k: ctx.keys.get(k) for k in ctx.before("report")}, work,
                     always=True)
