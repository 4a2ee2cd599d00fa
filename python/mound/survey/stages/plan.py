"""The plan stage: mound_plan's tour (or K flights) within the budget."""

from __future__ import annotations

from mound import native
from mound.jsonio import read_json
from mound.survey.context import Context, run_stage


def stage_plan(ctx: Context) -> str:
    a = ctx.args

    def work() -> tuple[list[str], str, bool]:
        native.run_tool("mound_plan", [str(ctx.tree.sites), "--algo", a.algo, "--seed",
                                       str(a.plan_seed), "--flights", str(a.flights),
                                       "--out", str(ctx.tree.plan)],
                        timeout_s=600, log=ctx.tree.root / "log.txt")
        plan = read_json(ctx.tree.plan, "mound.plan", 1)
        if a.scene:
            from mound.survey import figures

            ctx.tree.report_dir.mkdir(parents=True, exist_ok=True)
            figures.scene_map(ctx.tree.root, read_json(ctx.tree.sites, "mound.sites", 1), plan,
                              ctx.tree.report_dir / "scene.png")
        each = "; ".join(f"flight {f['flight']}: {len(f['tour']) - 2} sites, "
                         f"{f['reward']:.2f} bits, {f['cost_m']:.0f} m"
                         for f in plan["flights"]) if len(plan["flights"]) > 1 else ""
        budget = (f"{plan['cost_m']:.0f} m in {len(plan['flights'])} flights of "
                  f"{plan['budget_m']:.0f} m each ({each})" if each else
                  f"{plan['cost_m']:.0f} m of {plan['budget_m']:.0f} m")
        return (["plan.json"], f"{a.algo}: {plan['n_visited']} of {plan['n_sites']} sites, "
                f"reward {plan['reward']:.2f} bits, {budget}", True)

    return run_stage(ctx, "plan", {"field": ctx.keys["field"], "algo": a.algo,
                                   "seed": a.plan_seed, "flights": a.flights}, work)
