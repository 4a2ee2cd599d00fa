"""The plan stage: mound_plan's tour (or K flights) within the budget."""

from __future__ import annotations

from mound import native
from mound.formats.plan import Plan
from mound.formats.sites import Sites
from mound.survey.context import Context, run_stage


def stage_plan(ctx: Context) -> str:
    a = ctx.args

    def work() -> tuple[list[str], str, bool]:
        native.run_tool("mound_plan", [str(ctx.tree.sites), "--algo", a.algo, "--seed",
                                       str(a.plan_seed), "--flights", str(a.flights),
                                       "--out", str(ctx.tree.plan)],
                        timeout_s=600, log=ctx.tree.root / "log.txt")
        plan = Plan.read(ctx.tree.plan)
        if a.scene:
            from mound.survey import figures

            ctx.tree.report_dir.mkdir(parents=True, exist_ok=True)
            figures.scene_map(ctx.tree.root, Sites.read(ctx.tree.sites), plan,
                              ctx.tree.report_dir / "scene.png")
        each = "; ".join(f"flight {k}: {len(f.sites)} sites, {f.reward:.2f} bits, "
                         f"{f.cost_m:.0f} m" for k, f in enumerate(plan.flights, start=1)
                         ) if len(plan.flights) > 1 else ""
        budget = (f"{plan.cost_m:.0f} m in {len(plan.flights)} flights of "
                  f"{plan.budget_m:.0f} m each ({each})" if each else
                  f"{plan.cost_m:.0f} m of {plan.budget_m:.0f} m")
        return (["plan.json"], f"{a.algo}: {len(plan.visited())} of {plan.extra['n_sites']} "
                f"sites, reward {plan.reward:.2f} bits, {budget}", True)

    return run_stage(ctx, "plan", {"field": ctx.keys["field"], "algo": a.algo,
                                   "seed": a.plan_seed, "flights": a.flights}, work)
