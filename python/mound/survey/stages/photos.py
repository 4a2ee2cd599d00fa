"""The photos stage: the aircraft's card (--photos, --second-photos) sorted into the visited
sites."""

from __future__ import annotations

from pathlib import Path

from mound.errors import InputError
from mound.formats.survey import StageRun
from mound.survey.context import Context, card_digest, digest_files, run_stage


def stage_photos(ctx: Context) -> str:
    """--photos: the card sorted into the visited sites of plan.json (links, photos.json)."""
    from mound.photos.sort import SortSpec, sort_card

    a = ctx.args
    if not a.photos:
        note = ("not needed: photos from --images-root" if a.images_root
                else "battery by battery (--cards): each card is sorted as its battery is "
                "judged (battery_K/photos/)" if a.cards is not None
                else "not needed: each visited site's flight is simulated")
        ctx.stages.append(StageRun("photos", 0.0, True, note))
        ctx.say(f"[photos] {note}")
        ctx.keys["photos"] = "none"
        return "none"

    def work() -> tuple[list[str], str, bool]:
        assert a.photos
        doc = sort_card(a.photos, str(ctx.tree.plan), str(ctx.tree.photos),
                        SortSpec(site_diameter_m=a.site_diameter_m), a.camera)
        counts = ", ".join(f"{n} {k}" for k, n in sorted(doc.counts.items()))
        ok = sum(1 for v in doc.sites.values() if v.status == "ok")
        few = [k for k, v in doc.sites.items() if v.status != "ok"]
        note = (f"{doc.files} files on the card: {counts}; {ok} of "
                f"{len(doc.sites)} visited sites with enough photos"
                + (f" (too few: {', '.join(few)})" if few else ""))
        made = ["photos/photos.json"]
        if a.second_photos:
            plan2 = ctx.tree.second_look / "plan.json"
            if not plan2.is_file():
                raise InputError(f"--second-photos: no second looks to sort it by ({plan2} "
                                 "is missing: the run before advised none, or has not run)")
            second = sort_card(a.second_photos, str(plan2), str(ctx.tree.second_photos),
                               SortSpec(site_diameter_m=a.site_diameter_m), a.camera)
            ok2 = [k for k, v in second.sites.items() if v.status == "ok"]
            note += (f"; second card: {second.files} files, {len(ok2)} of "
                     f"{len(second.sites)} second looks with enough photos")
            made.append(str((ctx.tree.second_photos / "photos.json").relative_to(
                ctx.tree.root)))
        return made, note, True

    material = {"plan": ctx.keys["plan"], "card": card_digest(Path(a.photos)),
                "camera": digest_files([a.camera]) if a.camera else None,
                "diameter": a.site_diameter_m,
                "second_card": card_digest(Path(a.second_photos)) if a.second_photos
                else None}
    return run_stage(ctx, "photos", material, work)
