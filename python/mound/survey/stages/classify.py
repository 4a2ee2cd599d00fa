"""The classify stage: the coarse-search classifier (Statlog, or the scenes' model with
--scene)."""

from __future__ import annotations

from mound.formats.survey import StageRun
from mound.jsonio import write_json
from mound.survey.context import Context, digest_files, run_stage


def stage_classify(ctx: Context) -> str:
    from mound import datasets
    from mound.classify import coarse, statlog

    if ctx.args.scene:
        return stage_classify_scene(ctx)
    if ctx.args.sites:
        ctx.stages.append(StageRun("classify", 0.0, True,
                                   "not needed: --sites gives each site's p_mound"))
        ctx.say("[classify] not needed: --sites gives each site's p_mound")
        ctx.keys["classify"] = "user-sites"
        return "user-sites"

    def work() -> tuple[list[str], str, bool]:
        datasets.fetch(datasets.STATLOG)
        model = coarse.train(statlog.load("sat.trn"), coarse.DEFAULT_BAND)
        write_json(ctx.tree.model, model.to_doc())
        s = coarse.evaluate(model, statlog.load("sat.tst"))
        write_json(ctx.tree.classifier_eval, {
            "schema": "mound.classifier_eval", "version": 1,
            **{k: v for k, v in s.items() if k != "reliability"}})
        return (["model.json", "classifier.json"],
                f"band {model.band} logistic regression, sat.tst accuracy {s['accuracy']:.3f}, "
                f"AUC {s['auc']:.3f}", True)

    return run_stage(ctx, "classify", {"data": datasets.STATLOG.files,
                                       "band": coarse.DEFAULT_BAND, "l2": coarse.DEFAULT_L2},
                     work)


def stage_classify_scene(ctx: Context) -> str:
    """The scene model: learned on the scene(s) from --labels, or the user's --scene-model."""
    from mound.args import parse_names
    from mound.jsonio import read_json as read_doc
    from mound.scene.model import SCHEMA as SCENE_SCHEMA
    from mound.scene.model import VERSION as SCENE_VERSION
    from mound.scene.model import SceneModel
    from mound.scene.workflow import train_model

    a = ctx.args
    path = ctx.tree.root / "scene_model.json"

    def work() -> tuple[list[str], str, bool]:
        if a.scene_model:
            doc = read_doc(a.scene_model, SCENE_SCHEMA, SCENE_VERSION)
            SceneModel.from_doc(doc, a.scene_model)
            write_json(path, doc)
            return ["scene_model.json"], f"scene model {a.scene_model}", True
        assert a.labels  # SurveyOptions.check: --labels or --scene-model
        model = train_model(a.scenes, a.labels, str(path), band_names=parse_names(a.band_names))
        cv = model.info.get("cross_validation") or {}
        note = (f"{model.spec.kind} scene model on {len(a.scenes)} scene(s)"
                + (f", leave-scenes-out AUC {cv['auc_mean']:.3f}, recall@5 "
                   f"{cv['recall_at_5']:.3f}" if cv.get("auc_mean") is not None else ""))
        return ["scene_model.json"], note, True

    material = {"scenes": digest_files(a.scenes), "band_names": a.band_names,
                "labels": digest_files([a.labels]) if a.labels else None,
                "model": digest_files([a.scene_model]) if a.scene_model else None}
    return run_stage(ctx, "classify", material, work)
