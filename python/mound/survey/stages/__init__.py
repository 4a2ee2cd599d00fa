"""The survey's stages, one module each, run in order by `run_stages`: the stage table
(after ODM's) alone says what stages there are and their order (classify, field, plan,
mission, photos, sites3d (or learn: sites3d flight by flight), report); the ledger's keys,
--rerun-from and the report follow it. Each stage reads the run's Context
(mound.survey.context) and the files of the stages before it, writes its own, and is
skipped on a rerun when its inputs are unchanged (context.run_stage)."""

from __future__ import annotations

from collections.abc import Callable

from mound.survey.context import Context
from mound.survey.stages.classify import stage_classify
from mound.survey.stages.field import stage_field
from mound.survey.stages.learn import stage_learn
from mound.survey.stages.mission import stage_mission
from mound.survey.stages.photos import stage_photos
from mound.survey.stages.plan import stage_plan
from mound.survey.stages.report import stage_report
from mound.survey.stages.sites3d import stage_sites3d


def _sites(ctx: Context) -> str:
    return stage_learn(ctx) if ctx.args.learn else stage_sites3d(ctx)


# (its name: the ledger's, --rerun-from's; the stage), in the order they run
TABLE: tuple[tuple[str, Callable[[Context], str]], ...] = (
    ("classify", stage_classify),
    ("field", stage_field),
    ("plan", stage_plan),
    ("mission", stage_mission),
    ("photos", stage_photos),
    ("sites3d", _sites),
    ("report", stage_report),
)
NAMES = tuple(name for name, _ in TABLE)


def run_stages(ctx: Context) -> None:
    """Every stage of the table in order."""
    ctx.order = NAMES
    for _, stage in TABLE:
        stage(ctx)
