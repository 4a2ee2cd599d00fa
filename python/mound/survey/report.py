"""The survey's results: summary.json (mound.survey v1), report.html and report.md.

Final label of a site: the 3-D verdict where the UAV visited it and the verdict came out;
the classifier's (p_mound >= 0.5) elsewhere, failed sites included. The paper's error
rates on the sites whose truth is known: eps_MD, the fraction of true mounds labelled
"no mound" (missed detections); eps_FA, the fraction of the other sites labelled "mound"
(false alarms). Beside them, the same rates of the classifier alone and of a perfect
verification of the visited sites (the paper's Table I assumption).

report.html opens from the file system: styles inline, every picture a PNG beside it
(report/ and sites/<id>/), referenced by relative paths.
"""

from __future__ import annotations

import html
import json
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from mound.classify.metrics import detection_error_rates, says_mound
from mound.formats.learn import LearnRecord
from mound.formats.mission import MissionSummary
from mound.formats.photos import CardSummary
from mound.formats.plan import Plan
from mound.formats.site_row import SiteRow
from mound.formats.sites import Sites
from mound.formats.survey import (
    ErrorRates,
    FieldCounts,
    FieldTeamSite,
    StageRun,
    SurveyMetrics,
    SurveySite,
    SurveySummary,
    ThreeAnswers,
)
from mound.jsonio import write_atomic
from mound.survey import figures
from mound.survey.options import SurveyOptions
from mound.survey.tree import RunTree, SiteTree, waiting_for_card


def _plan(path: Path) -> Plan | None:
    return Plan.read(path) if path.is_file() else None


def site_rows(tree: RunTree, sites_doc: Sites, plan: Plan | None) -> list[SurveySite]:
    """Every candidate site, with its 3-D work's row where the tour visited it (its files
    those that exist, relative to the run directory as report.html is)."""
    tour = plan.visited() if plan else set()
    rows = []
    for s in sites_doc.sites:
        row = None
        if s.id in tour:
            path = SiteTree(tree.site_dir(s.id)).result
            row = SiteRow.read(path) if path.is_file() else None
        if row is not None and row.files:
            row = replace(row, files={k: v for k, v in row.files.items()
                                      if (tree.root / v).exists()})
        rows.append(SurveySite(s, s.id in tour, row))
    return rows


def three_answer_metrics(judged: list[SurveySite]) -> ThreeAnswers:
    """The judged sites by the verdict's own answer, and the selective error rates: of the
    decided sites with a known truth, the true mounds called no_mound and the other sites
    called mound (the undecided ones left to a second look or a person)."""
    answer = [r.answer or r.verdict for r in judged]
    decided = [r for r, a in zip(judged, answer, strict=True)
               if a != "undecided" and r.truth is not None]
    mounds = [r for r in decided if r.truth]
    others = [r for r in decided if not r.truth]
    return ThreeAnswers(
        sum(1 for a in answer if a != "undecided"), sum(1 for a in answer if a == "undecided"),
        ErrorRates(sum(1 for r in mounds if (r.answer or r.verdict) == "no_mound") / len(mounds)
                   if mounds else None,
                   sum(1 for r in others if (r.answer or r.verdict) == "mound") / len(others)
                   if others else None),
        len(decided))


def field_team(judged: list[SurveySite]) -> list[FieldTeamSite]:
    """The sites still undecided after every look the survey flew: for the field team, each
    with its p(mound) and why (the verdict's undecided reasons)."""
    out = []
    for r in judged:
        v = r.judged_verdict
        if v is None or v.label != "undecided" or r.row is None:
            continue
        why = r.undecided_reasons()
        look = r.row.second_look
        codes = (x.get("code") for x in why)
        out.append(FieldTeamSite(r.id, r.site.x_m, r.site.y_m, v.p_mound,
                                 tuple(c if isinstance(c, str) else None for c in codes),
                                 "; ".join(str(x.get("text", "")) for x in why),
                                 bool(look is not None and look.flown)))
    return out


def _rates(labels: list[bool], truth: list[bool | None]) -> ErrorRates:
    return ErrorRates(*detection_error_rates(labels, truth))


def build_summary(tree: RunTree, args: SurveyOptions, stages: list[StageRun],
                  started: float) -> SurveySummary:
    learned = args.learn
    sites_doc = Sites.read(tree.final_sites(learned))
    plan = _plan(tree.final_plan(learned))
    rows = site_rows(tree, sites_doc, plan)
    truth = [r.truth for r in rows]
    final = [r.final_label == "mound" for r in rows]
    classifier = [r.classifier_label == "mound" for r in rows]
    perfect = [bool(r.truth) if r.visited and r.truth is not None else c
               for r, c in zip(rows, classifier, strict=True)]
    visited = [r for r in rows if r.visited]
    judged = [r for r in visited if r.judged]
    correct = [r for r in judged if r.truth is not None and (r.verdict == "mound") == r.truth]
    status, reason = "ok", ""
    if not visited:
        status, reason = "failed", "no site fits the budget: nothing was flown"
    elif not judged:
        status, reason = "failed", "no visited site could be judged (see sites[].failure)"
    elif len(judged) < len(visited):
        status, reason = "partial", f"{len(visited) - len(judged)} visited sites failed"
    waiting = waiting_for_card(tree) if args.cards is not None else None
    if waiting is not None and status != "partial":
        status, reason = "waiting", waiting
    learn, before = None, None
    if learned and (tree.learn / "learn.json").is_file():
        learn = LearnRecord.read(tree.learn / "learn.json")
        first = Sites.read(tree.sites)
        before = _rates([s.p_mound is not None and says_mound(s.p_mound)
                         for s in first.sites], truth)
    photos = None
    if (tree.photos / "photos.json").is_file():
        photos = CardSummary.read(tree.photos / "photos.json", "photos/photos.json")
    metrics = SurveyMetrics(
        _rates(final, truth), plan.reward if plan else 0.0, plan.cost_m if plan else 0.0,
        sites_doc.budget_m, len(visited), len(judged), len(correct),
        sum(1 for r in judged if r.truth is not None), _rates(classifier, truth),
        _rates(perfect, truth), three_answer_metrics(judged), before)
    return SurveySummary(
        status, reason, time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), sites_doc.origin,
        args.as_dict(),
        FieldCounts(args.sites or f"standard field seed {args.field_seed}", len(rows),
                    sum(1 for t in truth if t), sum(1 for t in truth if t is not None),
                    sum(r.site.reward for r in rows)),
        tuple(rows), metrics, tuple(field_team(judged)), tuple(stages), time.time() - started,
        learn, photos, plan, _missions(tree.mission_summary),
        _missions(tree.second_look / "mission.json"))


def _missions(path: Path) -> MissionSummary | None:
    return MissionSummary.read(path) if path.is_file() else None


def _second_look_text(s: SurveySummary) -> str:
    """The second looks' missions in a sentence (plain text; empty without any)."""
    second = s.second_look
    sl = second.second_look if second is not None else None
    if second is None or sl is None:
        return ""
    flights = second.flights
    text = (f"Second looks advised for {len(sl.sites)} sites ({', '.join(sl.sites)}): "
            f"{len(flights)} mission{'s' if len(flights) != 1 else ''} with a "
            f"{_fmt(sl.site_diameter_m, 0)} m scan ({_fmt(sl.scan_factor, 1)} x as wide), "
            f"{_fmt(second.flight_distance_m, 0)} m in all, in second_look/ ("
            + "; ".join(f"{f.file}: {', '.join(x.id for x in f.sites)}, "
                        f"{_fmt(f.flight_distance_m, 0)} m" for f in flights) + ").")
    for r in sl.refused:
        text += f" {r.id} refused: {r.reason}."
    return text


def _fmt(v: Any, digits: int = 3) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


STYLE = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:24px;color:#222;
max-width:1200px}
h1{margin-bottom:4px} h2{border-bottom:1px solid #ccc;padding-bottom:4px;margin-top:32px}
table{border-collapse:collapse;font-size:13px;margin:8px 0}
td,th{border:1px solid #ddd;padding:3px 8px;text-align:right}
th{background:#f3f3f3} td.l,th.l{text-align:left}
.mound{color:#b35900;font-weight:600} .no_mound{color:#205080} .failed{color:#b00020;
font-weight:600}
.card{border:1px solid #ccc;border-radius:6px;padding:10px 14px;margin:14px 0}
.card img{max-width:100%;margin:4px 0} .row{display:flex;gap:12px;flex-wrap:wrap}
.row img{max-width:48%} .muted{color:#666;font-size:13px} .big{font-size:18px}
"""

CHECK_IMAGES = """
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); });
  document.body.setAttribute('data-images', String(imgs.length));
  document.body.setAttribute('data-broken', broken.map(function (i) {
    return i.getAttribute('src'); }).join(' '));
});
"""


def _label(v: str) -> str:
    return f'<span class="{html.escape(v)}">{html.escape(v.replace("_", " "))}</span>'


def _img(src: str, alt: str) -> str:
    return f'<img src="{html.escape(src)}" alt="{html.escape(alt)}">'


def _site_card(r: SurveySite) -> str:
    e = html.escape
    row = r.row or SiteRow(r.id, "", reason="not processed")
    truth = "" if r.truth is None else (" · truth: " + _label("mound" if r.truth
                                                             else "no_mound"))
    parts = [f'<div class="card" id="site-{e(r.id)}"><div class="big"><b>{e(r.id)}</b> '
             f'at ({r.site.x_m:.0f}, {r.site.y_m:.0f}) m · p(mound) {r.p_mound:.3f} · '
             f'3-D verdict: {_label(r.answer or r.verdict or "")}{truth}</div>']
    v = r.judged_verdict
    if v is None:
        parts.append(f'<p class="failed">failed: {e(row.reason or "?")}</p>'
                     f'<p class="muted">final label from the classifier: '
                     f'{_label(r.final_label)}</p>')
    else:
        prob = (f'p(mound) {_fmt(v.p_mound)}, calibrated' if v.p_mound is not None
                else f'confidence {_fmt(v.confidence)}')
        if row.verdict_cloud:
            prob += f', judged on the {e(row.verdict_cloud)} cloud'
        parts.append(f'<p>{e(v.reason)} ({prob}, method {e(v.method)})</p>')
        look = row.second_look
        if look is not None and look.flown:
            first = row.first_look.p_mound if row.first_look is not None else None
            parts.append(f'<p>second look (a scan of {_fmt(look.site_diameter_m, 0)} m; the first '
                         f'flight left it undecided at p(mound) {_fmt(first)}): '
                         f'{_label(str(r.verdict))}</p>')
        elif look is not None:
            parts.append(f'<p class="failed">second look advised, not flown: '
                         f'{e(look.reason or "")}</p>')
        if v.label == "undecided":
            why = "; ".join(str(x.get("text", "")) for x in r.undecided_reasons())
            parts.append(f'<p class="failed">undecided, for the field team: {e(why)}</p>')
        cov = v.coverage
        if cov is not None and cov.get("status") == "clipped":
            parts.append(f'<p class="failed">coverage: {e(str(cov.get("message", "")))}</p>')
        for key, what in (("dense_error", "dense cloud"), ("rasters_error", "GeoTIFFs")):
            if row.extra.get(key):
                parts.append(f'<p class="failed">{what}: {e(str(row.extra[key]))}</p>')
    files = row.files
    if "thumbnails" in files:
        parts.append(_img(files["thumbnails"], f"images of {r.id}"))
    pics = [_img(files[k], f"{k} of {r.id}") for k in ("cloud", "relief", "terrain")
            if k in files]
    if pics:
        parts.append('<div class="row">' + "".join(pics) + "</div>")
    rec, sim = row.extra.get("recon"), row.extra.get("simulated")
    bits = []
    if isinstance(rec, dict) and rec:
        bits.append(f"{rec.get('registered')}/{rec.get('images')} images registered, "
                    f"{rec.get('points')} points, RMSE {_fmt(rec.get('reprojection_rmse_px'))}"
                    f" px, frame {rec.get('frame')}")
    if isinstance(sim, dict) and sim:
        bits.append("simulated " + (f"tumulus {sim['height_m']:.1f} m high, "
                                    f"{sim['diameter_m']:.0f} m across" if sim["mound"]
                                    else "flat ground") + f" (seed {sim['seed']})")
    if row.timings_s:
        bits.append("time " + ", ".join(f"{k} {t:.1f} s" for k, t in row.timings_s.items()))
    if row.worker:
        bits.append(f"worker {row.worker}")
    parts.append('<p class="muted">' + e(" · ".join(bits)) + "</p></div>")
    return "".join(parts)


def _metrics_table(m: SurveyMetrics) -> str:
    rows = [("classifier alone (p ≥ 0.5)", m.classifier_only),
            ("this survey (3-D verdicts where visited)", m.survey),
            ("perfect verification of the visited sites", m.perfect_verification)]
    three = m.three_answers
    if three.undecided:
        rows.insert(2, (f"this survey, its {three.decided} decided verdicts only "
                        f"({three.undecided} undecided)", three.selective))
    body = "".join(f'<tr><td class="l">{html.escape(name)}</td><td>{_fmt(v.eps_md)}</td>'
                   f'<td>{_fmt(v.eps_fa)}</td></tr>' for name, v in rows)
    return ('<table><tr><th class="l">labels</th><th>ε<sub>MD</sub> (missed)</th>'
            f'<th>ε<sub>FA</sub> (false alarms)</th></tr>{body}</table>')


def _card_table(card: CardSummary) -> str:
    """The sorted photo card: what became of its files, and each site's photos."""
    e = html.escape
    counts = "".join(f'<tr><td class="l">{e(k)}</td><td>{n}</td></tr>'
                     for k, n in sorted(card.counts.items()))
    sites = "".join(
        f'<tr><td class="l">{e(sid)}</td><td>{v.photos}</td><td>{v.blurred}</td>'
        f'<td>{v.median_sharpness:.0f}</td><td class="l">{e(v.status)}</td>'
        f'<td class="l">{e(str(v.camera.get("source", "")))}</td></tr>'
        for sid, v in card.sites.items())
    skipped = "".join(f"<li>{e(x)}</li>" for x in card.skipped_folders)
    return (f'<p>Card {e(card.card)} ({e(card.file)}): every file, its site or why '
            'it has none.</p><div class="row"><table><tr><th class="l">files</th><th>count'
            f'</th></tr>{counts}</table><table><tr><th class="l">site</th><th>photos</th>'
            '<th>blurred</th><th>median sharpness</th><th class="l">status</th>'
            f'<th class="l">camera</th></tr>{sites}</table></div>'
            + (f'<p class="muted">folders not read:</p><ul>{skipped}</ul>' if skipped else ""))


def _learn_table(learn: LearnRecord, m: SurveyMetrics) -> str:
    """Each flight teaching the next: what it flew, what was learned, how p changed."""
    e = html.escape
    body = ""
    for f in learn.flights:
        ex = ", ".join(f'{x.id} {x.verdict.replace("_", " ")} ({x.confidence:.2f})'
                       for x in f.examples)
        moved = ", ".join(f'{c.id} {c.p_before:.3f}→{c.p_after:.3f}' for c in f.changes[:3])
        first = " ".join(f.first_plan_sites)
        body += (f'<tr><td>{f.flight}</td><td class="l">{e(" ".join(f.sites))}</td>'
                 f'<td class="l">{e(first)}</td>'
                 f'<td>{f.planned_reward:.2f}</td><td class="l">{e(ex)}</td>'
                 f'<td>{f.held_out_auc:.4f}</td><td>{f.labels_flipped}</td>'
                 f'<td>{f.max_abs_dp:.4f}</td><td class="l">{e(moved)}</td></tr>')
    before = m.classifier_before_flights or ErrorRates(None, None)
    return (f'<p>After each flight its verdicts (weighted by confidence times '
            f'{learn.learn_weight:g}) retrained the classifier and the next flight was '
            f're-planned. Held-out AUC ({e(learn.evaluation)}, '
            f'{learn.held_out_rows} rows): {learn.held_out_auc_before:.4f} before, '
            f'{learn.held_out_auc_after:.4f} after. The classifier alone before any '
            f'flight: ε<sub>MD</sub> {_fmt(before.eps_md)}, ε<sub>FA</sub> '
            f'{_fmt(before.eps_fa)}.</p><table><tr><th>flight</th>'
            '<th class="l">sites flown</th><th class="l">sites of the first plan</th>'
            '<th>planned reward (bits)</th><th class="l">learned '
            '(verdict, confidence)</th><th>held-out AUC</th><th>labels flipped</th>'
            '<th>max |Δp|</th><th class="l">largest changes of p</th></tr>'
            f'{body}</table>')


def _stage_table(stages: tuple[StageRun, ...]) -> str:
    body = ""
    for s in stages:
        wall = (f"skipped (ran in {_fmt(s.wall_s_when_run, 1)} s)" if s.skipped
                else f"{s.wall_s:.1f} s")
        body += (f'<tr><td class="l">{html.escape(s.name)}</td><td>{wall}</td>'
                 f'<td class="l">{html.escape(s.note)}</td></tr>')
    return ('<table><tr><th class="l">stage</th><th>wall time</th><th class="l">result</th>'
            f'</tr>{body}</table>')


def _sites_table(rows: tuple[SurveySite, ...]) -> str:
    body = ""
    for r in sorted(rows, key=lambda r: (not r.visited, -r.site.reward)):
        link = (f'<a href="#site-{html.escape(r.id)}">{html.escape(r.id)}</a>'
                if r.visited else html.escape(r.id))
        truth = "" if r.truth is None else _label("mound" if r.truth else "no_mound")
        v = r.judged_verdict
        p = v.p_mound if v is not None else None
        body += (f'<tr><td class="l">{link}</td><td>{r.site.x_m:.0f}</td>'
                 f'<td>{r.site.y_m:.0f}</td><td>{r.p_mound:.3f}</td>'
                 f'<td>{r.site.reward:.3f}</td><td>{"yes" if r.visited else ""}</td>'
                 f'<td class="l">{_label(r.verdict) if r.verdict is not None else ""}</td>'
                 f'<td>{_fmt(p) if p is not None else ""}</td>'
                 f'<td class="l">{_label(r.final_label)}</td><td class="l">{truth}</td></tr>')
    return ('<table><tr><th class="l">site</th><th>x (m)</th><th>y (m)</th><th>p(mound)</th>'
            '<th>reward (bits)</th><th>visited</th><th class="l">3-D verdict</th>'
            '<th>verdict p(mound)</th>'
            f'<th class="l">final label</th><th class="l">truth</th></tr>{body}</table>')


def write_reports(tree: RunTree, summary: SurveySummary) -> SurveySummary:
    """report.html, report.md, the field figure and the map; the summary with the map
    page's name (None: the map's libraries are not installed)."""
    tree.report_dir.mkdir(parents=True, exist_ok=True)
    learned = bool(summary.options.get("learn"))
    sites_doc = Sites.read(tree.final_sites(learned))
    figures.field_map(sites_doc, summary.plan,
                      {r.id: r.verdict for r in summary.sites if r.verdict is not None},
                      tree.report_dir / "field.png")
    from mound.survey import webmap

    basemap = summary.options.get("basemap")
    page = webmap.write_map(tree, summary, sites_doc,
                            basemap=basemap if isinstance(basemap, str) else None)
    summary = replace(summary, map=page.name if page else None)
    write_atomic(tree.report_html, render_html(tree, summary))
    write_atomic(tree.report_md, render_md(summary))
    return summary


def _wall_line(s: SurveySummary) -> str:
    """This invocation's wall time, and the stages' own times when some were skipped."""
    line = f"wall time {s.wall_s:.0f} s"
    if any(st.skipped for st in s.stages):
        total = sum((st.wall_s_when_run or 0.0) if st.skipped else st.wall_s
                    for st in s.stages)
        line += f" (resumed; the stages took {total:.0f} s when they ran)"
    return line


def _mission_text(mission: MissionSummary | None) -> str:
    """The mission in a sentence: its items, each flight where there are several (over a
    DEM its energy and lowest clearance), and whether it was uploaded."""
    flights = mission.flights if mission is not None else ()
    upload = mission.upload if mission is not None else None
    return (f"Mission: {mission.items if mission is not None else 0} MAVLink items"
            + (f" in {len(flights)} flights ("
               + "; ".join(f"flight {f.flight}: {len(f.sites)} sites, "
                           f"{f.flight_distance_m:.0f} m"
                           + (f", energy {f.terrain.energy_m:.0f} m, lowest clearance "
                              f"{f.terrain.lowest_clearance_m:.1f} m" if f.terrain else "")
                           for f in flights) + ")"
               if len(flights) > 1 else "") + ", "
            + (f"uploaded to system {upload.target_system} and read back."
               if upload else "not uploaded (no --connect)."))


def render_html(tree: RunTree, s: SurveySummary) -> str:
    e = html.escape
    m = s.metrics
    algo = s.plan.algo if s.plan is not None else ""
    head = (f"<p>{e(s.field.source)}: {s.field.sites} candidate sites, "
            f"{s.field.true_mounds} true mounds; status <b>{e(s.status)}</b>"
            + (f" ({e(s.reason)})" if s.reason else "") + "</p>"
            f"<p>Tour ({e(str(algo or ''))}): {m.visited} sites, reward "
            f"{_fmt(m.reward, 2)} bits, {_fmt(m.cost_m, 0)} m of a {m.budget_m:.0f} m budget. "
            f"3-D verdicts: {m.judged} of {m.visited} sites ({m.failed} failed), "
            f"{m.verdicts_correct} of {m.verdicts_with_truth} right where the truth is "
            f"known. {_mission_text(s.mission)}</p>")
    maps = (f'<p><a href="{e(s.map)}">The survey on a map</a> (pan, zoom, the sites\' '
            "orthophotos and relief models where they lie; click a site for its card)</p>"
            if s.map else "")
    maps += _img("report/field.png", "field map")
    for png in (sorted(tree.report_dir.glob("mission*.png"))
                + sorted(tree.report_dir.glob("legs*.png"))):
        kind, _, flight = png.stem.partition("_")
        what = "mission map" if kind == "mission" else "transit legs over the DEM"
        maps += _img(f"report/{png.name}", what + (f", flight {flight}" if flight else ""))
    if (tree.report_dir / "scene.png").is_file():
        maps += _img("report/scene.png", "p(mound) over the scene, candidates and tour")
    for png in sorted((tree.second_look).glob("mission*.png")):
        flight = png.stem.partition("_")[2]
        maps += _img(f"second_look/{png.name}",
                     "second-look mission" + (f", flight {flight}" if flight else ""))
    second = _second_look_text(s)
    if second:
        head += f"<p>{e(second)}</p>"
    cards = "".join(_site_card(r) for r in s.visited)
    extra = ""
    team = s.field_team
    if team:
        extra += ("<h2>For the field team</h2>\n<p>Still undecided after every look flown: "
                  "a person should see these.</p><table><tr><th class=\"l\">site</th>"
                  "<th>x, y m</th><th>p(mound)</th><th class=\"l\">why</th></tr>"
                  + "".join(f'<tr><td class="l"><a href="#site-{e(t.id)}">{e(t.id)}</a>'
                            f'</td><td>{t.x_m:.0f}, {t.y_m:.0f}</td>'
                            f'<td>{_fmt(t.p_mound)}</td><td class="l">{e(t.why)}</td>'
                            "</tr>" for t in team) + "</table>\n")
    if s.photos:
        extra += f"<h2>Photo card</h2>\n{_card_table(s.photos)}\n"
    if s.learn:
        extra += f"<h2>Learning between flights</h2>\n{_learn_table(s.learn, m)}\n"
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>mound-survey report</title>
<style>{STYLE}</style></head>
<body>
<h1>Survey report</h1>
<p class="muted">mound-survey · {e(s.created_utc)} · run {e(str(tree.root))} ·
{_wall_line(s)} · origin {e(json.dumps(s.origin.to_doc() if s.origin else None))}</p>
{head}
<h2>Error rates</h2>
{_metrics_table(m)}
<h2>Field and tour</h2>
<div class="row">{maps}</div>
{extra}<h2>Visited sites</h2>
{cards or '<p>none</p>'}
<h2>All sites</h2>
{_sites_table(s.sites)}
<h2>Stages</h2>
{_stage_table(s.stages)}
<p class="muted">Final label: the 3-D verdict where the site was visited and judged, the
classifier's (p ≥ 0.5) elsewhere. ε<sub>MD</sub>: true mounds labelled no mound;
ε<sub>FA</sub>: other sites labelled mound (the paper's definitions).</p>
<script>{CHECK_IMAGES}</script>
</body></html>
"""


def render_md(s: SurveySummary) -> str:
    m = s.metrics
    second = _second_look_text(s)
    lines = ["# Survey report", "",
             f"{s.field.source}: {s.field.sites} sites, "
             f"{s.field.true_mounds} true mounds; status **{s.status}**"
             + (f" ({s.reason})" if s.reason else ""), "",
             f"Tour: {m.visited} sites, reward {_fmt(m.reward, 2)} bits, "
             f"{_fmt(m.cost_m, 0)} m of {m.budget_m:.0f} m. 3-D verdicts: {m.judged} of "
             f"{m.visited} ({m.failed} failed), {m.verdicts_correct} of "
             f"{m.verdicts_with_truth} right." + (f" {second}" if second else ""), "",
             "| labels | eps_MD | eps_FA |", "|---|---|---|",
             *(f"| {name} | {_fmt(v.eps_md)} | {_fmt(v.eps_fa)} |"
               for name, v in (("classifier alone", m.classifier_only), ("this survey", m.survey),
                               ("perfect verification", m.perfect_verification))), "",
             "![field](report/field.png)", "", "## Visited sites", "",
             "| site | p(mound) | verdict | truth | height m | diameter m | note |",
             "|---|---|---|---|---|---|---|"]
    for r in s.visited:
        v = r.judged_verdict
        rise = (v.rise if v is not None else None) or {}
        note = ((r.row.reason if r.row is not None else "not processed") or "?"
                if r.verdict == "failed" else "")
        lines.append(f"| {r.id} | {r.p_mound:.3f} | {r.answer or r.verdict} | "
                     f"{_fmt(r.truth)} | {_fmt(rise.get('height_m'), 1)} | "
                     f"{_fmt(rise.get('base_diameter_m'), 1)} | {note} |")
    if s.field_team:
        lines += ["", "## For the field team", "", "| site | x, y m | p(mound) | why |",
                  "|---|---|---|---|"]
        lines += [f"| {t.id} | {t.x_m:.0f}, {t.y_m:.0f} | {_fmt(t.p_mound)} | "
                  f"{t.why} |" for t in s.field_team]
    if s.photos:
        card = s.photos
        lines += ["", "## Photo card", "", "| files | count |", "|---|---|"]
        lines += [f"| {k} | {n} |" for k, n in sorted(card.counts.items())]
        lines += ["", "| site | photos | blurred | status |", "|---|---|---|---|"]
        lines += [f"| {k} | {v.photos} | {v.blurred} | {v.status} |"
                  for k, v in card.sites.items()]
    if s.learn:
        lr = s.learn
        lines += ["", "## Learning between flights", "",
                  f"Held-out AUC ({lr.evaluation}): {lr.held_out_auc_before:.4f} -> "
                  f"{lr.held_out_auc_after:.4f}", "",
                  "| flight | sites | learned | held-out AUC | labels flipped |",
                  "|---|---|---|---|---|"]
        lines += [f"| {f.flight} | {' '.join(f.sites)} | {len(f.examples)} | "
                  f"{f.held_out_auc:.4f} | {f.labels_flipped} |" for f in lr.flights]
    lines += ["", "## Stages", "", "| stage | wall s | result |", "|---|---|---|"]
    for st in s.stages:
        wall = "skipped" if st.skipped else f"{st.wall_s:.1f}"
        lines.append(f"| {st.name} | {wall} | {st.note} |")
    return "\n".join(lines) + "\n"
